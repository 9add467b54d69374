"""``scara-ident run``: the whole identification graph in one command.

Starts, as separate processes, the MCAP recorder, one identifier serving FFMW, FFW and FFS
(under ``/ffmw``, ``/ffw``, ``/ffs``, one subscription to ``/joint_states``) and the
simulated SCARA, their threads under ``SCHED_FIFO`` where the user may (simulator first,
then identifier, then recorder: :data:`~scara_ident_ros.nodes.realtime.GRAPH_PRIORITIES`;
the learners at normal priority). Each waits for its own subscribers; the simulator
publishes ``--duration`` seconds at 1 kHz and stops; then the identifier (it publishes its
last, pending predictions and saves the models) and the recorder are stopped with SIGINT,
in that order. A summary accounts for every
published sample per method (predicted, skipped, lost, not drained) and gives each method's
errors; unless ``--no-report`` the tables and figures follow (``scara-ident tables``).

It refuses to start (exit 2) if another graph already publishes ``/joint_states`` or the
identifiers' topics, unless ``--allow-other-graph``. Ctrl-C or SIGTERM stops the graph
the same way, early (the nodes run in sessions of their own, so only this command gets
the terminal's SIGINT); a second Ctrl-C skips the report. Exit status: 0, 130 after a
signal, 1 if a node failed.

Output directory layout (``--out DIR``)::

    DIR/bag/            the MCAP rosbag2 bag (or --bag PATH)
    DIR/models/M.npz    each method's network at the end of the run
    DIR/logs/*.log      each process's output
    DIR/stats/*.json    each process's final counters
    DIR/summary.json    the summary printed at the end
    DIR/report/         tables and figures (report.md)
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import time
from pathlib import Path
from typing import Any

from scara_ident_ros.cli import CliError
from scara_ident_ros.cli.run_summary import JointStatesUse, MethodRow, RunSummary
from scara_ident_ros.identification.trainer import TRAINERS
from scara_ident_ros.identification.learner_methods import LEARNER_METHODS
from scara_ident_ros.nn.presets import METHODS
from scara_ident_ros.nodes.realtime import GRAPH_PRIORITIES
from scara_ident_ros.paths import unwritable_dir
from scara_ident_ros.cli.process_graph import (NodeProcess, ProcessGraph, StopSignals,
                                           publishers_on)
from scara_ident_ros.sim.registry import SEQUENCE, TRAJECTORIES
from scara_ident_ros.topics import IDENTIFIER_OUTPUTS, JOINT_STATES, in_namespace, torque_topic

__all__ = ['add_parser', 'run', 'bag_message_counts']

STARTUP_TIMEOUT = 60.0  # s allowed for the processes to start and discover each other
DRAIN_TIME = 1.0  # s the consumers get to drain their queues after the last sample
POLL_PERIOD = 0.1  # s between two looks at the processes and the stop signals
INTERRUPTED = 130  # exit status after a Ctrl-C (128 + SIGINT), as a shell reports it
JOINT_STATES_TOPIC = in_namespace(JOINT_STATES)  # the robot's: the identifier takes it
IDENTIFIER = 'identifier'  # the identifier's process, logs and node name
RECORDER = '/recorder'  # the recorder's node, fully qualified
END_HISTORY_AFTER = 0.1  # s after the last sample: its predictions (the identifier's)


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``scara-ident run``."""
    parser = subparsers.add_parser(
        'run', help='run simulator, the identifier (three networks) and the recorder; summarise',
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--duration', type=float, default=60.0,
                        help='seconds of simulated samples at 1 kHz (default: 60)')
    parser.add_argument('--out', type=Path, default=Path('out/run'),
                        help='output directory (default: out/run)')
    parser.add_argument('--bag', type=Path, default=None,
                        help='bag directory to record (default: OUT/bag); must not exist')
    parser.add_argument('--methods', nargs='+', default=list(METHODS),
                        choices=[*METHODS, *LEARNER_METHODS],
                        help='identifiers to run side by side (default: the three networks; '
                             'kernel and gp are the kernel learners)')
    parser.add_argument('--trajectory', default=SEQUENCE,
                        help=f'excitation, one of {", ".join(TRAJECTORIES)} (default: '
                             f'{SEQUENCE}, a new random excitation every 5 s)')
    parser.add_argument('--seed', type=int, default=0, help='excitation seed')
    parser.add_argument('--trainer', default='lm', choices=list(TRAINERS),
                        help="identifiers' online training: lm (Levenberg-Marquardt on a "
                             "reservoir of the stream, the identifier's default) or bp (the "
                             "paper's per-sample back-propagation)")
    parser.add_argument('--lm-interval', type=int, default=0,
                        help="least new samples between two updates of each lm trainer "
                             "(default: the identifier's lm_interval); the trainers learn "
                             'beside the stream, as often as the CPU allows')
    parser.add_argument('--compression', default='zstd', choices=('zstd', 'none'),
                        help='MCAP chunk compression of the bag (default: zstd)')
    parser.add_argument('--no-report', dest='report', action='store_false',
                        help='skip the tables and figures at the end')
    parser.add_argument('--allow-other-graph', action='store_true',
                        help='start even if another graph already publishes /joint_states '
                             "or the identifiers' topics on this ROS domain (its samples "
                             'then mix with this run\'s)')
    parser.add_argument('--robot', default=None, metavar='NAME',
                        help='simulate this example-robot-data arm with robot_sim instead of '
                             'the SCARA (ur5, panda, ...); the identifiers get its URDF and '
                             'acceleration limits (default: the SCARA, scara_sim)')
    parser.set_defaults(func=run)


def bag_message_counts(bag: Path) -> dict[str, int]:
    """Messages per topic of a bag, as its ``metadata.yaml`` says (empty if unreadable)."""
    from scara_ident_ros.bag import BagError, open_bag

    try:
        with open_bag(bag) as source:
            return {topic: info.count for topic, info in source.topics.items()}
    except BagError:
        return {}


def _read_json(path: Path) -> dict[str, Any]:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return {}


def run(args: argparse.Namespace) -> int:
    """Run the graph, print the summary, produce the report; return the exit status."""
    if args.duration <= 0:
        raise CliError(f'--duration must be > 0, got {args.duration}')
    if args.trajectory not in TRAJECTORIES:
        raise CliError(f'--trajectory must be one of {", ".join(TRAJECTORIES)}, '
                       f'got {args.trajectory!r}')
    if args.lm_interval < 0:
        raise CliError(f'--lm-interval must be >= 1, got {args.lm_interval}')
    if len(set(args.methods)) != len(args.methods):
        raise CliError(f'--methods names a method twice: {" ".join(args.methods)} (each runs '
                       'one identifier under its own namespace)')
    out: Path = args.out
    problem = unwritable_dir(out)
    if problem:
        raise CliError(f'--out {out} {problem}')
    bag: Path = args.bag or out / 'bag'
    if bag.exists():
        raise CliError(f'{bag} exists already, not overwriting (choose another --out or --bag)')
    if not args.allow_other_graph:
        _refuse_other_graph(args.methods)
    stats, models = out / 'stats', out / 'models'
    for directory in (stats, models):
        directory.mkdir(parents=True, exist_ok=True)

    sim_name, sim_args, robot_args = _simulator(getattr(args, 'robot', None))
    graph = ProcessGraph(out / 'logs')
    graph.start(NodeProcess('recorder', 'scara_ident_ros.nodes.recorder', [
        '-p', f'output:={bag}', '-p', f'compression:={args.compression}',
        '-p', f'stats_file:={stats / "recorder.json"}',
        '-p', f'realtime_priority:={GRAPH_PRIORITIES["recorder"]}']))
    graph.start(NodeProcess(IDENTIFIER, 'scara_ident_ros.nodes.identifier', [
        '-r', f'{JOINT_STATES}:={JOINT_STATES_TOPIC}',
        '-p', f'methods:=[{",".join(args.methods)}]',
        '-p', f'save_path:={models}/{{method}}.npz', '-p', f'trainer:={args.trainer}',
        # not recorded: measured - predicted is in the bag already (joint_states and
        # identified_torque); contacts are still detected and published
        '-p', 'external_torque:=false',
        *(['-p', f'lm_interval:={args.lm_interval}'] if args.lm_interval else []),
        # subscribe /joint_states only once the recorder records every method's outputs:
        # the simulator's wait below then covers the predictions too
        '-p', 'wait_for_subscribers:=1', '-p', f'wait_for_nodes:=[{RECORDER}]',
        '-p', f'wait_timeout:={STARTUP_TIMEOUT}',
        '-p', f'stats_file:={stats}/{{method}}.json',
        # the last samples' predictions when the simulator ends, not when the identifier stops
        '-p', f'end_history_after:={END_HISTORY_AFTER}',
        '-p', f'realtime_priority:={GRAPH_PRIORITIES[IDENTIFIER]}', *robot_args]))
    sim = graph.start(NodeProcess(sim_name, f'scara_ident_ros.nodes.{sim_name}', [
        '-p', f'duration:={args.duration}', '-p', f'trajectory:={args.trajectory}',
        '-p', f'seed:={args.seed}', '-p', 'wait_for_subscribers:=2',
        # this run's two, not any two: a user's recorder or `scara-ident lag` may be there
        '-p', f'wait_for_nodes:=[{RECORDER},/{IDENTIFIER}]',
        '-p', f'wait_timeout:={STARTUP_TIMEOUT}',
        '-p', f'stats_file:={stats / "scara_sim.json"}',
        '-p', f'realtime_priority:={GRAPH_PRIORITIES["simulator"]}', *sim_args]))
    print(f'scara-ident run: {args.duration:g} s at 1 kHz, identifying with '
          f'{", ".join(m.upper() for m in args.methods)}, recording {bag}', flush=True)
    with StopSignals() as signals:
        try:
            _watch(graph, sim, signals, args.duration)
        finally:
            codes = graph.stop_all()
    interrupted = signals.received is not None
    failed = {name: code for name, code in codes.items() if code != 0}
    summary = _summary(args.methods, stats, bag, out, codes, interrupted=interrupted)
    (out / 'summary.json').write_text(json.dumps(summary.as_dict(), indent=1))
    _print_summary(summary)
    if failed:
        for name in failed:
            print(f'--- {name} exited with {failed[name]}; log {out / "logs" / name}.log:')
            print(graph.log_text(next(n for n in graph.nodes if n.name == name))[-2000:])
        return 1
    if args.report:
        _report(bag, out / 'report', args.methods, interrupted=interrupted)
    return INTERRUPTED if interrupted else 0


def _refuse_other_graph(methods: list[str]) -> None:
    """Raise CliError if another graph already publishes this run's topics on the domain."""
    found = publishers_on([JOINT_STATES_TOPIC, *(
        in_namespace(topic, method) for method in methods for topic in IDENTIFIER_OUTPUTS)])
    if found:
        listed = ', '.join(f'{topic} ({count} publisher{"s" if count > 1 else ""})'
                           for topic, count in found.items())
        domain = os.environ.get('ROS_DOMAIN_ID', '0')
        raise CliError(f'another graph already publishes on ROS domain {domain}: {listed}; '
                       "its samples would mix with this run's. Stop it, set another "
                       'ROS_DOMAIN_ID, or pass --allow-other-graph')


def _watch(graph: ProcessGraph, sim: NodeProcess, signals: StopSignals,
           duration: float) -> None:
    """Return when the simulator is done (and the consumers had time to drain), a node has
    failed, the simulator is hopelessly slow, or a stop signal came (Ctrl-C)."""
    started = time.monotonic()
    while sim.returncode is None and not graph.failed():
        if signals.received is not None:
            break
        time.sleep(POLL_PERIOD)
        if time.monotonic() - started > duration * 3 + STARTUP_TIMEOUT:
            print('scara-ident run: the simulator is far behind real time; stopping',
                  flush=True)
            return
    drained = time.monotonic() + DRAIN_TIME
    while signals.received is None and time.monotonic() < drained:
        time.sleep(POLL_PERIOD)
    if signals.received is not None:
        print(f'scara-ident run: {signal.Signals(signals.received).name}: stopping the graph '
              '(simulator, identifier, recorder, in that order)', flush=True)


def _report(bag: Path, out: Path, methods: list[str], *, interrupted: bool) -> None:
    """Make the tables and figures from the bag; after a Ctrl-C, from what it recorded."""
    from scara_ident_ros.bag import BagError
    from scara_ident_ros.cli.tables import make_report
    from scara_ident_ros.identification.recording import RecordingError
    from scara_ident_ros.identification.split import SplitError

    if interrupted:
        print('scara-ident run: making the report from the samples recorded (Ctrl-C again '
              'to skip it)', flush=True)
    try:
        report = make_report([bag], out, methods=methods)
    except (BagError, RecordingError, ValueError) as exc:
        if not interrupted and not isinstance(exc, SplitError):  # too short to validate on
            raise
        print(f'scara-ident run: no report: {exc}')
        return
    print(f'scara-ident run: report in {report}')


def _summary(methods: list[str], stats: Path, bag: Path, out: Path,
             codes: dict[str, int], *, interrupted: bool) -> RunSummary:
    sim = _read_json(stats / 'scara_sim.json')
    recorder = _read_json(stats / 'recorder.json')
    counts = bag_message_counts(bag)
    published = sim.get('published')
    rows = {name: MethodRow.of(_read_json(stats / f'{name}.json'), published,
                               counts.get(torque_topic(name)),
                               str(out / 'models' / f'{name}.npz'))
            for name in methods}
    joint_states = JointStatesUse(
        published=published, late=sim.get('late'), recorded=counts.get(JOINT_STATES_TOPIC),
        lost=recorder.get('lost', {}).get(JOINT_STATES_TOPIC),
        publishers=recorder.get('publishers', {}).get(JOINT_STATES_TOPIC))
    return RunSummary(bag=str(bag), exit_codes=codes, joint_states=joint_states,
                      recorder=recorder, methods=rows, interrupted=interrupted)


def _fmt(value: Any) -> str:
    if value is None:
        return '–'
    if isinstance(value, float):
        return f'{value:.4g}'
    return str(value)


def _print_summary(summary: RunSummary) -> None:
    js = summary.joint_states
    print(f'\n/joint_states: published {_fmt(js.published)}, recorded '
          f'{_fmt(js.recorded)}, late {_fmt(js.late)}, lost {_fmt(js.lost)}')
    if (js.publishers or 0) > 1:
        print(f"WARNING: {js.publishers} publishers on /joint_states during the run: "
              "another graph's samples are mixed with this run's in the bag and the models")
    print('\n| method | trainer | predicted | skipped | lost | not drained | learnt '
          '| held out | updates (/s) | identified_torque published | recorded '
          '| final MSE (windowed) | final NMSE | validation NMSE |')
    print('|---|---|---|---|---|---|---|---|---|---|---|---|---|---|')
    for name, row in summary.methods.items():
        use = row.use
        updates = _fmt(row.updates)
        if row.updates_per_s is not None:
            updates += f' ({row.updates_per_s:.1f})'
        print(f'| {name.upper()} | {_fmt(row.trainer)} | {_fmt(use.predicted)} | '
              f'{use.skipped.total} | {_fmt(use.lost)} | {_fmt(use.not_drained)} | '
              f'{_fmt(row.learnt)} | {_fmt(row.held_out)} | {updates} | '
              f'{_fmt(row.published)} | {_fmt(row.recorded)} | {_fmt(row.mse_total)} | '
              f'{_fmt(row.nmse_total)} | {_fmt(row.validation_nmse_total)} |')
    print()
    for name, row in summary.methods.items():
        use = row.use
        if use.shortfall or use.predicted is None:
            print(f'WARNING: {name.upper()} predicted {_fmt(use.predicted)} of the '
                  f'{_fmt(js.published)} samples published: skipped {use.skipped}; lost '
                  f'before the identifier {_fmt(use.lost)}; not drained when it stopped '
                  f'{_fmt(use.not_drained)}')
        elif row.recorded is not None and row.recorded != use.predicted:
            print(f'WARNING: {name.upper()}: {use.predicted} predictions published, '
                  f'{row.recorded} recorded')


# -- --robot: an example-robot-data arm simulated by robot_sim instead of the SCARA --------

def _simulator(robot: str | None) -> tuple[str, list[str], list[str]]:
    """The simulator node, its extra arguments and the identifiers' extra arguments: for a
    robot name, ``robot_sim`` with ``robot:=NAME`` and the identifiers get its URDF, joints
    and derived acceleration limits; its counters still go to ``stats/scara_sim.json``."""
    if robot is None:
        return 'scara_sim', [], []
    # imported here: pinocchio is loaded for --robot runs only
    from scara_ident_ros.sim.example_robots import ExampleRobotError, example_robot
    from scara_ident_ros.sim.pinocchio_robot import PinocchioRobot

    try:
        entry = example_robot(robot)
    except ExampleRobotError as exc:
        raise CliError(f'--robot: {exc}') from None
    model = PinocchioRobot.from_urdf(entry.urdf, joints=entry.joints)
    names = ','.join(model.joint_names)
    limits = ','.join(repr(float(a)) for a in model.acceleration_max)
    return 'robot_sim', ['-p', f'robot:={robot}'], [
        '-p', f'urdf_file:={entry.urdf}', '-p', f'joint_names:=[{names}]',
        '-p', f'acceleration_max:=[{limits}]']
