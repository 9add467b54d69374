"""The physical model, the hybrid's gate and learners on a real arm's recording: the TX40.

Data: ``../shared/realdata/tx40/tx40_joint.npz`` (t, q [rad], τ [N·m] on the joint side at
5 kHz, 9 s, no velocities) and its ``tx40.urdf`` (read in place, never copied). q, q' and
q'' come from a centred Savitzky-Golay fit (cubic, ``--window`` samples at 5 kHz: zero
phase, as ``scara-ident train``'s input stage estimates q''), then every 5th sample is kept
(1 kHz).

Splits (``--draws``): for draw d, 0.5 s blocks, 1 in 5 held out (``block_split``, fraction
0.2, seed d), never seen by any fit. Of the other blocks, 1 in 5 again validate (seed d + 1;
draw 0 is the split of the earlier runs); the rest (``fit``) train. As ``scara-ident train``
does, the hybrid's network early-stops on every other validation block
(``alternate_blocks``) and its gate is set on all of them, block by block.

Models (rows), per draw:

``physical``
    coupled 5-6 friction and physically consistent (pseudo-inertia LMI), Coulomb shape
    chosen on validation: ``scara-ident train --method physical --coupled joint_5,joint_6
    --consistent``, fitted on ``fit``.
``linear``, ``gp``, ``kernel``
    learners alone, on all non-held-out blocks (``fit`` and validation): linear least
    squares on [q, q', q'', sin q, cos q, tanh(q'/0.05), 1]; the exact GP (``ExactGP``,
    ``train --method gp``); the sparse-spectrum GP (``SparseSpectrumGP``, D = 1000, its
    marginal-likelihood kernel: not by default, it took over 6 minutes at load 10).
``physical + linear``, ``physical + gp``
    the physical model plus that learner fitted to its residual on ``fit``, gated on the
    validation blocks (``gate_scales``).
``hybrid, no gate`` / ``old gate`` / ``gate`` (per ``--seeds``)
    the physical model plus an FFS network (``fit_hybrid``: LM, early stop on half the
    validation blocks): its correction applied as it is; withheld per joint unless it lowers
    the error over the validation blocks and in each (the gate before this benchmark); and
    the gate of ``HybridModel.validate_gate`` (a scale in [0, 1] per joint, kept only if its
    cross-validated gain over the validation blocks passes a one-sided paired t-test at
    ``GATE_LEVEL``). Also the gate at levels 0.5 (a positive mean gain), 0.2 and 0.05, on
    blocks of 0.1 s, and the scale without a test, to show the choice.

The hybrids' corrections and residuals on the validation and held-out samples are cached
(``--cache``) so that the gates are compared on the same networks. Writes
``benchmarks/physical_real.md`` with the commit, the load average and the counts of
(draw, seed) where a gated hybrid is worse than its physical part on held-out data.

Usage::

    nice -n 5 .venv/bin/python benchmarks/bench_physical_real.py [--draws 0 1 2] \\
        [--seeds 0 1 2 3 4] [--cache /tmp/tx40-cache]
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
from scara_ident_ros.dynamics.physical_options import select_coulomb  # noqa: E402
from scara_ident_ros.learners.hybrid_model import (GATE_LEVEL, fit_hybrid,  # noqa: E402
                                                   gate_errors, gate_scales)
from scara_ident_ros.dynamics.physical_model import PhysicalModel  # noqa: E402
from scara_ident_ros.identification.dataset import Dataset  # noqa: E402
from scara_ident_ros.identification.split import (alternate_blocks, block_index,  # noqa: E402
                                                  block_split)
from scara_ident_ros.learners.exact_gp import ExactGP  # noqa: E402
from scara_ident_ros.learners.linear_features import LinearFeatures  # noqa: E402
from scara_ident_ros.learners.sparse_spectrum_gp import SparseSpectrumGP  # noqa: E402
from scara_ident_ros.nn.presets import make_network  # noqa: E402

REALDATA = ROOT.parent.parent / 'shared' / 'realdata'
DECIMATE = 5          # 5 kHz → 1 kHz
BLOCK_S = 0.5         # s, held-out and validation blocks
FRACTION = 0.2        # 1 in 5 blocks
COUPLED = [('joint_5', 'joint_6')]
#: The gates compared: label → function of (correction, residual, blocks) on validation.
Gate = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def old_gate(c: np.ndarray, r: np.ndarray, blocks: np.ndarray) -> np.ndarray:
    """The gate before: 1 where the correction lowers the MSE over all and in each block."""
    alone, fixed = gate_errors(c, r)
    keep = fixed < alone
    for label in np.unique(blocks):
        part = blocks == label
        alone, fixed = gate_errors(c[part], r[part])
        keep &= fixed < alone
    return keep.astype(np.float64)


GATES: dict[str, Gate] = {
    'no gate': lambda c, r, b: np.ones(c.shape[1]),
    'old gate': old_gate,
    'gate': lambda c, r, b: gate_scales(c, r, b),
    'gate, level 0.5': lambda c, r, b: gate_scales(c, r, b, level=0.5),
    'gate, level 0.2': lambda c, r, b: gate_scales(c, r, b, level=0.2),
    'gate, level 0.05': lambda c, r, b: gate_scales(c, r, b, level=0.05),
    'scale only': lambda c, r, b: gate_scales(c, r, np.zeros(len(c))),
    'gate, 0.1 s blocks': lambda c, r, b: gate_scales(c, r, b),  # given finer blocks
}
FINE_S = 0.1  # s, the blocks of 'gate, 0.1 s blocks'
#: Gates shown to explain the choice of the shipped one, not candidates for the best method.
DIAGNOSTIC = ('gate, level 0.5', 'gate, level 0.2', 'gate, level 0.05', 'scale only',
              'gate, 0.1 s blocks')


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


def nmse(predicted: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Held-out NMSE per joint."""
    return np.asarray(np.mean((predicted - y) ** 2, axis=0) / y.var(axis=0))


def learner(name: str) -> LinearFeatures | ExactGP | SparseSpectrumGP:
    """A fresh learner of ``name``."""
    if name == 'linear':
        return LinearFeatures()
    if name == 'gp':
        return ExactGP()
    return SparseSpectrumGP(1000)


def physical_model(urdf: Path, names: list[str], fit: Dataset, validation: Dataset,
                   cache: Path | None) -> tuple[PhysicalModel, str]:
    """``train --method physical --coupled joint_5,joint_6 --consistent`` on ``fit``."""
    if cache is not None and cache.exists():
        model = PhysicalModel.load(cache)
        return model, str(model.metadata.get('choice', ''))

    def build(coulomb: str, eps: float) -> PhysicalModel:
        return PhysicalModel.from_urdf_file(urdf, joint_names=names, coulomb=coulomb,
                                            coulomb_eps=eps, coupled=COUPLED, consistent=True)

    started = time.perf_counter()
    model, choice = select_coulomb(build, (fit.X, fit.Y), (validation.X, validation.Y))
    label = f'Coulomb {choice.label}, fit {time.perf_counter() - started:.0f} s'
    model.metadata['choice'] = np.array(label)
    if cache is not None:
        model.save(cache)
    return model, label


def hybrid_arrays(model: PhysicalModel, fit: Dataset, stop: Dataset, seed: int,
                  iterations: int, samples: dict[str, Dataset],
                  cache: Path | None) -> dict[str, np.ndarray]:
    """``train --method hybrid``'s network on ``model``'s residual: its raw correction and
    the residual on each of ``samples`` (``c_<key>``, ``r_<key>``)."""
    if cache is not None and cache.exists():
        with np.load(cache) as stored:
            return dict(stored)
    fresh = PhysicalModel.from_arrays(model.to_arrays(), source=model.source)
    network = make_network('ffs', model.n_joints, seed=seed, friction_steps=True)
    started = time.perf_counter()
    with single_blas_thread():
        out, history = fit_hybrid(fresh, network, (fit.X, fit.Y),
                                  validation=(stop.X, stop.Y), seed=seed,
                                  iterations=iterations, max_fail=50, min_iterations=50)
    arrays = {'seconds': np.array(time.perf_counter() - started),
              'best_iteration': np.array(history.best_iteration)}
    for key, data in samples.items():
        arrays[f'c_{key}'] = out.raw_correction(data.X)
        arrays[f'r_{key}'] = data.Y - out.physical.predict(data.X)
    if cache is not None:
        np.savez(cache, **arrays)
    return arrays


def row(label: str, values: np.ndarray, note: str = '') -> str:
    cells = ' | '.join(f'{v:.4f}' for v in values)
    return f'| {label} | {cells} | {note} |'


def figures(values: np.ndarray) -> str:
    return ', '.join(f'{v:.4f}' for v in values)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--draws', type=int, nargs='+', default=[0, 1, 2])
    parser.add_argument('--seeds', type=int, nargs='+', default=[0, 1, 2, 3, 4])
    parser.add_argument('--learners', nargs='*', default=['linear', 'gp'],
                        choices=['linear', 'gp', 'kernel'])
    parser.add_argument('--iterations', type=int, default=300)
    parser.add_argument('--window', type=int, default=51,
                        help='Savitzky-Golay window, samples at 5 kHz (default 51: 10 ms)')
    parser.add_argument('--cache', type=Path, default=None,
                        help='folder of fitted models and corrections to reuse')
    parser.add_argument('--out', type=Path, default=ROOT / 'benchmarks' / 'physical_real.md')
    args = parser.parse_args()
    load_before = open('/proc/loadavg').read().split()[:3]
    started = time.perf_counter()
    if args.cache is not None:
        args.cache.mkdir(parents=True, exist_ok=True)
    data, names = tx40_dataset(args.window)
    urdf = realdata() / 'tx40' / 'tx40.urdf'
    header = ('| model | ' + ' | '.join(names) + ' | note |\n|---|'
              + '---|' * len(names) + '---|')
    lines: list[str] = []
    physical: list[np.ndarray] = []  # per draw
    scores: dict[str, list[np.ndarray]] = {}  # model → per draw (mean over seeds)
    hybrids: dict[str, list[np.ndarray]] = {key: [] for key in GATES}  # per (draw, seed)
    gates: dict[str, list[np.ndarray]] = {key: [] for key in GATES}
    pairs: list[np.ndarray] = []  # the hybrid's physical part's NMSE, each (draw, seed)
    refit = 0.0  # largest relative difference of a hybrid's physical part from physical
    sizes = ''
    kept = [0, 0]  # joints the shipped gate kept, of all

    def add(label: str, values: np.ndarray, note: str = '') -> None:
        lines.append(row(label, values, note))
        print(lines[-1], flush=True)

    for draw in args.draws:
        train, held = block_split(data, FRACTION, block_s=BLOCK_S, seed=draw)
        fit, validation = block_split(train, FRACTION, block_s=BLOCK_S, seed=draw + 1)
        start_ns = int(data.stamp_ns[0])
        stop, _ = alternate_blocks(validation, block_s=BLOCK_S, start_ns=start_ns)
        blocks = block_index(validation.stamp_ns, block_s=BLOCK_S, start_ns=start_ns)
        fine = block_index(validation.stamp_ns, block_s=FINE_S, start_ns=start_ns)
        sizes = (f'fit {len(fit)}, validation {len(validation)} in '
                 f'{len(np.unique(blocks))} blocks (network stop on {len(stop)}), held out '
                 f'{len(held)}')
        print(f'draw {draw}: {sizes}', flush=True)
        cache = args.cache
        model, note = physical_model(
            urdf, names, fit, validation,
            None if cache is None else cache / f'physical_{draw}.npz')
        base = model.predict(held.X)
        physical.append(nmse(base, held.Y))
        add(f'physical, draw {draw}', physical[-1], note)
        scores.setdefault('physical', []).append(physical[-1])
        r_val = validation.Y - model.predict(validation.X)
        for name in args.learners:
            clock = time.perf_counter()
            alone = learner(name).fit(train.X, train.Y)
            scores.setdefault(name, []).append(nmse(alone.predict(held.X), held.Y))
            add(f'{name}, draw {draw}', scores[name][-1],
                f'{time.perf_counter() - clock:.0f} s')
            if name == 'kernel':
                continue
            clock = time.perf_counter()
            residual = learner(name).fit(fit.X, fit.Y - model.predict(fit.X))
            gate = gate_scales(residual.predict(validation.X), r_val, blocks)
            key = f'physical + {name}'
            scores.setdefault(key, []).append(nmse(base + gate * residual.predict(held.X),
                                                   held.Y))
            scores.setdefault(key + ', no gate', []).append(
                nmse(base + residual.predict(held.X), held.Y))
            add(f'{key}, no gate, draw {draw}', scores[key + ', no gate'][-1])
            add(f'{key}, draw {draw}', scores[key][-1],
                f'gate {figures(gate)}; {time.perf_counter() - clock:.0f} s')
        per_seed: dict[str, list[np.ndarray]] = {key: [] for key in GATES}
        for seed in args.seeds:
            arrays = hybrid_arrays(
                model, fit, stop, seed, args.iterations,
                {'val': validation, 'held': held},
                None if cache is None else cache / f'hybrid_{draw}_{seed}.npz')
            # fit_hybrid refits the physical part (the same fit; the LMI solver's tolerance)
            pairs.append(nmse(held.Y - arrays['r_held'], held.Y))
            refit = max(refit, float(np.max(np.abs(pairs[-1] / physical[-1] - 1.0))))
            kept[0] += int(np.count_nonzero(GATES['gate'](arrays['c_val'], arrays['r_val'],
                                                          blocks)))
            kept[1] += len(names)
            for key, rule in GATES.items():
                gate = rule(arrays['c_val'], arrays['r_val'],
                            fine if key == 'gate, 0.1 s blocks' else blocks)
                predicted = held.Y - arrays['r_held'] + gate * arrays['c_held']
                score = nmse(predicted, held.Y)
                hybrids[key].append(score)
                gates[key].append(gate)
                per_seed[key].append(score)
                add(f'hybrid, {key}, draw {draw}, seed {seed}', score,
                    f'gate {figures(gate)}' if key != 'no gate' else
                    f'LM best at {int(arrays["best_iteration"])}, '
                    f'{float(arrays["seconds"]):.0f} s')
        for key in GATES:
            scores.setdefault(f'hybrid, {key}', []).append(np.mean(per_seed[key], axis=0))
    load_after = open('/proc/loadavg').read().split()[:3]
    commit = subprocess.run(['git', '-C', str(ROOT), 'rev-parse', '--short', 'HEAD'],
                            capture_output=True, text=True).stdout.strip()
    means = {key: np.mean(values, axis=0) for key, values in scores.items()}
    summary = [row(key, value, f'mean of {len(args.draws)} draws'
                   + (f' × {len(args.seeds)} seeds' if key.startswith('hybrid') else ''))
               for key, value in means.items()]
    phys = np.array(pairs)
    counts = ['| gate | ' + ' | '.join(names) + ' | any joint | worst ratio to physical |',
              '|---|' + '---|' * (len(names) + 2)]
    for key in GATES:
        values = np.array(hybrids[key])
        worse = values > phys * (1 + 1e-9)
        ratio = values / phys
        counts.append(f'| {key} | ' + ' | '.join(str(int(w)) for w in worse.sum(axis=0))
                      + f' | {int(worse.any(axis=1).sum())} of {len(values)} | '
                      f'{ratio.max():.3f} ({names[int(np.argmax(ratio.max(axis=0)))]}) |')
    shipped = [key for key in means  # the diagnostic gates are not candidates
               if not any(key == f'hybrid, {gate}' for gate in DIAGNOSTIC)]
    best_key = {j: min(shipped, key=lambda k: means[k][j]) for j in range(len(names))}
    best = np.array([means[best_key[j]][j] for j in range(len(names))])
    p_mean = means['physical']
    worst = np.argsort(p_mean)[::-1][:2]
    targets = [
        '- Best method per joint (mean over draws): '
        + ', '.join(f'{names[j]} {best_key[j]} {best[j]:.4f}' for j in range(len(names)))
        + '.',
        f'- At most the physical model on every joint: **{bool(np.all(best <= p_mean))}**; '
        f'half of it on its two worst joints ({", ".join(names[j] for j in worst)}: '
        f'{figures(p_mean[worst])}, half {figures(0.5 * p_mean[worst])}): '
        f'**{bool(np.all(best[worst] <= 0.5 * p_mean[worst]))}** ({figures(best[worst])}).']
    text = '\n'.join([
        '# Physical model, hybrid gate and learners on a real arm: the Stäubli TX40', '',
        f'Generated by `nice -n 5 .venv/bin/python benchmarks/bench_physical_real.py '
        f'--draws {" ".join(map(str, args.draws))} --seeds {" ".join(map(str, args.seeds))}'
        f'` (commit {commit}; load average {" ".join(load_before)} before, '
        f'{" ".join(load_after)} after, on 2 cores shared with other jobs; '
        f'{time.perf_counter() - started:.0f} s of which fits could be cached). Timings are '
        'of a loaded machine.', '',
        f'Data: `../shared/realdata/tx40/` (5 kHz, 9 s; q\', q\'\' from a centred cubic '
        f'Savitzky-Golay fit of {args.window} samples, then 1 kHz: {len(data)} samples). '
        f'0.5 s blocks; per draw d 1 in 5 held out (seed d) and of the rest 1 in 5 validate '
        f'(seed d + 1); last draw: {sizes}. Network: FFS 18-40-6 with friction steps, '
        f'Levenberg-Marquardt up to {args.iterations} iterations (max_fail 50, '
        f'min_iterations 50), seeds {args.seeds}. The gate\'s test level: '
        f'`GATE_LEVEL` = {GATE_LEVEL:g}.', '',
        '## Hybrid worse than its physical part on held-out data', '',
        f'Count of (draw, seed) of {len(phys)} where the hybrid\'s held-out NMSE exceeds that '
        'of its own physical part, per joint (`fit_hybrid` refits the physical part: it '
        f'differs from the `physical` row by at most {refit:.1e} relative, the consistent '
        f'fit\'s solver tolerance). The gate kept the correction on {kept[0]} of {kept[1]} '
        '(draw, seed, joint).', '', *counts, '',
        '## Held-out NMSE per joint, mean', '', header, *summary, '',
        '## Targets', '',
        'Candidates: the models above but the diagnostic gates (other levels, 0.1 s '
        'blocks, scale only), chosen after the fact.', '', *targets, '',
        '## Per draw and seed', '', header, *lines, ''])
    args.out.write_text(text, encoding='utf-8')
    print(text)
    return 0


if __name__ == '__main__':
    sys.exit(main())
