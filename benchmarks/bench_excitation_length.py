"""How long to excite: the physical model from seconds of the random sequence or the
optimised plan, held-out NMSE and parameter error against the length.

Robots: ``robot_sim``'s UR5 and Panda (example-robot-data) and the SCARA (urdf/scara.urdf),
their limits as ``robot_sim`` and ``excitation`` take them (the URDF's, acceleration limits
``robot_sim``'s default for the arms, config/scara.yaml's for the SCARA) with the
``excitation`` node's margins (10 % of each range, half the velocity and acceleration
limits). Per seed s, the plans are those of ``scara-ident excitation --dry-run`` from the
middle of the ranges, sampled every 0.01 s (its point period): the random sequence (seed s)
and the optimised plan (``--optimize``: its defaults, 10 harmonics of a 10 s period, seeded
start s, its 2-minute time budget, the links kept apart for the arms, whose URDFs have
collision geometry). The efforts are the model's with known parameters: the rigid body
of the URDF (Pinocchio's regressor, which is RNEA) with ``robot_sim``'s rotor inertia
(1e-3 s² × the effort limit), viscous friction (2 % of the effort limit per rad/s or m/s)
and Coulomb friction (3 %, tanh(q'/0.05)), plus normal noise of 0.3 N·m (N) on every joint,
as a torque sensor has.

For each length (``--lengths``, the seconds of excitation after the approach), the
physical model (``PhysicalModel`` of the URDF, ``train --method physical``'s least squares
with tanh(q'/0.05) Coulomb friction) is fitted and scored on the noise-free efforts of other
motion: 30 s of the random sequence of seed 1000 + s (mean NMSE over the joints). Also per
fit: the NMSE the noise gives on average (from the covariance, free of the one noise draw's
luck); the regressor's condition number; the share of base parameters with %σ <= 5 % (all of
them, as the issue counts, and those with |θ| above 1 % of the largest: a true 0 has an
infinite %σ however well it is found), and of those the share within 5 % of the true value;
the training motions' peak speed and RMS effort.

Targets (issue 34): the optimised plan's condition number <= 1/3 of the random sequence's
of the same length; 20 s optimised reaches the NMSE of 60 s random (medians over seeds);
after 30 s optimised, >= 90 % of the base parameters with %σ <= 5 %, within 5 % of the
truth.

Writes ``benchmarks/excitation_length.md`` and ``docs/excitation_length.png``.

    .venv/bin/python benchmarks/bench_excitation_length.py [--robots ur5 panda scara]
        [--seeds 5] [--lengths 5 10 20 30 60] [--workers 2] [--max-seconds 120]
"""
from __future__ import annotations

import argparse
import datetime
import os
import subprocess
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / 'benchmarks' / 'excitation_length.md'
FIGURE = ROOT / 'docs' / 'excitation_length.png'
STEP = 0.01            # s, the excitation's point period
NOISE = 0.3            # N·m (N), effort noise
HELD_OUT = 30.0        # s of other motion scored
HELD_OUT_SEED = 1000   # + seed
GOOD = 0.05            # %σ and relative error called good
LARGE = 0.01           # |θ| above this share of the largest base |θ|: the second %σ count


def robot_setup(name: str) -> tuple[Any, Any, np.ndarray, Any]:
    """The limits with the node's margins, the physical model, the true θ and the
    self-collision check (None for the SCARA: no collision geometry)."""
    from scara_ident_ros.dynamics.joint_limits import JointLimits, load_motion_limits
    from scara_ident_ros.dynamics.physical_model import PhysicalModel
    from scara_ident_ros.excitation import LoopSettings
    from scara_ident_ros.excitation.self_collision import self_collision
    from scara_ident_ros.sim.example_robots import example_robot
    from scara_ident_ros.sim.pinocchio_robot import (ARMATURE_PER_EFFORT, FRICTION_DEFAULTS,
                                                     PinocchioRobot)

    if name == 'scara':
        urdf = str(ROOT / 'urdf' / 'scara.urdf')
        limits = load_motion_limits(urdf_file=urdf,
                                    robot_config=str(ROOT / 'config' / 'scara.yaml'))
    else:
        found = example_robot(name)
        urdf = found.urdf
        robot = PinocchioRobot.from_urdf(urdf, joints=found.joints)
        limits = JointLimits.of(robot.joint_names, {key: robot.array(key) for key in (
            'position_min', 'position_max', 'velocity_max', 'acceleration_max',
            'effort_max')}, source=name)
    node = LoopSettings()
    margined = limits.with_margins(node.position_margin, node.velocity_scale,
                                   node.acceleration_scale)
    model = PhysicalModel.from_urdf_file(urdf, joint_names=list(limits.names))
    effort = limits.effort_max
    standard = model.urdf_standard_parameters()
    standard[-model.n_joints:] = ARMATURE_PER_EFFORT * effort      # rotor inertias
    truth = np.concatenate([model.reduction.base_values(standard),
                            FRICTION_DEFAULTS['viscous'] * effort,
                            FRICTION_DEFAULTS['coulomb'] * effort])
    return margined, model, truth, self_collision(urdf, limits.names, margined.centre)


def run_seed(name: str, seed: int, lengths: list[float], max_seconds: float
             ) -> dict[str, Any]:
    """Every length of both plans for one robot and seed."""
    from scara_ident_ros.blas_threads import single_blas_thread
    from scara_ident_ros.excitation import ExcitationPlan
    from scara_ident_ros.excitation.optimized_excitation import optimize_excitation
    from scara_ident_ros.identification.metrics import effort_errors

    with single_blas_thread():
        margined, model, truth, collision = robot_setup(name)
        model.set_theta(truth)
        start = 0.5 * (margined.position_min + margined.position_max)
        held = ExcitationPlan(margined, start, seed=HELD_OUT_SEED + seed)
        t = held.approach_duration + STEP * np.arange(round(HELD_OUT / STEP))
        q_h, qd_h, qdd_h = held.evaluate(t)
        X_h = np.hstack([q_h, qd_h, qdd_h])
        Y_h = model.predict(X_h)
        started = time.perf_counter()
        found = optimize_excitation(model, margined, seed=seed, max_seconds=max_seconds,
                                    collision=collision)
        plans = {'random': ExcitationPlan(margined, start, seed=seed),
                 'optimised': ExcitationPlan(margined, start, seed=seed, excitation=found)}
        out: dict[str, Any] = {'robot': name, 'seed': seed, 'n_base': model.n_base,
                               'zero': int(np.sum(np.abs(truth[:model.n_base]) < 1e-12)),
                               'optimise_s': time.perf_counter() - started,
                               'iterations': found.iterations,
                               'collision_scale': found.collision_scale, 'rows': []}
        rng = np.random.default_rng(seed)
        longest = max(lengths)
        nb = model.n_base
        large = np.abs(truth[:nb]) > LARGE * np.abs(truth[:nb]).max()
        out['large'] = int(np.sum(large))
        held_regressor = model.regressor(q_h, qd_h, qdd_h)                 # (N, n, p)
        for kind, plan in plans.items():
            t = plan.approach_duration + STEP * np.arange(round(longest / STEP))
            q, qd, qdd = plan.evaluate(t)
            model.set_theta(truth)
            tau = model.predict(np.hstack([q, qd, qdd]))
            out[f'{kind}_speed'] = float(np.median(np.abs(qd).max(axis=0)
                                                   / margined.velocity_max))
            out[f'{kind}_effort'] = np.sqrt(np.mean(tau ** 2, axis=0))
            tau = tau + rng.normal(0.0, NOISE, tau.shape)
            for length in lengths:
                rows = slice(0, round(length / STEP))
                model.fit_states(q[rows], qd[rows], qdd[rows], tau[rows])
                found_u = model.uncertainty
                assert found_u is not None
                relative = found_u.relative_std[:nb]
                with np.errstate(divide='ignore'):
                    error = np.abs(model.theta[:nb] - truth[:nb]) / np.abs(truth[:nb])
                good = relative <= GOOD
                out['rows'].append({
                    'plan': kind, 'seconds': length,
                    'nmse': float(effort_errors(Y_h, model.predict(X_h)).nmse_total),
                    'expected': _expected_nmse(model, q[rows], qd[rows], qdd[rows],
                                               held_regressor, Y_h),
                    'condition': found_u.condition_number,
                    'determined': float(np.mean(good)),
                    'determined_large': float(np.mean(good[large])),
                    'within': float(np.mean(error[good] <= GOOD)) if good.any() else 0.0,
                    'median_error': float(np.median(error))})
    return out


def _expected_nmse(model: Any, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                   held_regressor: np.ndarray, held_effort: np.ndarray) -> float:
    """The held-out NMSE the noise alone gives on average: the mean over the joints j of
    NOISE² tr(W_j (WᵀW)⁻¹ W_jᵀ) / (N var τ_j), W the training regressor stacked, W_j
    (N, p) the held-out motion's rows of joint j, τ_j its noise-free efforts."""
    w = model.regressor(q, qd, qdd).reshape(-1, model.n_parameters)
    inverse = np.linalg.pinv(w.T @ w)
    spread = np.einsum('ijk,kl,ijl->j', held_regressor, inverse, held_regressor)
    return float(np.mean(NOISE ** 2 * spread / held_regressor.shape[0]
                         / np.var(held_effort, axis=0)))


def summary(results: list[dict[str, Any]], lengths: list[float]) -> tuple[str, dict]:
    """The Markdown tables and the medians by (robot, plan, seconds)."""
    medians: dict[tuple[str, str, float], dict[str, float]] = {}
    lines = []
    robots = sorted({r['robot'] for r in results}, key=['ur5', 'panda', 'scara'].index)
    for robot in robots:
        mine = [r for r in results if r['robot'] == robot]
        seeds = sorted(r['seed'] for r in mine)
        lines += [f'### {robot}: {mine[0]["n_base"]} base parameters ({mine[0]["zero"]} of them 0 '
                  f'in truth: their %σ is ∞ or large however well they are found; '
                  f'{mine[0]["large"]} with |θ| above {100 * LARGE:g} % of the largest), seeds '
                  f'{seeds}', '',
                  f'Optimisation: {np.median([r["optimise_s"] for r in mine]):.0f} s median '
                  f'({min(r["optimise_s"] for r in mine):.0f}–'
                  f'{max(r["optimise_s"] for r in mine):.0f} s), '
                  f'{np.median([r["iterations"] for r in mine]):.0f} SLSQP iterations; '
                  + _collision_text(mine), '',
                  'Size of the training motion (medians over the seeds): peak speed '
                  f'{np.median([r["random_speed"] for r in mine]):.2f} of the limits (median '
                  f'over the joints) for the random sequence, '
                  f'{np.median([r["optimised_speed"] for r in mine]):.2f} for the optimised '
                  'plan; RMS effort optimised / random per joint '
                  + ', '.join(f'{v:.2f}' for v in np.median(
                      [r['optimised_effort'] / r['random_effort'] for r in mine], axis=0))
                  + '.', '',
                  '| s | plan | NMSE median (range) | expected NMSE | cond median | %σ ≤ 5 % '
                  '(all) | %σ ≤ 5 % (large θ) | of those (all) within 5 % | median parameter '
                  'error |', '|---|---|---|---|---|---|---|---|---|']
        for length in lengths:
            for plan in ('random', 'optimised'):
                rows = [row for r in mine for row in r['rows']
                        if row['plan'] == plan and row['seconds'] == length]
                m = {key: float(np.median([row[key] for row in rows])) for key in
                     ('nmse', 'expected', 'condition', 'determined', 'determined_large',
                      'within', 'median_error')}
                medians[(robot, plan, length)] = m
                low, high = (f(row['nmse'] for row in rows) for f in (min, max))
                lines.append(f'| {length:g} | {plan} | {m["nmse"]:.2g} ({low:.2g}–{high:.2g}) '
                             f'| {m["expected"]:.2g} | {m["condition"]:.0f} | '
                             f'{100 * m["determined"]:.0f} % | '
                             f'{100 * m["determined_large"]:.0f} % | '
                             f'{100 * m["within"]:.0f} % | {100 * m["median_error"]:.2g} % |')
        lines.append('')
    return '\n'.join(lines), medians


def _collision_text(results: list[dict[str, Any]]) -> str:
    scales = [r['collision_scale'] for r in results]
    if scales[0] is None:
        return 'no collision geometry: self-collision not checked.'
    return ('self-collision checked; amplitudes shrunk to keep the links apart: '
            + ', '.join(f'{s:.2g}' for s in scales) + ' (per seed).')


def targets(medians: dict, lengths: list[float]) -> str:
    """The issue's targets, met or not, per robot."""
    lines = ['| robot | cond optimised / random (worst length) | NMSE 20 s optimised vs 60 s '
             'random | 30 s optimised: %σ ≤ 5 % (all base parameters, as the issue counts), '
             'within 5 % |', '|---|---|---|---|']
    for robot in sorted({key[0] for key in medians}, key=['ur5', 'panda', 'scara'].index):
        ratio = max(medians[(robot, 'optimised', s)]['condition']
                    / medians[(robot, 'random', s)]['condition'] for s in lengths)
        cells = [f'{ratio:.2f} ({"met" if ratio <= 1 / 3 else "missed"})']
        if 20 in lengths and 60 in lengths:
            ours = medians[(robot, 'optimised', 20)]['nmse']
            theirs = medians[(robot, 'random', 60)]['nmse']
            cells.append(f'{ours:.2g} vs {theirs:.2g} ({"met" if ours <= theirs else "missed"})')
        else:
            cells.append('not run')
        if 30 in lengths:
            m = medians[(robot, 'optimised', 30)]
            met = m['determined'] >= 0.9 and m['within'] >= 0.9
            cells.append(f'{100 * m["determined"]:.0f} %, {100 * m["within"]:.0f} % '
                         f'({"met" if met else "missed"}; large θ: '
                         f'{100 * m["determined_large"]:.0f} %)')
        else:
            cells.append('not run')
        lines.append(f'| {robot} | ' + ' | '.join(cells) + ' |')
    return '\n'.join(lines)


def plot(medians: dict, results: list[dict[str, Any]], lengths: list[float]) -> None:
    import matplotlib
    matplotlib.use('Agg', force=True)
    import matplotlib.pyplot as plt

    robots = sorted({key[0] for key in medians}, key=['ur5', 'panda', 'scara'].index)
    fig, axes = plt.subplots(2, len(robots), figsize=(4.2 * len(robots), 6.4), squeeze=False)
    for col, robot in enumerate(robots):
        for plan, colour in (('random', 'tab:grey'), ('optimised', 'tab:blue')):
            for r in results:
                if r['robot'] != robot:
                    continue
                rows = [row for row in r['rows'] if row['plan'] == plan]
                axes[0, col].plot([row['seconds'] for row in rows],
                                  [row['nmse'] for row in rows], color=colour, lw=0.5,
                                  alpha=0.4)
            axes[0, col].plot(lengths, [medians[(robot, plan, s)]['nmse'] for s in lengths],
                              'o-', color=colour, label=plan)
            axes[1, col].plot(lengths, [100 * medians[(robot, plan, s)]['determined']
                                        for s in lengths], 'o-', color=colour, label=plan)
        axes[0, col].set_yscale('log')
        axes[0, col].set_title(f'{robot}: held-out NMSE (median, seeds thin)', fontsize=9)
        axes[1, col].set_title('base parameters with %σ ≤ 5 % (median)', fontsize=9)
        axes[1, col].set_ylim(0, 100)
        axes[1, col].set_xlabel('seconds of excitation')
        axes[0, col].legend(fontsize=8)
    fig.suptitle(f'physical model from the random sequence or the optimised plan, effort noise '
                 f'{NOISE:g} N·m', fontsize=10)
    fig.tight_layout()
    fig.savefig(FIGURE, dpi=100)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--robots', nargs='+', default=['ur5', 'panda', 'scara'])
    parser.add_argument('--seeds', type=int, default=5)
    parser.add_argument('--lengths', type=float, nargs='+', default=[5, 10, 20, 30, 60])
    parser.add_argument('--workers', type=int, default=2)
    parser.add_argument('--max-seconds', type=float, default=120.0)
    args = parser.parse_args()
    started = time.perf_counter()
    load_before = os.getloadavg()
    commit = subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], cwd=ROOT, text=True,
                            capture_output=True, check=False).stdout.strip()
    jobs = [(robot, seed) for robot in args.robots for seed in range(args.seeds)]
    with ProcessPoolExecutor(args.workers) as pool:
        results = list(pool.map(run_seed, *zip(*jobs), [args.lengths] * len(jobs),
                                [args.max_seconds] * len(jobs)))
    tables, medians = summary(results, args.lengths)
    plot(medians, results, args.lengths)
    load_after = os.getloadavg()
    text = '\n'.join([
        '# How long to excite: random sequence or optimised plan', '',
        f'Written by `benchmarks/bench_excitation_length.py --robots {" ".join(args.robots)} '
        f'--seeds {args.seeds} --lengths {" ".join(f"{s:g}" for s in args.lengths)} '
        f'--workers {args.workers} --max-seconds {args.max_seconds:g}` '
        f'({datetime.date.today()}, commit {commit}, {time.perf_counter() - started:.0f} s; '
        f'load average {load_before[0]:.1f} at the start, {load_after[0]:.1f} at the end, '
        f'2 shared cores). What it measures: the script\'s docstring. Figure: '
        '[`../docs/excitation_length.png`](../docs/excitation_length.png).', '',
        '## Targets (issue 34)', '', targets(medians, args.lengths), '',
        '## Per robot', '',
        'NMSE: mean over the joints on the noise-free efforts of 30 s of other motion; '
        'expected NMSE: what the noise alone gives on average, from the covariance (the '
        'realised NMSE of one noise draw scatters about it); cond: '
        'condition number of the stacked regressor (base, friction and rotor-inertia columns) '
        'of the training motion; %σ: relative standard deviation of each base parameter '
        '(`dynamics/parameter_uncertainty.py`); "within 5 %": of the base parameters with '
        '%σ ≤ 5 %, the share whose estimate is within 5 % of the true value; "large θ": of '
        f'the base parameters with |θ| above {100 * LARGE:g} % of the largest (the issue\'s '
        'target counts all of them); parameter '
        'error: |θ̂ − θ| / |θ| over all base parameters (∞ for a true value of 0).', '',
        tables])
    OUT.write_text(text, encoding='utf-8')
    print(text)


if __name__ == '__main__':
    main()
