"""Learners on real arms' recordings against the published numbers (``../shared/realdata``).

Reads the recordings directly with numpy (the README there describes them) and scores each
learner on each data set's held-out part:

``wam``
    Barrett WAM, the published split: 12,000 training rows, 3,000 test rows; the kernel's
    hyperparameters from ``X_hyper`` (every 10th training row, as published). Against
    GP 0.00159, sparse GP 0.00559, LWPR 0.0341 (SMSE, variance-weighted over the joints).
``sarcos``
    SARCOS, the official *test* set alone (4,449 rows, the train set is not included):
    its first 75 % learn, the last 25 % score (a split in time, not the published one).
``tiago``
    TIAGo torso and arm_1–4 (the joints that carry torque), 100 Hz; q'' a centred
    derivative of q' on the uneven stamps (``np.gradient``); 1 s blocks, one in five held
    out (spread over the run as ``block_split`` draws them, seed 0); also ``tiago70``: the
    first 70 % learn, the last 30 % score (extrapolation).
``tx40``
    Stäubli TX40 at 5 kHz, no velocities: q low-passed (zero-phase 4th-order Butterworth,
    ``--tx40-cutoff`` Hz), q' and q'' its centred differences, every 5th sample kept
    (1 kHz; τ as measured); 0.5 s blocks, one in five held out.

Learners (``--methods``):

``linear``
    least squares on [q, q', q'', sin q, cos q, tanh(q'/0.05), 1] of the modelled joints.
``kernel``
    the sparse-spectrum GP (``SparseSpectrumGP``, ``--features`` features, one kernel per
    joint) fitted on every training row (batch solution).
``online``
    the same, learnt one sample at a time in the recording's order (``partial_fit``, each
    sample predicted before it is learnt), then frozen and scored on the held-out part; its
    kernel (hyperparameters) is the offline one's.
``gp``
    an exact GP with the same kernel on every training row (``--gp-rows`` at most).
``ffs``
    the FFS network as ``scara-ident train`` trains it (21-40-7 for 7 joints, friction
    steps, Levenberg–Marquardt, early stop on a tenth of the training rows / blocks), with
    ``--ffs-iterations``.

Scores: NMSE per joint (MSE / variance of the held-out effort) and SMSE (sum of squared
errors over the joints / sum of squared deviations: the WAM's published figure). The
kernel's hyperparameters are fitted once per data set by an exact GP's marginal likelihood on
``--hyper-samples`` training rows and kept in ``--cache`` (delete it to refit).

    nice -n 5 .venv/bin/python benchmarks/bench_realdata.py [--data wam tiago ...]
        [--methods linear kernel online gp] [--features 1000] [--out benchmarks/realdata.md]
"""
from __future__ import annotations

import argparse
import os
import subprocess
import time
from collections.abc import Callable
from pathlib import Path
from typing import NamedTuple

import numpy as np
from scipy.linalg import cho_factor, cho_solve
from scipy.signal import butter, filtfilt

from scara_ident_ros.blas_threads import single_blas_thread
from scara_ident_ros.learners import SparseSpectrumGP
from scara_ident_ros.learners.ard_hyperparameters import (ArdHyperparameters,
                                                          fit_ard_hyperparameters)

REALDATA = Path(__file__).resolve().parents[2] / 'shared' / 'realdata'
if not REALDATA.exists():
    REALDATA = Path('/work/shared/realdata')
TIAGO_JOINTS = ('torso_lift_joint', 'arm_1_joint', 'arm_2_joint', 'arm_3_joint',
                'arm_4_joint')
#: Published and reference figures, quoted beside ours.
PUBLISHED = {
    'wam': 'SMSE: GP 0.00159, sparse GP 0.00559, LWPR 0.0341, linear (README) 0.154; '
           'FFS 21-40-7 (issue 25) 0.048',
    'sarcos': 'joint 1 SMSE on the full 44,484-row train set (not comparable: another '
              'split): GP 0.011, LWPR 0.040, rigid-body 0.104, linear 0.075',
    'tiago': 'issue 25: linear 0.48, 0.16, 0.14, 0.070, 0.032; FFS 0.69, 0.61, 0.17, 0.15, '
             '0.070; target: half of linear per joint',
    'tiago70': 'issue 25: FFS 0.66-4.9',
    'tx40': 'issue 25 (q\' by np.gradient): physical 0.035-0.245, hybrid 0.030-0.318, '
            'FFS 0.17-1.31',
}


class Split(NamedTuple):
    """A data set's training rows (in time order) and held-out rows."""

    name: str
    joints: tuple[str, ...]
    X: np.ndarray
    Y: np.ndarray
    Xt: np.ndarray
    Yt: np.ndarray
    hyper_rows: np.ndarray | None  # rows for the hyperparameters (None: drawn)
    note: str


def block_mask(t: np.ndarray, block_s: float, fraction: float = 0.2,
               seed: int = 0) -> np.ndarray:
    """Held-out rows: ``block_split``'s draw (one block per stratum) on stamps t [s]."""
    blocks = np.floor((t - t[0]) / block_s).astype(np.int64)
    present = np.unique(blocks)
    k = len(present)
    m = min(max(1, round(fraction * k)), k - 1)
    edges = (np.arange(m + 1) * k) // m
    chosen = present[np.random.default_rng(seed).integers(edges[:-1], edges[1:])]
    return np.isin(blocks, chosen)


def load_wam() -> Split:
    d = np.load(REALDATA / 'barrett_wam.npz')
    x = d['X_train']
    hyper = np.nonzero(np.isin(x, d['X_hyper']).all(axis=1))[0]
    return Split('wam', tuple(f'joint {j + 1}' for j in range(7)), x, d['Y_train'],
                 d['X_test'], d['Y_test'], hyper if len(hyper) == len(d['X_hyper']) else None,
                 'published split: 12,000 training rows, 3,000 test rows')


def load_sarcos(fraction: float = 0.75) -> Split:
    d = np.load(REALDATA / 'sarcos_test.npz')
    x, y = d['X'], d['Y']
    cut = int(fraction * len(x))
    return Split('sarcos', tuple(f'joint {j + 1}' for j in range(7)), x[:cut], y[:cut],
                 x[cut:], y[cut:], None,
                 f'the official test set alone, in time: first {cut} rows learn, last '
                 f'{len(x) - cut} score (not the published split)')


def tiago_arrays() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """t (N,), X (N, 15) = [q, q', q''] and Y (N, 5) of TIAGo's torque-carrying joints."""
    cols = {}
    for kind in ('position', 'velocity', 'effort'):
        table = np.genfromtxt(REALDATA / 'tiago' / f'tiago_{kind}.csv', delimiter=',',
                              names=True)
        cols[kind] = np.column_stack([table[f'_{j}_{kind}'] for j in TIAGO_JOINTS])
        t = table['t']
    q, qd, tau = cols['position'], cols['velocity'], cols['effort']
    qdd = np.gradient(qd, t, axis=0)  # centred on uneven stamps
    return t, np.hstack([q, qd, qdd]), tau, qd


def load_tiago() -> Split:
    t, x, y, _ = tiago_arrays()
    held = block_mask(t, 1.0)
    return Split('tiago', TIAGO_JOINTS, x[~held], y[~held], x[held], y[held], None,
                 f'1 s blocks, {held.sum()} of {len(t)} rows in '
                 f'{len(np.unique(np.floor(t[held])))} blocks held out (seed 0)')


def load_tiago70() -> Split:
    t, x, y, _ = tiago_arrays()
    cut = int(0.7 * len(t))
    return Split('tiago70', TIAGO_JOINTS, x[:cut], y[:cut], x[cut:], y[cut:], None,
                 f'first 70 % ({t[cut]:.1f} s) learn, the rest scores: extrapolation')


def load_tx40(cutoff_hz: float = 20.0, keep_every: int = 5) -> Split:
    d = np.load(REALDATA / 'tx40' / 'tx40_joint.npz')
    t, q, tau = d['t'], d['q'], d['tau']
    rate = 1.0 / np.median(np.diff(t))
    b, a = butter(4, cutoff_hz / (rate / 2.0))
    qf = filtfilt(b, a, q, axis=0)
    qd = np.gradient(qf, t, axis=0)
    qdd = np.gradient(qd, t, axis=0)
    keep = slice(None, None, keep_every)
    t, x, y = t[keep], np.hstack([qf, qd, qdd])[keep], tau[keep]
    held = block_mask(t, 0.5)
    names = tuple(str(s) for s in d['names'])
    return Split('tx40', names, x[~held], y[~held], x[held], y[held], None,
                 f'q low-passed at {cutoff_hz:g} Hz (zero phase), q\', q\'\' centred, '
                 f'{rate / keep_every:.0f} Hz; 0.5 s blocks, {held.sum()} of {len(t)} rows '
                 'held out (seed 0)')


LOADERS: dict[str, Callable[[], Split]] = {
    'wam': load_wam, 'sarcos': load_sarcos, 'tiago': load_tiago, 'tiago70': load_tiago70,
    'tx40': load_tx40}


def linear_features(x: np.ndarray) -> np.ndarray:
    n = x.shape[1] // 3
    q, qd = x[:, :n], x[:, n:2 * n]
    return np.hstack([x, np.sin(q), np.cos(q), np.tanh(qd / 0.05), np.ones((len(x), 1))])


def run_linear(s: Split, _: argparse.Namespace) -> tuple[np.ndarray, str]:
    coef, *_ = np.linalg.lstsq(linear_features(s.X), s.Y, rcond=None)
    return linear_features(s.Xt) @ coef, ''


def hyperparameters(s: Split, args: argparse.Namespace) -> tuple[ArdHyperparameters, str]:
    """The per-joint kernel of ``s``, fitted once and cached."""
    data = s.name.replace('tiago70', 'tiago')  # the same recording
    path = args.cache / f'{data}_{args.hyper_samples}_{args.seed}.npz'
    if path.exists():
        h = np.load(path)
        return ArdHyperparameters(h['length_scales'], h['signal'], h['noise']), 'cached'
    model = SparseSpectrumGP(2)
    model.set_kernel(s.X, s.Y, ArdHyperparameters(np.ones((1, s.X.shape[1])), np.ones(1),
                                                  np.ones(1)))
    rows = s.hyper_rows
    if rows is None:
        rows = np.sort(np.random.default_rng(args.seed).choice(
            len(s.X), min(args.hyper_samples, len(s.X)), replace=False))
    started = time.perf_counter()
    hyper = fit_ard_hyperparameters((s.X[rows] - model.x_mean_) / model.x_scale_,
                                    (s.Y[rows] - model.y_mean_) / model.y_scale_,
                                    per_joint=True, samples=len(rows), seed=args.seed)
    args.cache.mkdir(parents=True, exist_ok=True)
    np.savez(path, length_scales=hyper.length_scales, signal=hyper.signal, noise=hyper.noise)
    return hyper, f'fitted on {len(rows)} rows in {time.perf_counter() - started:.0f} s'


def run_kernel(s: Split, args: argparse.Namespace) -> tuple[np.ndarray, str]:
    hyper, how = hyperparameters(s, args)
    model = SparseSpectrumGP(args.features, per_joint=True, seed=args.seed)
    model.set_kernel(s.X, s.Y, hyper).fit(s.X, s.Y)
    return np.asarray(model.predict(s.Xt)), f'D={args.features}, kernel {how}'


def run_online(s: Split, args: argparse.Namespace) -> tuple[np.ndarray, str]:
    hyper, how = hyperparameters(s, args)
    model = SparseSpectrumGP(args.features, per_joint=True, seed=args.seed)
    model.set_kernel(s.X, s.Y, hyper)
    started = time.perf_counter()
    prequential = np.vstack([model.partial_fit(s.X[i:i + 1], s.Y[i:i + 1])
                             for i in range(len(s.X))])
    per_sample = (time.perf_counter() - started) / len(s.X) * 1e6
    late = slice(len(s.X) // 2, None)
    stream = nmse(s.Y[late], prequential[late]).max()
    return (np.asarray(model.predict(s.Xt)),
            f'D={args.features}, one pass in order, {per_sample:.0f} µs/sample; '
            f'prequential worst-joint NMSE over the second half {stream:.3g}')


def run_gp(s: Split, args: argparse.Namespace) -> tuple[np.ndarray, str]:
    hyper, how = hyperparameters(s, args)
    model = SparseSpectrumGP(2).set_kernel(s.X, s.Y, hyper)
    rows = np.arange(len(s.X))
    if len(rows) > args.gp_rows:
        rows = np.sort(np.random.default_rng(args.seed).choice(rows, args.gp_rows, False))
    u = (s.X[rows] - model.x_mean_) / model.x_scale_
    ut = (s.Xt - model.x_mean_) / model.x_scale_
    t = (s.Y[rows] - model.y_mean_) / model.y_scale_
    out = np.empty((len(s.Xt), s.Y.shape[1]))
    for j in range(s.Y.shape[1]):
        a, b = u / hyper.length_scales[j], ut / hyper.length_scales[j]
        sq = (a ** 2).sum(1)
        k = hyper.signal[j] * np.exp(-0.5 * np.maximum(
            sq[:, None] + sq[None, :] - 2.0 * a @ a.T, 0.0))
        k[np.diag_indices_from(k)] += hyper.noise[j]
        alpha = cho_solve(cho_factor(k, lower=True, overwrite_a=True), t[:, j])
        del k
        kt = hyper.signal[j] * np.exp(-0.5 * np.maximum(
            (b ** 2).sum(1)[:, None] + sq[None, :] - 2.0 * b @ a.T, 0.0))
        out[:, j] = kt @ alpha
    return out * model.y_scale_ + model.y_mean_, f'{len(rows)} rows, kernel {how}'


def run_ffs(s: Split, args: argparse.Namespace) -> tuple[np.ndarray, str]:
    from scara_ident_ros.cli.train import MAX_FAIL, MIN_ITERATIONS, SAMPLES
    from scara_ident_ros.nn import fit
    from scara_ident_ros.nn.presets import make_network

    n = s.Y.shape[1]
    validation = np.arange(len(s.X)) % 10 == 9
    x, y = s.X[~validation], s.Y[~validation]
    if len(x) > SAMPLES:
        rows = np.random.default_rng(args.seed).choice(len(x), SAMPLES, replace=False)
        x, y = x[rows], y[rows]
    net = make_network('ffs', n, seed=args.seed, friction_steps=True)
    history = fit(net, x, y, iterations=args.ffs_iterations,
                  validation=(s.X[validation], s.Y[validation]), max_fail=MAX_FAIL,
                  min_iterations=MIN_ITERATIONS)
    return net.predict(s.Xt), (f'{history.iterations} LM iterations '
                               f'({history.stop_reason})')


METHODS: dict[str, tuple[str, Callable[[Split, argparse.Namespace],
                                       tuple[np.ndarray, str]]]] = {
    'linear': ('linear LS [q, q\', q\'\', sin q, cos q, tanh(q\'/0.05), 1]', run_linear),
    'ffs': ('FFS network (train\'s defaults)', run_ffs),
    'kernel': ('kernel offline (sparse-spectrum GP, batch)', run_kernel),
    'online': ('kernel online (one pass in order, frozen)', run_online),
    'gp': ('exact GP (same kernel)', run_gp),
}


def nmse(y: np.ndarray, p: np.ndarray) -> np.ndarray:
    return np.asarray(((y - p) ** 2).mean(axis=0) / y.var(axis=0))


def smse(y: np.ndarray, p: np.ndarray) -> float:
    return float(((y - p) ** 2).sum() / ((y - y.mean(axis=0)) ** 2).sum())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--data', nargs='+', default=list(LOADERS), choices=list(LOADERS))
    parser.add_argument('--methods', nargs='+', default=['linear', 'kernel', 'online', 'gp'],
                        choices=list(METHODS))
    parser.add_argument('--features', type=int, default=1000)
    parser.add_argument('--hyper-samples', type=int, default=1200)
    parser.add_argument('--gp-rows', type=int, default=12000)
    parser.add_argument('--ffs-iterations', type=int, default=500)
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--cache', type=Path, default=Path('/tmp/bench_realdata_hyper'))
    parser.add_argument('--out', type=Path, default=None,
                        help='Markdown file to append the tables to')
    args = parser.parse_args()
    commit = subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], capture_output=True,
                            text=True, cwd=Path(__file__).parent).stdout.strip()
    lines = [f'\n## {time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}, commit {commit}, '
             f'seed {args.seed}, D={args.features}, hyperparameter rows '
             f'{args.hyper_samples}\n']
    print(lines[0], flush=True)
    for name in args.data:
        s = LOADERS[name]()
        head = (f'### {name}: {len(s.X)} training rows, {len(s.Xt)} held out ({s.note})\n\n'
                f'Published / reference: {PUBLISHED[name]}\n\n'
                f'| learner | SMSE | NMSE per joint ({", ".join(s.joints)}) | s | load | '
                f'notes |\n|---|---|---|---|---|---|')
        print(head, flush=True)
        lines.append(head)
        for key in args.methods:
            label, run = METHODS[key]
            started = time.perf_counter()
            with single_blas_thread():
                prediction, note = run(s, args)
            seconds = time.perf_counter() - started
            row = (f'| {label} | {smse(s.Yt, prediction):.3g} | '
                   f'{", ".join(f"{v:.3g}" for v in nmse(s.Yt, prediction))} | '
                   f'{seconds:.0f} | {os.getloadavg()[0]:.1f} | {note} |')
            print(row, flush=True)
            lines.append(row)
        lines.append('')
    if args.out is not None:
        with args.out.open('a') as stream:
            stream.write('\n'.join(lines) + '\n')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
