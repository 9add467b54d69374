"""``scara-ident train`` settings against the error on excitations never trained on.

Writes a bag of 80 s of the simulated SCARA (1 kHz, no noise) and reads it back as
``scara-ident train`` does (same samples, same q'' estimate), then trains FFS networks under
several settings and evaluates each on held-out excitations: 4 further 'standard'
excitations of 10 s (seeds 1000-1003, q'' estimated the same way), never trained on.

Recordings (``--data``):

``standard8``
    8 'standard' excitations of 10 s (seeds 0-7, each two periods of its 5 s curve),
    1 s apart so that the q'' estimate restarts between them.
``sequence80``
    80 s of the 'sequence' trajectory (seed 7): a new excitation every 5 s, blended; what
    ``scara-ident run`` records by default.

Settings (``--config``, repeatable; default: the old and the new defaults):

``old``
    the defaults before block validation: the last 20 % of the time validates, early stop
    after 6 failures, all samples, 315 iterations, no friction steps.
``new``
    ``scara-ident train``'s defaults now (imported from it), friction steps included.
``NAME:KEY=VALUE,...``
    anything else, keys ``split`` (time, blocks, none), ``samples``, ``iterations``,
    ``max_fail``, ``min_iterations``, ``friction_steps`` (1: the network starts with the
    identifier's friction steps, ``make_network(friction_steps=True)``, 0: all random);
    unnamed keys take the new defaults.

Each setting is run from ``--seeds`` initial weights (seed of the weights, of the block
draw and of the sample draw, as ``--seed`` does in ``train``). One Markdown row per run:
held-out NMSE per joint, iterations (that of the weights kept), why it stopped, the
training wall time with BLAS on one thread, and the load average. ``--cli`` also runs the
``scara-ident train`` command itself with its defaults (the figures must equal ``new``
seed 0's, except for the time).

Measured on 2 shared cores (load 2.5-5), seeds 0, 1, 2: the worst joint's held-out NMSE
(joint 2 in most runs) and the training time::

    sequence80  old defaults  1.0e-3  2.0e-3  0.57     35-212 s
                new defaults  6.3e-4  6.8e-5  7.6e-4   28-49 s
    standard8   old defaults  0.32    0.39    0.26     9-13 s
                new defaults  0.74    0.71    1.4      8-29 s

Friction steps (2026-12-02, load 1-2; before them the defaults had none; seeds 0-5, the
worst joint, median [range])::

    sequence80  no steps        7.0e-4 [6.8e-5-0.079]   (seeds 3, 4: 0.079, 4.1e-3)
                steps, 4 widths 3.0e-4 [1.3e-4-4.5e-3]
                steps, 5 widths 3.0e-4 [1.3e-4-8.9e-4]  (the default, 15-45 s)
    standard8   no steps        0.87 [0.39-1.4]
                steps, 4 widths 7.3e-4 [3.0e-4-0.15]
                steps, 5 widths 2.2e-4 [1.1e-4-0.013]

so ``train`` starts with them too. With no validation split (``split=none``) standard8
without steps stays at 1.4-1.6 (seeds 0-2): the early stop is not what fails there.

Why the worst joint misses 1e-4 (measured 2026-12-02, seed 0): 33 % of the held-out samples
have some input beyond the range of the 80 s recording (joint 2's speed reaches 8.9 rad/s
in them, 6.2 rad/s in the recording: a sequence spends most of each segment in a blend of
two excitations, smaller than either), and they carry 66 % of joint 2's squared error;
on the held-out samples inside the range joint 2 is at 3.2e-4. The validation blocks
(worst joint 2.7e-5 to 1.8e-4) do not show it: they interpolate the same excitations.
Tried, not adopted (seeds 0, 1, 2 of the split and sample draw):

- the best of 3 initial weights by validation NMSE: held-out worst joint 3.5e-4, 6.8e-5,
  6.0e-4 (one run with validation 4.4e-5 had held-out 2.9e-3: validation does not rank
  what it cannot see);
- sequences that blend over the last half (last quarter) of each segment only: 29 % (25 %)
  of the held-out samples outside the range, worst joint 7.1e-4, 1.6e-4, 0.12
  (9.2e-4, 3.8e-4, 0.078);
- the friction steps (adopted, above) lower joint 4 and the median seed, not the range:
  joint 2, the worst in most seeds, stays above 1e-4;
- the inputs and outputs scaled by the robot's limits, as the identifier does, instead of
  the data's ranges (seeds 0-5, friction steps): 5.9e-4 [1.3e-4-0.024], worse;
- training longer (seeds 0-3, friction steps): 1,000 iterations keeping the best
  validation weights, 1.5e-3, 1.4e-4, 1.7e-3, 3.2e-4; 1,000 iterations without a
  validation split, 4.3e-4, 3.1e-4, 0.014, 0.014. More fitting of the recording makes
  the extrapolation worse, not better;
- more samples, 24,000 instead of 8,000 (seeds 0-2): 3.1e-4, 1.3e-4, 4.3e-3, 67-90 s;
- mini-batch LM, as the identifier steps online: each step on a fresh draw of 4,000
  training samples, float32 normal equations (2026-12-02, seeds 0-5): sequence80 after
  2,400 steps (70 s) 3.6e-4, 2.5e-4, 8.1e-4, 1.2e-4, 1.1e-4, 7.3e-4, median 3.1e-4, as
  the default; standard8 after 1,200 steps 0.011, 2.5e-4, 0.22, 1.4e-4, 2.1e-3, 1.7e-3,
  worse than the default;
- a wider sequence, its excitations at the standard preset's fractions (0.8 instead of
  0.76, blends checked against 0.95 of the limits; seeds 0-5): 7.9e-4, 8.6e-5, 7.2e-4,
  3.7e-4, 2.0e-4, 1.9e-4, median 2.9e-4, as the default.

On the learning curves' held-out set (``learning_curves.held_out_set``: 5 standard
excitations of 6 s and 30 s of sequence), where the identifier reaches 5.7e-5 online after
120 s and 8.7e-5 [5.2e-5-2.0e-4] after 90 s, the defaults on sequence80 give 8.5e-4,
3.8e-4, 3.8e-4, 1.8e-4 (seeds 0, 3, 4, 5) and the mini-batch LM 2.9e-4, 3.9e-5, 3.7e-4,
6.9e-5, 6.5e-5, 1.6e-4 (seeds 0-5): a fit of 80 s is behind the stream's 90-120 s on the
motions it has to extrapolate to, whichever way it is trained.

More recording helps, not more fitting: the defaults on 120 s of the same sequence (seed 7)
give 1.5e-4, 2.1e-4, 7.5e-5, 3.6e-4, 9.6e-5, 1.3e-4 (seeds 0-5, median 1.4e-4; 2 of 6
at or below 1e-4), against 3.0e-4 [1.3e-4-8.9e-4] on 80 s.

The issue's own recipe (no validation split, 8,000 samples, 315 iterations, all-random
weights), reported there at 2e-5 on 8 excitations of another SCARA, is not reproduced
on ``other_scara.yaml``'s standard8 (held out: 4 of its standard excitations, seeds
1000-1003; seeds 0-5): 0.59, 0.70, 1.5, 8.6, 0.90, 0.88; with the friction steps 2.3e-3,
6.5e-3, 1.9e-3, 1.5e-4, 3.1e-4, 0.049; the defaults 0.056, 4.5e-4, 0.036, 0.39, 7.8e-4,
1.4e-4. Joint 2 is the worst in all but one run.

Usage::

    .venv/bin/python benchmarks/bench_train_defaults.py --data sequence80 --cli
    .venv/bin/python benchmarks/bench_train_defaults.py --data standard8 \\
        --config 'more:iterations=1000' --seeds 0 1
"""
from __future__ import annotations

import argparse
import contextlib
import io
import os
import re
import statistics
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / 'test' / 'bag'))  # fake_bags: the tests' bag writer

from fake_bags import States, write_rosbag  # noqa: E402

from scara_ident_ros.cli import main  # noqa: E402
from scara_ident_ros.cli import train as train_cli  # noqa: E402
from scara_ident_ros.dynamics import ScaraParams  # noqa: E402
from scara_ident_ros.identification.dataset import Dataset  # noqa: E402
from scara_ident_ros.paper.datasets import simulate_dataset, simulate_record  # noqa: E402
from scara_ident_ros.nn.presets import make_network  # noqa: E402
from scara_ident_ros.nn import FeedForwardNet, fit  # noqa: E402
from scara_ident_ros.blas_threads import single_blas_thread  # noqa: E402
from scara_ident_ros.cli.evaluation import evaluate  # noqa: E402
from scara_ident_ros.identification.recording import load_recording  # noqa: E402
from scara_ident_ros.identification.split import (VALIDATION_BLOCK_S,  # noqa: E402
                                                   block_split)

NAMES = ('joint1', 'joint2', 'joint3', 'joint4')
START_NS = 1_700_000_000_000_000_000
METHOD = 'ffs'


@dataclass(frozen=True)
class Setting:
    """How ``train`` splits, samples and stops."""

    split: str = 'blocks'            # 'blocks', 'time' or 'none'
    samples: int = train_cli.SAMPLES
    iterations: int = train_cli.ITERATIONS
    max_fail: int = train_cli.MAX_FAIL
    min_iterations: int = train_cli.MIN_ITERATIONS
    friction_steps: int = int(train_cli.FRICTION_STEPS)  # 1: make_network(friction_steps=True)

    def text(self) -> str:
        return (f'{self.split}, {self.samples or "all"} samples, {self.iterations} it, '
                f'stop {self.min_iterations}+{self.max_fail}'
                + (', friction steps' if self.friction_steps else ''))


SETTINGS = {
    'old': Setting(split='time', samples=0, iterations=315, max_fail=6, min_iterations=0,
                   friction_steps=0),
    'new': Setting(),
}


def parse_setting(spec: str) -> tuple[str, Setting]:
    """``'old'``, ``'new'`` or ``'NAME:key=value,...'``."""
    if spec in SETTINGS:
        return spec, SETTINGS[spec]
    name, _, body = spec.partition(':')
    values: dict[str, object] = {}
    for item in filter(None, body.split(',')):
        key, _, value = item.partition('=')
        values[key.strip()] = value.strip() if key.strip() == 'split' else int(value)
    return name, replace(Setting(), **values)  # type: ignore[arg-type]


def write_recording(path: Path, params: ScaraParams, data: str) -> Path:
    """The bag of ``data`` (see the module docstring), written once."""
    if path.exists():
        return path
    if data == 'standard8':
        records = [simulate_record(params, seconds=10.0, seed=seed) for seed in range(8)]
    else:
        records = [simulate_record(params, seconds=80.0, seed=7, preset='sequence')]
    parts = []
    offset = START_NS
    for rec in records:
        stamps = rec.stamp_ns - rec.stamp_ns[0] + offset
        parts.append((stamps, rec.q, rec.qd, rec.effort))
        offset = int(stamps[-1]) + 1_000_000_000
    stamps, q, qd, effort = (np.concatenate(arrays) for arrays in zip(*parts))
    return write_rosbag(path, States(stamps, NAMES, q, qd, effort), storage='mcap')


def time_split(data: Dataset, validation_fraction: float) -> tuple[Dataset, Dataset]:
    """The split tried before blocks: the last ``validation_fraction`` of the time validates.

    Parameters
    ----------
    data : Dataset
        Samples in time order.
    validation_fraction : float
        Fraction in [0, 1) of the time span, from its end, kept for validation.

    Returns
    -------
    train, validation : Dataset
        Samples stamped before, and from, ``t_0 + (1 - fraction)·(t_N − t_0)``, named
        ``'train'`` and ``'validation'``; ``validation`` is empty when the fraction is 0 and
        has at least one sample otherwise.
    """
    if not 0.0 <= validation_fraction < 1.0:
        raise ValueError(f'validation fraction must be in [0, 1), got {validation_fraction}')
    n = len(data)
    if n == 0 or validation_fraction == 0.0:
        return data.take(slice(None), 'train'), data.take(slice(0, 0), 'validation')
    t0, t1 = int(data.stamp_ns[0]), int(data.stamp_ns[-1])
    split_ns = t0 + round((1.0 - validation_fraction) * (t1 - t0))
    cut = min(int(np.searchsorted(data.stamp_ns, split_ns, side='left')), n - 1)
    return data.take(slice(0, cut), 'train'), data.take(slice(cut, None), 'validation')


def train_once(data: Dataset, setting: Setting, seed: int
               ) -> tuple[FeedForwardNet, dict[str, object]]:
    """What ``scara-ident train`` does with ``setting`` and ``--seed seed``."""
    if setting.split == 'blocks':
        train, val = block_split(data, 0.2, block_s=VALIDATION_BLOCK_S, seed=seed)
    elif setting.split == 'time':
        train, val = time_split(data, 0.2)
    else:
        train, val = data, data.take(slice(0, 0))
    if setting.samples:
        train = train.subsample(setting.samples, seed=seed)
    network = make_network(METHOD, data.n_joints, seed=seed,
                           friction_steps=bool(setting.friction_steps))
    started = time.perf_counter()
    with single_blas_thread():
        history = fit(network, train.X, train.Y, iterations=setting.iterations,
                      validation=(val.X, val.Y) if len(val) else None,
                      max_fail=setting.max_fail,
                      min_iterations=setting.min_iterations)
    return network, {'iterations': history.iterations, 'best': history.best_iteration,
                     'stop': history.stop_reason, 'seconds': time.perf_counter() - started}


def run_cli(bag: Path, model: Path) -> dict[str, object]:
    """``scara-ident train BAG --method ffs --out MODEL``, its defaults."""
    out = io.StringIO()
    started = time.perf_counter()
    with contextlib.redirect_stdout(out), open(os.devnull, 'w') as null, \
            contextlib.redirect_stderr(null):
        code = main(['train', str(bag), '--method', METHOD, '--out', str(model)])
    seconds = time.perf_counter() - started
    text = out.getvalue()
    found = re.search(r'(\d+) iterations in [\d.]+ s \(stopped: (\w+); weights of '
                      r'iteration (\d+)\)', text)
    if code != 0 or found is None:
        raise SystemExit(f'scara-ident train failed:\n{text}')
    return {'iterations': int(found[1]), 'stop': found[2], 'best': int(found[3]),
            'seconds': seconds}


def row(label: str, what: str, seed: int | str, nmse: np.ndarray,
        info: dict[str, object]) -> str:
    cells = ' | '.join(f'{v:.1e}' for v in nmse)
    return (f'| {label} | {what} | {seed} | {cells} | {float(np.max(nmse)):.1e} | '
            f'{info["iterations"]} ({info["best"]}) | {info["stop"]} | '
            f'{float(info["seconds"]):.0f} | {os.getloadavg()[0]:.1f} |')  # type: ignore


def main_bench() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--data', choices=('standard8', 'sequence80'), default='sequence80')
    parser.add_argument('--config', action='append', default=None, metavar='SETTING')
    parser.add_argument('--seeds', type=int, nargs='+', default=[0, 1, 2])
    parser.add_argument('--cli', action='store_true',
                        help='also run scara-ident train with its defaults')
    parser.add_argument('--out', type=Path, default=ROOT / 'out' / 'bench_train')
    args = parser.parse_args()
    params = ScaraParams.from_yaml(ROOT / 'config' / 'scara.yaml')
    args.out.mkdir(parents=True, exist_ok=True)
    bag = write_recording(args.out / args.data, params, args.data)
    data = load_recording(bag).samples.data
    sets = [simulate_dataset(params, seconds=10.0, seed=1000 + i, acceleration='estimated')
            for i in range(4)]
    held_x, held_y = np.vstack([d.X for d in sets]), np.vstack([d.Y for d in sets])
    print(f'{args.data}: {bag}, {len(data)} samples over {data.seconds:.1f} s; held out: '
          f'4 standard excitations of 10 s (seeds 1000-1003), {held_x.shape[0]} samples\n')
    print('| setting | split, samples, iterations, stop | seed | held-out NMSE joint1 | '
          'joint2 | joint3 | joint4 | worst joint | iterations (kept) | stopped | '
          'time (s) | load |')
    print('|---|---|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|')
    for spec in args.config or ['old', 'new']:
        name, setting = parse_setting(spec)
        worst = []
        for seed in args.seeds:
            network, info = train_once(data, setting, seed)
            nmse = evaluate(network, held_x, held_y).nmse
            worst.append(float(np.max(nmse)))
            print(row(name, setting.text(), seed, nmse, info), flush=True)
        print(f'| {name} | median of the worst joint over seeds: '
              f'{statistics.median(worst):.1e} |||||||||||', flush=True)
    if args.cli:
        model = args.out / f'{args.data}_cli.npz'
        info = run_cli(bag, model)
        nmse = evaluate(FeedForwardNet.load(model), held_x, held_y).nmse
        print(row('scara-ident train (defaults)', 'the command, whole run', 0, nmse, info))


if __name__ == '__main__':
    main_bench()
