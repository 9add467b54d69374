"""The physical model and the hybrid on a real arm's recording: the Stäubli TX40.

Data: ``../shared/realdata/tx40/tx40_joint.npz`` (t, q [rad], τ [N·m] on the joint side at
5 kHz, 9 s, no velocities) and its ``tx40.urdf`` (read in place, never copied). q, q' and
q'' come from a centred Savitzky-Golay fit (cubic, ``--window`` samples at 5 kHz: zero
phase, as ``scara-ident train``'s input stage estimates q''), then every 5th sample is kept
(1 kHz).

Split: 0.5 s blocks, 1 in 5 held out (``block_split``, fraction 0.2, seed 0), never seen by
any fit. Of the other blocks, 1 in 5 again validate (seed 1): the Coulomb shape is chosen
on them (``coulomb_selection``); as ``scara-ident train`` does, the hybrid's network
early-stops on every other validation block (``alternate_blocks``) and its gate is set on
all of them, block by block; the rest train.

Models (rows):

``physical (before)``
    the physical model as it was: least squares, viscous and Coulomb friction per joint,
    Coulomb shape chosen on validation.
``physical + coupled 5-6``
    with the friction of the coupled wrist motors (``coupled=[('joint_5', 'joint_6')]``).
``physical + coupled + offsets + asymmetric``
    and an effort offset and an asymmetric Coulomb term per joint.
``physical (after)``
    coupled 5-6 and physically consistent (pseudo-inertia LMI, ``consistent=True``): the
    model ``scara-ident train --method physical --coupled joint_5,joint_6`` fits.
``hybrid (before), no gate``
    physical (before) plus an FFS network on its residual (``fit_hybrid``) early-stopped on
    all validation blocks, no gate: the hybrid as it was.
``hybrid (after), no gate`` / ``gated on the other blocks`` / ``gated``
    physical (after) plus the network stopped on half the validation blocks: without a
    gate; gated on the mean error of the other validation blocks; and gated block by block
    on all validation blocks (a joint keeps its correction only if it lowers the error in
    each: the model ``train --method hybrid`` fits).

For each, the held-out NMSE per joint (MSE over the held-out efforts' variance); the
hybrids per network seed (``--seeds``) and their mean. Writes ``benchmarks/physical_real.md``
with the commit and the load average.

Usage::

    nice -n 5 .venv/bin/python benchmarks/bench_physical_real.py [--seeds 0 1 2]
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from scipy.signal import savgol_filter

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from scara_ident_ros.blas_threads import single_blas_thread  # noqa: E402
from scara_ident_ros.dynamics.coulomb_selection import select_coulomb  # noqa: E402
from scara_ident_ros.dynamics.hybrid_model import HybridModel, fit_hybrid  # noqa: E402
from scara_ident_ros.dynamics.physical_model import PhysicalModel  # noqa: E402
from scara_ident_ros.identification.dataset import Dataset  # noqa: E402
from scara_ident_ros.identification.split import (alternate_blocks, block_index,  # noqa: E402
                                                  block_split)
from scara_ident_ros.nn.presets import make_network  # noqa: E402

REALDATA = ROOT.parent.parent / 'shared' / 'realdata'
DECIMATE = 5          # 5 kHz → 1 kHz
BLOCK_S = 0.5         # s, held-out and validation blocks
FRACTION = 0.2        # 1 in 5 blocks
COUPLED = [('joint_5', 'joint_6')]


def realdata() -> Path:
    """The shared real recordings (``$SCARA_REALDATA`` or ``../shared/realdata``)."""
    path = Path(os.environ.get('SCARA_REALDATA', REALDATA))
    if not (path / 'tx40' / 'tx40_joint.npz').exists():
        path = Path('/work/shared/realdata')
    return path


def tx40_dataset(window: int) -> tuple[Dataset, list[str]]:
    """The TX40 recording with q' and q'' from a centred cubic Savitzky-Golay fit, 1 kHz."""
    data = np.load(realdata() / 'tx40' / 'tx40_joint.npz')
    t, q, tau = data['t'], data['q'], data['tau']
    dt = float(np.median(np.diff(t)))
    fitted = [savgol_filter(q, window, 3, deriv=d, delta=dt, axis=0) for d in (0, 1, 2)]
    keep = slice(window, q.shape[0] - window, DECIMATE)  # the fit's edges left out
    X = np.hstack(fitted)[keep]
    stamps = np.round(t[keep] * 1e9).astype(np.int64)
    return Dataset(stamps, X, tau[keep], acceleration='estimated', name='tx40'), \
        [str(name) for name in data['names']]


def nmse(predict: Callable[[np.ndarray], np.ndarray], data: Dataset) -> np.ndarray:
    """Held-out NMSE per joint."""
    return np.asarray(np.mean((predict(data.X) - data.Y) ** 2, axis=0) / data.Y.var(axis=0))


def physical(urdf: Path, names: list[str], fit: Dataset, validation: Dataset,
             **options: object) -> tuple[PhysicalModel, str, float]:
    """A physical model of ``options``, Coulomb shape chosen on validation; fit seconds."""
    def build(coulomb: str, eps: float) -> PhysicalModel:
        return PhysicalModel.from_urdf_file(urdf, joint_names=names, coulomb=coulomb,
                                            coulomb_eps=eps, **options)  # type: ignore[arg-type]

    started = time.perf_counter()
    model, choice = select_coulomb(build, (fit.X, fit.Y), (validation.X, validation.Y))
    return model, choice.label, time.perf_counter() - started


def hybrid(model: PhysicalModel, fit: Dataset, validation: Dataset, seed: int,
           iterations: int) -> HybridModel:
    """``train --method hybrid``'s fit on ``model``'s options and Coulomb shape."""
    fresh = PhysicalModel.from_arrays(model.to_arrays(), source=model.source)
    network = make_network('ffs', model.n_joints, seed=seed, friction_steps=True)
    with single_blas_thread():
        out, _ = fit_hybrid(fresh, network, (fit.X, fit.Y),
                            validation=(validation.X, validation.Y),
                            seed=seed,
                            iterations=iterations, max_fail=50, min_iterations=50)
    return out


def row(label: str, values: np.ndarray, note: str = '') -> str:
    cells = ' | '.join(f'{v:.4f}' for v in values)
    return f'| {label} | {cells} | {note} |'


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--seeds', type=int, nargs='+', default=[0, 1, 2])
    parser.add_argument('--iterations', type=int, default=300)
    parser.add_argument('--window', type=int, default=51,
                        help='Savitzky-Golay window, samples at 5 kHz (default 51: 10 ms)')
    parser.add_argument('--out', type=Path, default=ROOT / 'benchmarks' / 'physical_real.md')
    args = parser.parse_args()
    load_before = open('/proc/loadavg').read().split()[:3]
    started = time.perf_counter()
    data, names = tx40_dataset(args.window)
    urdf = realdata() / 'tx40' / 'tx40.urdf'
    train, held = block_split(data, FRACTION, block_s=BLOCK_S, seed=0)
    fit, validation = block_split(train, FRACTION, block_s=BLOCK_S, seed=1)
    stop, gate_set = alternate_blocks(validation, block_s=BLOCK_S,
                                      start_ns=int(data.stamp_ns[0]))
    print(f'TX40: {len(data)} samples at 1 kHz; fit {len(fit)}, validation {len(validation)}, '
          f'held out {len(held)}; network stop {len(stop)}, gate {len(gate_set)}', flush=True)
    header = ('| model | ' + ' | '.join(names) + ' | note |\n|---|'
              + '---|' * len(names) + '---|')
    lines: list[str] = []
    variants = {
        'physical (before)': {},
        'physical + coupled 5-6': {'coupled': COUPLED},
        'physical + coupled + offsets + asymmetric': {'coupled': COUPLED, 'offsets': True,
                                                      'asymmetric': True},
        'physical (after)': {'coupled': COUPLED, 'consistent': True},
    }
    models: dict[str, PhysicalModel] = {}
    scores: dict[str, np.ndarray] = {}
    for label, options in variants.items():
        model, shape, seconds = physical(urdf, names, fit, validation, **options)
        models[label], scores[label] = model, nmse(model.predict, held)
        lines.append(row(label, scores[label], f'Coulomb {shape}, fit {seconds:.1f} s'))
        print(lines[-1], flush=True)
    hybrids: dict[str, list[np.ndarray]] = {'hybrid (before), no gate': [],
                                            'hybrid (after), no gate': [],
                                            'hybrid (after), gated on the other blocks': [],
                                            'hybrid (after), gated': []}
    for seed in args.seeds:
        before = hybrid(models['physical (before)'], fit, validation, seed, args.iterations)
        before.gate = np.ones(before.n_outputs)
        after = hybrid(models['physical (after)'], fit, stop, seed, args.iterations)
        after.validate_gate(validation.X, validation.Y, groups=block_index(
            validation.stamp_ns, block_s=BLOCK_S, start_ns=int(data.stamp_ns[0])))
        gate = after.gate.copy()
        results = {'hybrid (before), no gate': (before, None)}
        after.gate = np.ones(after.n_outputs)
        results['hybrid (after), no gate'] = (after, None)
        results['hybrid (after), gated'] = (after, gate)
        other = HybridModel(after.physical, after.network)
        other.bounds = after.bounds
        other.validate_gate(gate_set.X, gate_set.Y)
        results['hybrid (after), gated on the other blocks'] = (other, other.gate)
        for key in hybrids:
            model, chosen = results[key]
            if chosen is not None:
                model.gate = chosen
            hybrids[key].append(nmse(model.predict, held))
            note = '' if chosen is None else 'gate ' + ''.join(str(int(g)) for g in chosen)
            lines.append(row(f'{key}, seed {seed}', hybrids[key][-1], note))
            print(lines[-1], flush=True)
    means = {key: np.mean(values, axis=0) for key, values in hybrids.items()}
    worst = {key: np.max(values, axis=0) for key, values in hybrids.items()}
    after = scores['physical (after)']
    summary = [row(label, scores[label]) for label in variants]
    summary += [row(f'{key}, mean of {len(args.seeds)} seeds', means[key],
                    f'worst seed per joint: {", ".join(f"{v:.4f}" for v in worst[key])}')
                for key in hybrids]
    gated = np.array(hybrids['hybrid (after), gated'])
    never_worse = bool(np.all(gated <= after[None, :] * (1 + 1e-12)))
    best = np.minimum(after, means['hybrid (after), gated'])
    before = scores['physical (before)']
    worst_joint = int(np.argmax(before))
    load_after = open('/proc/loadavg').read().split()[:3]
    commit = subprocess.run(['git', '-C', str(ROOT), 'rev-parse', '--short', 'HEAD'],
                            capture_output=True, text=True).stdout.strip()
    def figures(values: np.ndarray) -> str:
        return ', '.join(f'{v:.4f}' for v in values)

    half = bool(best[worst_joint] <= 0.5 * before[worst_joint])
    worst_after = int(np.argmax(after))
    half_after = bool(best[worst_after] <= 0.5 * after[worst_after])
    targets = [
        f'- Hybrid (gated) never worse than its physical part on any held-out joint, every '
        f'seed: **{never_worse}**.',
        f'- Best of physical (after) and the gated hybrid (mean) per joint: {figures(best)}.',
        f'  Against physical (before), {figures(before)}: at most it on every joint: '
        f'**{bool(np.all(best <= before))}**; at most half of it on its worst joint '
        f'({names[worst_joint]}, {before[worst_joint]:.4f}): **{half}** '
        f'({best[worst_joint]:.4f}).',
        f'  Against physical (after): half of it on its worst joint ({names[worst_after]}, '
        f'{after[worst_after]:.4f}): **{half_after}** ({best[worst_after]:.4f}).']
    text = '\n'.join([
        '# Physical model and hybrid on a real arm: the Stäubli TX40', '',
        f'Generated by `benchmarks/bench_physical_real.py` (commit {commit}; load average '
        f'{" ".join(load_before)} before, {" ".join(load_after)} after, on 2 cores shared '
        f'with other jobs; {time.perf_counter() - started:.0f} s). Timings are of a loaded '
        'machine.', '',
        f'Data: `../shared/realdata/tx40/` (5 kHz, 9 s; q\', q\'\' from a centred cubic '
        f'Savitzky-Golay fit of {args.window} samples, then 1 kHz: {len(data)} samples). '
        f'0.5 s blocks, 1 in 5 held out ({len(held)} samples, never fitted); of the rest 1 '
        f'in 5 validate ({len(validation)}: the Coulomb shape; the network\'s early stop on '
        f'every other block, {len(stop)}; the gate on all, block by block), '
        f'{len(fit)} train. Network: FFS 18-40-6 with friction steps, Levenberg-Marquardt up '
        f'to {args.iterations} iterations (max_fail 50, min_iterations 50), seeds '
        f'{args.seeds}.', '',
        '## Held-out NMSE per joint', '', header, *summary, '',
        'Per model and seed:', '', header, *lines, '',
        '## Targets', '', *targets, ''])
    args.out.write_text(text, encoding='utf-8')
    print(text)
    return 0


if __name__ == '__main__':
    sys.exit(main())
