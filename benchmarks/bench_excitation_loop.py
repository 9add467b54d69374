"""The excitation loop on this machine: excitation -> scara_sim (as the controller) ->
/joint_states, and what a real arm would be sent.

a. **Plan check** (no ROS). The chunks the ``excitation`` node sends over ``--seconds``
   (every 0.25 s, 1 s ahead, then each chunk's stop), every point checked against the
   SCARA's URDF limits with the node's margins: peak |q'| and |q''| as fractions of the
   robot's limits, closest approach to the position limits (fraction of the range); and
   stops begun every 0.1 s of the plan: peak |q''| of the stop against the limit.
b. **Loop**. ``scara_sim trajectory:=external`` and ``excitation`` (until stopped) run as
   processes; this script records ``/joint_states`` and the commands; after ``--seconds`` of
   excitation it calls ``/excitation/stop``. Tracking error = measured q − the plan at the
   same stamp, over the motion before the stop (max and RMS per joint). The stop: peak
   |q''| of the last command after its stop began, and of the measured motion (q' of the
   joint states differentiated), against the acceleration limits.
c. ``--identify``: the issue's target. An identifier (its defaults: FFS, ``lm``) learns for
   ``--seconds`` in two graphs, the loop above and ``scara_sim``'s own ``sequence``; both
   saved models are then scored frozen on the held-out motions of
   ``bench_learning_curves.py`` (5 ``standard`` excitations and 30 s of another ``sequence``,
   never streamed): the loop should reach the held-out NMSE of the simulator's sequence.
   Two minutes of graph each (``--seconds 120``): run it on a quiet machine. Also when
   the loop's identifier first armed contact detection (``contact_armed``), from the
   excitation's first chunk.
d. ``--in-process``: the same target measured on the motion, not on the machine (no ROS,
   instead of a-c). The loop is simulated in one process, synchronously
   (:func:`~scara_ident_ros.excitation.simulated_loop.simulate_loop`: the node's plan, same
   seed, margins, scales, approach and chunks as sent, followed by ``scara_sim``'s
   ``trajectory:=external`` follower, computed torque + PD); the identifier's pipeline (FFS
   ``lm``, the node's defaults) learns its stream as the learning curves learn
   ``scara_sim``'s own ``sequence`` (``paper.learning_curves.network_curve``: every
   sample, every LM update, whatever the machine's load), frozen at the checkpoints up to
   ``--seconds`` and scored on the held-out motions; beside it, ``scara_sim``'s own
   ``sequence`` with the same seeds. Each ``--settings`` is a node setting
   ``position_margin:velocity_scale:acceleration_scale``. Also per stream: its amplitude
   against the held-out motions' (RMS of q − centre, q', q'' as fractions of the half-range
   and limits), the share of held-out samples outside the stream's per-joint ranges, the
   time at rest, the loops' tracking error, and each seed's worst joint at the end.
   ``--seeds`` seeds in ``--workers`` processes (one BLAS thread each).

    .venv/bin/python benchmarks/bench_excitation_loop.py [--seconds 10] [--identify]
        [--position-margin 0.1] [--velocity-scale 0.5] [--acceleration-scale 0.5]
    .venv/bin/python benchmarks/bench_excitation_loop.py --in-process [--seconds 120]
        [--seeds 5] [--workers 2] [--settings 0.1:0.5:0.5 0.1:1:1 0:1:1]

DDS stays on this machine (``ros_env``). Prints Markdown tables.
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np

from ros_env import ros_env  # benchmarks/: the script's own folder
from scara_ident_ros.excitation import LoopSettings

ROOT = Path(__file__).resolve().parents[1]
URDF = ROOT / 'urdf' / 'scara.urdf'
NODE = LoopSettings()  # the excitation node's defaults
START_TIMEOUT = 60.0  # s, the machine is shared
S = 1_000_000_000  # ns


def plan_check(seconds: float, position_margin: float, velocity_scale: float,
               acceleration_scale: float) -> None:
    """Part a: every point of every chunk, and stops every 0.1 s."""
    from scara_ident_ros.excitation import (ExcitationPlan, load_motion_limits, make_chunk,
                                            plan_stop)

    limits = load_motion_limits(urdf_file=str(URDF))
    margined = limits.with_margins(position_margin, velocity_scale, acceleration_scale)
    start = np.array([0.5, -0.5, 0.05, 2.0])
    plan = ExcitationPlan(margined, start, seed=0)
    end = plan.approach_duration + seconds
    step = NODE.point_period
    chunks = [make_chunk(plan, t - step, min(t + NODE.horizon, end), step, margined)
              for t in np.arange(0.0, end, NODE.chunk_period)]
    q = np.vstack([c.q for c in chunks])
    qd = np.vstack([c.qd for c in chunks])
    qdd = np.vstack([c.qdd for c in chunks])
    broken = margined.violations(q, qd, qdd, position_hull=start)
    span = limits.position_max - limits.position_min
    clearance = np.minimum(q - limits.position_min, limits.position_max - q).min(axis=0) / span
    stops = [plan_stop(plan, t, margined, step) for t in np.arange(0.0, end, 0.1)]
    stop_peak = np.zeros(limits.n_joints)
    for stop in stops:
        _, _, a = stop.evaluate(np.linspace(stop.start, stop.end, 201))
        stop_peak = np.maximum(stop_peak, np.abs(a).max(axis=0))
    durations = [stop.duration for stop in stops]
    print(f'### a. Plan check: {len(chunks)} chunks, {len(q)} points, approach '
          f'{plan.approach_duration:g} s + {seconds:g} s (margins {position_margin:g}, scales '
          f'{velocity_scale:g}/{acceleration_scale:g})\n')
    print('| joint | peak \\|q\'\\| / limit | peak \\|q\'\'\\| / limit | closest to a position '
          'limit (of range) | stop peak \\|q\'\'\\| / limit |')
    print('|---|---:|---:|---:|---:|')
    for j, name in enumerate(limits.names):
        print(f'| {name} | {np.abs(qd[:, j]).max() / limits.velocity_max[j]:.3f} | '
              f'{np.abs(qdd[:, j]).max() / limits.acceleration_max[j]:.3f} | '
              f'{clearance[j]:.3f} | {stop_peak[j] / limits.acceleration_max[j]:.3f} |')
    print(f'\nviolations of the limits with margins: {len(broken)} '
          f'({"; ".join(broken) if broken else "none"}); {len(stops)} stops of '
          f'{min(durations):g}-{max(durations):g} s.\n')


class Graph:
    """Processes of one run, and a recorder of /joint_states and of the commands."""

    def __init__(self, env: dict[str, str], logs: Path) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.experimental import EventsExecutor
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Bool
        from trajectory_msgs.msg import JointTrajectory

        os.environ.update({k: env[k] for k in ('ROS_DOMAIN_ID',
                                               'ROS_AUTOMATIC_DISCOVERY_RANGE')})
        self.env, self.logs = env, logs
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node('bench_excitation_loop', context=self.context)
        self.executor = EventsExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.states: list[tuple[int, list[float], list[float]]] = []
        self.commands: list[Any] = []
        self.node.create_subscription(
            JointState, '/joint_states',
            lambda m: self.states.append((m.header.stamp.sec * S + m.header.stamp.nanosec,
                                          list(m.position), list(m.velocity))),
            QoSProfile(depth=5000, reliability=ReliabilityPolicy.RELIABLE))
        self.first_command: float | None = None  # monotonic s

        def command(message: JointTrajectory) -> None:
            if self.first_command is None:
                self.first_command = time.monotonic()
            self.commands.append(message)
        self.node.create_subscription(JointTrajectory,
                                      '/joint_trajectory_controller/joint_trajectory',
                                      command, 10)
        self.armed: list[tuple[float, bool]] = []  # (monotonic s, contact_armed)

        def armed(message: Bool) -> None:
            self.armed.append((time.monotonic(), bool(message.data)))
        self.node.create_subscription(
            Bool, '/contact_armed', armed,
            QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self.torques = 0  # identified_torque messages: the identifier is up

        def count(_: Any) -> None:
            self.torques += 1
        self.node.create_subscription(JointState, '/identified_torque', count, 10)
        self.processes: list[subprocess.Popen[bytes]] = []

    def start(self, name: str, module: str, *params: str) -> subprocess.Popen[bytes]:
        args = [sys.executable, '-m', module, '--ros-args']
        for param in params:
            args += ['-p', param]
        log = (self.logs / f'{name}.log').open('wb')
        process = subprocess.Popen(args, env=self.env, stdout=log, stderr=log)
        self.processes.append(process)
        return process

    def spin(self, seconds: float, until: Any = None) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline and not (until and until()):
            self.executor.spin_once(timeout_sec=0.01)

    def call_stop(self) -> None:
        from std_srvs.srv import Trigger

        client = self.node.create_client(Trigger, '/excitation/stop')
        self.spin(START_TIMEOUT, client.service_is_ready)
        future = client.call_async(Trigger.Request())
        self.spin(START_TIMEOUT, future.done)

    def close(self) -> None:
        for process in reversed(self.processes):
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
            try:
                process.wait(timeout=60)
            except subprocess.TimeoutExpired:
                process.kill()
        self.spin(0.5)
        self.executor.shutdown()
        self.node.destroy_node()
        self.context.try_shutdown()


def loop(seconds: float, position_margin: float, velocity_scale: float,
         acceleration_scale: float, env: dict[str, str], logs: Path, identify: bool
         ) -> Path | None:
    """Part b (and the loop's half of part c): returns the identifier's model, if any."""
    from scara_ident_ros.excitation import ExcitationPlan, load_motion_limits

    graph = Graph(env, logs)
    stats, model = logs / 'excitation.json', logs / 'loop_model.npz'
    try:
        graph.start('scara_sim', 'scara_ident_ros.nodes.scara_sim', 'trajectory:=external')
        graph.spin(START_TIMEOUT, lambda: len(graph.states) > 200)
        identifier = None
        if identify:  # up and learning before the excitation starts; stopped with it
            identifier = graph.start('identifier', 'scara_ident_ros.nodes.identifier',
                                     f'save_path:={model}',
                                     f'stats_file:={logs / "loop_identifier.json"}')
            graph.spin(START_TIMEOUT, lambda: graph.torques > 0)
        excitation = graph.start(
            'excitation', 'scara_ident_ros.nodes.excitation', f'urdf_file:={URDF}',
            f'position_margin:={position_margin}', f'velocity_scale:={velocity_scale}',
            f'acceleration_scale:={acceleration_scale}',
            f'stats_file:={stats}', 'wait_timeout:=60.0')
        graph.spin(START_TIMEOUT, lambda: len(graph.commands) > 0)
        graph.spin(seconds + 2.0)  # the approach (1-2 s), then --seconds of sequence
        graph.call_stop()
        if identifier is not None:
            identifier.send_signal(signal.SIGINT)
        graph.spin(START_TIMEOUT, lambda: excitation.poll() is not None)
        graph.spin(1.0)
    finally:
        graph.close()
    run = json.loads(stats.read_text())
    limits = load_motion_limits(urdf_file=str(URDF))
    margined = limits.with_margins(run['position_margin'], run['velocity_scale'],
                                   run['acceleration_scale'])
    plan = ExcitationPlan(margined, np.array(run['start']), seed=run['seed'])
    stamps = np.array([s[0] for s in graph.states])
    q = np.array([s[1] for s in graph.states])
    qd = np.array([s[2] for s in graph.states])
    t = (stamps - run['origin_ns']) / S
    moving = (t >= 0.0) & (t <= run['stop_time'])
    error = q[moving] - plan.evaluate(t[moving])[0]
    last = graph.commands[-1]
    times = np.array([p.time_from_start.sec + p.time_from_start.nanosec * 1e-9
                      for p in last.points])
    commanded = np.abs(np.array([p.accelerations for p in last.points])[
        times >= run['stop_time']]).max(axis=0)
    stopping = (t >= run['stop_time']) & (t <= run['rest_time'] + 0.2)
    measured = np.abs(np.gradient(qd[stopping], t[stopping], axis=0)).max(axis=0)
    print(f'### b. Loop: excitation -> scara_sim -> /joint_states, {t[moving].size} samples '
          f'over {t[moving].size / 1000:.1f} s of motion, {len(graph.commands)} chunks, '
          f'stop ({run["stop_reason"]}) at plan time {run["stop_time"]:.2f} s (load average '
          f'{os.getloadavg()[0]:.1f})\n')
    print('| joint | tracking max \\|e\\| | tracking RMS | stop: commanded peak \\|q\'\'\\| / '
          'limit | stop: measured peak \\|q\'\'\\| / limit |')
    print('|---|---:|---:|---:|---:|')
    for j, name in enumerate(limits.names):
        print(f'| {name} | {np.abs(error[:, j]).max():.2e} | '
              f'{np.sqrt(np.mean(error[:, j] ** 2)):.2e} | '
              f'{commanded[j] / limits.acceleration_max[j]:.3f} | '
              f'{measured[j] / limits.acceleration_max[j]:.3f} |')
    print('\n(e in rad, joint3 in m; limits: the URDF\'s, acceleration from config/scara.yaml; '
          f'the stop keeps to {run["acceleration_scale"]:g} of them.)\n')
    if identify:
        print(armed_line(graph.armed, graph.first_command) + '\n')
    if run['stop_reason'] != '~/stop called':
        print(f'**The excitation stopped early ({run["stop_reason"]}, exit status '
              f'{run["exit_status"]}) at plan time {run["stop_time"]:.2f} s of '
              f'{run["approach_duration"] + seconds:.2f}: the arm then rested; an identifier '
              'learnt rest until the end. Not a measurement of the target.**\n')
    return model if identify else None


def armed_line(changes: list[tuple[float, bool]], start: float | None) -> str:
    """When the identifier armed contact detection, from the excitation's first chunk."""
    since = [(t - (start or t), armed) for t, armed in changes]
    first = next((t for t, armed in since if armed), None)
    if first is None:
        return '**Contact detection not armed** during the loop.'
    later = [f'{t:.1f}' for t, armed in since if not armed and t > first]
    return (f'**Contact detection armed {first:.1f} s** after the excitation\'s first chunk'
            + (f', disarmed again at {", ".join(later)} s.' if later
               else ', armed until the end.'))


def sequence_model(seconds: float, env: dict[str, str], logs: Path) -> Path:
    """Part c's reference: the identifier on scara_sim's own sequence for ``seconds``."""
    graph = Graph(env, logs)
    model = logs / 'sequence_model.npz'
    try:
        identifier = graph.start('identifier_sequence', 'scara_ident_ros.nodes.identifier',
                                 f'save_path:={model}',
                                 f'stats_file:={logs / "sequence_identifier.json"}')
        graph.spin(5.0)
        graph.start('scara_sim_sequence', 'scara_ident_ros.nodes.scara_sim',
                    'wait_for_subscribers:=2', f'duration:={seconds + 2.0}')
        graph.spin(START_TIMEOUT + seconds + 2.0,
                   lambda: graph.processes[-1].poll() is not None)
        identifier.send_signal(signal.SIGINT)
        identifier.wait(timeout=120)
    finally:
        graph.close()
    return model


def score(models: dict[str, tuple[Path, Path]]) -> None:
    """Part c: the saved models (with the identifier's stats file) frozen on the held-out
    motions."""
    from scara_ident_ros.dynamics import ScaraParams
    from scara_ident_ros.paper.learning_curves import held_out_set
    from scara_ident_ros.cli.evaluation import evaluate, load_model

    params = ScaraParams.from_yaml(ROOT / 'config' / 'scara.yaml')
    held_out = held_out_set(params)
    print(f'### c. Held-out NMSE of the identifier\'s saved model ({held_out.X.shape[0]} '
          'samples never streamed)\n')
    print('| stream | samples learnt | LM updates | ' + ' | '.join(params.joint_names)
          + ' | worst |')
    print('|---|---:|---:|' + '---:|' * (len(params.joint_names) + 1))
    for label, (path, stats) in models.items():
        nmse = evaluate(load_model(path), held_out.X, held_out.Y).nmse
        run = json.loads(stats.read_text())
        print(f'| {label} | {run.get("learnt", "?")} | {run.get("updates", "?")} | '
              + ' | '.join(f'{x:.2e}' for x in nmse)
              + f' | {np.max(nmse):.2e} |')
    print()


Setting = tuple[float, float, float]  # position_margin, velocity_scale, acceleration_scale
SEQUENCE_LABEL = 'scara_sim sequence'
REST = 0.01  # a sample is at rest when every |q'| is below this fraction of its limit


def setting_label(setting: Setting) -> str:
    """A loop's row label: its node setting."""
    margin, velocity, acceleration = setting
    return f'loop, margin {margin:g}, scales {velocity:g}/{acceleration:g}'


def stream_stats(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, params: Any
                 ) -> dict[str, np.ndarray]:
    """RMS of q − centre, q', q'' (N, n) as fractions of the half-range and of the limits."""
    half = 0.5 * (params.array('position_max') - params.array('position_min'))
    return {'position': np.sqrt(np.mean((q - params.position_centre) ** 2, axis=0)) / half,
            'velocity': np.sqrt(np.mean(qd ** 2, axis=0)) / params.array('velocity_max'),
            'acceleration': (np.sqrt(np.mean(qdd ** 2, axis=0))
                             / params.array('acceleration_max'))}


def in_process_job(job: tuple[int, float, Setting | None, tuple[float, float]]
                   ) -> tuple[Any, dict[str, Any]]:
    """One seed of one stream (a loop's setting, None: scara_sim's sequence), learnt by FFS
    lm and scored at the checkpoints: its curve and its stream's figures."""
    from scara_ident_ros.blas_threads import single_blas_thread
    from scara_ident_ros.dynamics import ScaraParams
    from scara_ident_ros.excitation import load_motion_limits
    from scara_ident_ros.excitation.simulated_loop import simulate_loop
    from scara_ident_ros.paper.datasets import dataset_from_record, simulate_record
    from scara_ident_ros.paper.learning_curves import (CHECKPOINTS_S, held_out_set,
                                                             network_curve)
    from scara_ident_ros.sim import SimConfig

    seed, seconds, setting, held_out_s = job
    params = ScaraParams.from_yaml(ROOT / 'config' / 'scara.yaml')
    n = len(params.joint_names)
    figures: dict[str, Any] = {}
    with single_blas_thread():
        if setting is None:  # as the learning curves simulate it
            record = simulate_record(params, seconds=seconds, seed=seed, preset='sequence',
                                     config=SimConfig(seed=seed, n_joints=n))
        else:
            limits = load_motion_limits(urdf_file=str(URDF), joint_names=params.joint_names)
            loop = simulate_loop(params, limits, seconds=seconds, settings=LoopSettings(
                position_margin=setting[0], velocity_scale=setting[1],
                acceleration_scale=setting[2], seed=seed), config=SimConfig(seed=seed))
            record = loop.record
            t = loop.plan_times()
            moving = t >= 0.0
            error = record.q[moving] - loop.plan.evaluate(t[moving])[0]
            figures['tracking_max'] = np.abs(error).max(axis=0)
            figures['tracking_rms'] = np.sqrt(np.mean(error ** 2, axis=0))
            figures['approach_s'] = loop.plan.approach_duration
        held_out = held_out_set(params, excitation_s=held_out_s[0], sequence_s=held_out_s[1])
        checkpoints = tuple(c for c in CHECKPOINTS_S if c <= seconds) or (seconds,)
        curve = network_curve(record, held_out, params, method='ffs', trainer='lm', seed=seed,
                              checkpoints=checkpoints)
    stream = dataset_from_record(record, acceleration='estimated')  # as the network sees it
    X = stream.X
    figures.update(stream_stats(X[:, :n], X[:, n:2 * n], X[:, 2 * n:], params))
    low, high = X.min(axis=0), X.max(axis=0)
    outside = np.any((held_out.X < low) | (held_out.X > high), axis=1)
    figures['outside'] = float(outside.mean())
    figures['rest'] = float(np.mean(np.all(
        np.abs(record.qd) < REST * params.array('velocity_max'), axis=1)))
    label = SEQUENCE_LABEL if setting is None else setting_label(setting)
    return replace(curve, label=f'{label} (FFS lm)'), figures


def spread(values: list[float]) -> str:
    """median [min–max] of a figure over seeds."""
    from scara_ident_ros.paper.tables import format_value

    if len(values) == 1:
        return format_value(values[0])
    return (f'{format_value(float(np.median(values)))} [{format_value(min(values))}–'
            f'{format_value(max(values))}]')


def in_process(seconds: float, seeds: int, settings: list[Setting], workers: int,
               held_out_s: tuple[float, float]) -> None:
    """Part d: every stream and seed learnt in-process; the tables."""
    from scara_ident_ros.dynamics import ScaraParams
    from scara_ident_ros.paper.learning_curves import curves_markdown, held_out_set

    started = time.monotonic()
    streams: list[Setting | None] = [None, *settings]
    jobs = [(seed, seconds, setting, held_out_s) for setting in streams
            for seed in range(seeds)]
    if workers <= 1:
        results = [in_process_job(job) for job in jobs]
    else:
        with ProcessPoolExecutor(workers, mp_context=get_context('fork')) as pool:
            results = list(pool.map(in_process_job, jobs))
    params = ScaraParams.from_yaml(ROOT / 'config' / 'scara.yaml')
    n = len(params.joint_names)
    held_out = held_out_set(params, excitation_s=held_out_s[0], sequence_s=held_out_s[1])
    X = held_out.X
    reference = stream_stats(X[:, :n], X[:, n:2 * n], X[:, 2 * n:], params)
    print(f'### d. In-process: {seconds:g} s of stream, {seeds} seeds, FFS lm (load average '
          f'{os.getloadavg()[0]:.1f}, {time.monotonic() - started:.0f} s, {workers} '
          'workers)\n')
    print(curves_markdown([curve for curve, _ in results]))
    worst: dict[str, list[str]] = {}
    for curve, _ in results:
        worst.setdefault(curve.label, []).append(f'{curve.nmse[-1].max():.2e}')
    print(f'\nWorst joint at {seconds:g} s, seed by seed (0, 1, ...):\n')
    print('| stream | per seed |\n|---|---|')
    for label, values in worst.items():
        print(f'| {label} | {", ".join(values)} |')
    print(f'\nAmplitude: RMS of q − centre / half-range, of q\' and q\'\' / limit, per joint '
          f'({", ".join(params.joint_names)}), median over seeds; held-out samples outside '
          'the stream\'s per-joint ranges of q, q\', q\'\'; share of the stream at rest '
          f'(every |q\'| < {REST:g} of its limit); median [min–max] over seeds:\n')
    print('| stream | q − centre | q\' | q\'\' | held-out outside | at rest |')
    print('|---|---|---|---|---:|---:|')

    def joints(values: np.ndarray) -> str:
        return ', '.join(f'{v:.3f}' for v in values)
    print(f'| held-out ({X.shape[0]} samples) | ' + ' | '.join(
        joints(reference[key]) for key in ('position', 'velocity', 'acceleration'))
        + ' | — | — |')
    by_label: dict[str, list[dict[str, Any]]] = {}
    for curve, figures in results:
        by_label.setdefault(curve.label, []).append(figures)
    for label, group in by_label.items():
        cells = [joints(np.median([f[key] for f in group], axis=0))
                 for key in ('position', 'velocity', 'acceleration')]
        print(f'| {label} | ' + ' | '.join(cells) + f' | '
              f'{spread([100 * f["outside"] for f in group])} % | '
              f'{spread([100 * f["rest"] for f in group])} % |')
    print('\nTracking of the plan by the simulated arm from plan time 0 on (rad; joint3 m), '
          'the approach\'s duration:\n')
    print('| stream | max \\|e\\| per joint (max over seeds) | RMS per joint (median) | '
          'approach (s) |')
    print('|---|---|---|---|')
    for label, group in by_label.items():
        if 'tracking_max' not in group[0]:
            continue
        worst = np.max([f['tracking_max'] for f in group], axis=0)
        rms = np.median([f['tracking_rms'] for f in group], axis=0)
        print(f'| {label} | {", ".join(f"{v:.2e}" for v in worst)} | '
              f'{", ".join(f"{v:.2e}" for v in rms)} | '
              f'{spread([f["approach_s"] for f in group])} |')
    print()


def parse_setting(text: str) -> Setting:
    """``margin:velocity_scale:acceleration_scale`` as three floats."""
    try:
        margin, velocity, acceleration = (float(x) for x in text.split(':'))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f'{text!r} is not position_margin:velocity_scale:acceleration_scale') from None
    return margin, velocity, acceleration


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--seconds', type=float, default=10.0,
                        help='seconds of sequence after the approach (default 10)')
    parser.add_argument('--position-margin', type=float, default=NODE.position_margin)
    parser.add_argument('--velocity-scale', type=float, default=NODE.velocity_scale)
    parser.add_argument('--acceleration-scale', type=float, default=NODE.acceleration_scale)
    parser.add_argument('--identify', action='store_true',
                        help='part c: identifier on the loop and on the sequence, scored')
    parser.add_argument('--logs', type=Path, default=None, help='keep the node logs here')
    parser.add_argument('--in-process', action='store_true',
                        help='part d only: the loop simulated in-process, learnt as the '
                        'learning curves learn, beside scara_sim\'s sequence')
    parser.add_argument('--seeds', type=int, default=5, help='part d: seeds 0..SEEDS-1')
    parser.add_argument('--workers', type=int, default=2, help='part d: processes')
    parser.add_argument('--settings', type=parse_setting, nargs='+',
                        default=[(0.1, 0.5, 0.5), (0.1, 1.0, 1.0), (0.0, 1.0, 1.0)],
                        help='part d: loop settings position_margin:velocity_scale:'
                        'acceleration_scale (default 0.1:0.5:0.5 0.1:1:1 0:1:1)')
    parser.add_argument('--held-out', type=float, nargs=2, default=(6.0, 30.0),
                        metavar=('EXCITATION_S', 'SEQUENCE_S'),
                        help='part d: seconds of each held-out excitation and of the '
                        'held-out sequence')
    args = parser.parse_args()
    if args.in_process:
        in_process(args.seconds, args.seeds, args.settings, args.workers,
                   tuple(args.held_out))
        return 0
    plan_check(args.seconds, args.position_margin, args.velocity_scale,
               args.acceleration_scale)
    env = ros_env()
    with tempfile.TemporaryDirectory() as scratch:
        logs = args.logs or Path(scratch)
        logs.mkdir(parents=True, exist_ok=True)
        model = loop(args.seconds, args.position_margin, args.velocity_scale,
                     args.acceleration_scale, env, logs,
                     args.identify)
        if model is not None:
            reference = sequence_model(args.seconds, env, logs)
            score({f'loop ({args.seconds:g} s, margin {args.position_margin:g}, scales '
                   f'{args.velocity_scale:g}/'
                   f'{args.acceleration_scale:g})': (model, logs / 'loop_identifier.json'),
                   f'scara_sim sequence ({args.seconds:g} s)':
                       (reference, logs / 'sequence_identifier.json')})
    return 0


if __name__ == '__main__':
    sys.exit(main())
