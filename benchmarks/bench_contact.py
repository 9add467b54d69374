"""Contact detection on unseen motion: false alarms, pulses detected, the decision's delay.

An FFS network learns ``--seconds`` of a stream online as the identifier does (synchronous
``lm``, 10 % held-out blocks), then is frozen; the contact detector is calibrated as the node
calibrates it (:class:`~scara_ident_ros.identification.contact_detector.ContactDetector`:
thresholds from the tail of the residuals for ``contact_false_alarms_per_hour``, the arming
rule, the q, q' envelope), on the a-priori residuals of the last ``--recent-seconds`` of
stream (each sample predicted before it was learnt: the node's default) and, beside it, on
the held-out segments (the node's calibration before). On motion never
learnt: ``--clean-seconds`` without contact (false alarms: rising edges of "some joint
flagged") and ``--pulse-seconds`` with external effort pulses (``--amplitude`` of the effort
limit of each joint in turn, random sign, ``--pulse-ms`` long, about every 1.5 s) applied to
the simulated dynamics (detected per joint; the decision's delay from the pulse's start: the
first flagged sample's stamp plus the q'' estimate's lag, the machine's own delay apart: the
node reports it, ``bench_graph.py``). One row per calibration and ``--bounds`` value, and
the detector before those (12 robust sigmas of the held-out residuals).

While it learns, a detector of the node's defaults is calibrated every
``contact_calibration_period`` s of stream, as the node calibrates it on the model of that
moment: the stream time it is first armed, whether it stays armed, and when every threshold
is first under its joint's pulse.

The runs are deterministic given the options and the seed: ``--cache runs.npz`` keeps what
the detectors are evaluated on (residuals, inputs, pulses; written if missing, else read),
so that calibrations can be compared without simulating again.

``--stream loop`` (default): the issue's loop, ``excitation`` -> ``scara_sim
trajectory:=external`` (:func:`~scara_ident_ros.paper.contact.loop_record`), without sensor
noise as ``scara_sim`` by default (``--noise``: the noisy learning curves' sensor noise);
``--stream sequence``: ``scara_sim``'s own ``sequence``.

    .venv/bin/python benchmarks/bench_contact.py [--seconds 120] [--clean-seconds 600]
        [--pulse-seconds 300] [--bounds 1] [--seed 0] [--stream loop|sequence] [--noise]
        [--recent-seconds 25] [--envelope-margin 0.5] [--cache runs.npz]

Below the table, each calibration's room per joint: the largest |τ_ext − centre| it checks
on the clean run and the smallest, over the joint's pulses, of the largest it checks within
20 ms of the pulse's start (the q'' wait counted): a threshold between the two finds every
pulse within 20 ms without a false alarm.

CI-sized: ``--seconds 20 --clean-seconds 5 --pulse-seconds 5`` (too few held-out blocks to
arm the calibration before: the row says so).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable

import numpy as np

from scara_ident_ros.blas_threads import single_blas_thread
from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.identification import InputStage, JointMap
from scara_ident_ros.paper.contact import (Pulse, Trained, detect, evaluate, pulse_record,
                                           residuals_of, train_model)
from scara_ident_ros.sim import SimConfig, SimRecord
from scara_ident_ros.paper.learning_curves import noisy_config
from scara_ident_ros.identification.contact_detector import (A_PRIORI, HELD_OUT,
                                                             RECENT_S, Calibration,
                                                             ContactDetector, robust_spread)
from scara_ident_ros.nodes.identifier import PARAMETERS
from scara_ident_ros.resources import config_path

CLEAN_SEED, PULSE_SEED = 100, 200  # offsets of the unseen runs' seeds from the stream's
ARM_NMSE = next(spec.default for spec in PARAMETERS if spec.name == 'contact_arm_nmse')
ENVELOPE_MARGIN = next(spec.default for spec in PARAMETERS
                       if spec.name == 'contact_envelope_margin')
CALIBRATION_PERIOD = next(spec.default for spec in PARAMETERS
                          if spec.name == 'contact_calibration_period')


def _ms(values: np.ndarray, q: float) -> str:
    return f'{np.quantile(values, q) * 1e3:.0f}' if values.size else '—'


def main() -> int:
    """Train, run the unseen motions, print a Markdown table."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--stream', choices=('loop', 'sequence'), default='loop',
                        help="loop: excitation -> scara_sim trajectory:=external (the issue's "
                        "target); sequence: scara_sim's own")
    parser.add_argument('--noise', action='store_true',
                        help='sensor noise (default: none, as scara_sim by default)')
    parser.add_argument('--seconds', type=float, default=120.0, help='s of stream learnt')
    parser.add_argument('--clean-seconds', type=float, default=600.0)
    parser.add_argument('--pulse-seconds', type=float, default=300.0)
    parser.add_argument('--amplitude', type=float, default=0.1,
                        help="pulse size, fraction of the joint's effort limit")
    parser.add_argument('--pulse-ms', type=float, default=100.0)
    parser.add_argument('--bounds', type=float, nargs='+', default=[1.0],
                        help='contact_false_alarms_per_hour values, one row each')
    parser.add_argument('--min-samples', type=int, default=1)
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--recent-seconds', type=float, default=RECENT_S,
                        help='s of a-priori residuals the thresholds are calibrated on')
    parser.add_argument('--envelope-margin', type=float, default=ENVELOPE_MARGIN,
                        help="contact_envelope_margin: widening of the calibrated q, q' range")
    parser.add_argument('--cache', default='',
                        help='.npz of the runs (residuals, inputs, pulses): written if '
                        'missing, else read instead of simulating again (the same seed and '
                        'options give the same runs)')
    args = parser.parse_args()
    params = ScaraParams.from_yaml(config_path('scara.yaml'))
    started = time.monotonic()
    seed = args.seed

    def config(s: int) -> SimConfig:
        return noisy_config(params, s) if args.noise else SimConfig(seed=s, n_joints=4)

    data = _load(args.cache) if args.cache and os.path.exists(args.cache) else None
    if data is None:
        data = _simulate(args, params, config)
        if args.cache:
            np.savez_compressed(args.cache, **data)
    pulses = [Pulse(int(a), int(b), int(c), float(d)) for a, b, c, d in data['pulses']]
    clean_ext, clean_x = data['clean_ext'], data['clean_x']
    pulse_index, pulse_ext, pulse_x = data['pulse_index'], data['pulse_ext'], data['pulse_x']
    nmse, lag = float(data['nmse']), int(data['lag'])
    trained = _trained(data, '')
    timelines = {on: [(float(t), _calibrate(_node_detector(args, on), _trained(data, f'at{i}_')))
                      for i, t in enumerate(data['times'])] for on in (A_PRIORI, HELD_OUT)}
    dt = 1e-3
    clean_s = len(clean_ext) * dt
    segments = trained.residuals
    spread = robust_spread(segments.reshape(-1, 4))
    print(f'### Contact detection on the {args.stream} stream '
          f"({'with' if args.noise else 'without'} sensor noise): FFS learnt "
          f'{args.seconds:g} s (validation NMSE {nmse:.3g}), seed {seed}, load average '
          f'{os.getloadavg()[0]:.1f}\n')
    print(f'{len(segments)} held-out segments of {segments.shape[1]} samples '
          f'({len(set(trained.blocks.tolist()))} blocks); residual spread '
          '1.4826·MAD per joint: ' + ', '.join(f'{v:.3g}' for v in spread)
          + f' (N·m, N·m, N, N·m); pulses {args.amplitude:.0%} of the effort limit = '
          + ', '.join(f'{args.amplitude * v:.3g}' for v in params.array('effort_max'))
          + f', {args.pulse_ms:g} ms, on each joint in turn; {len(pulses)} pulses in '
          f'{args.pulse_seconds:g} s; clean run {clean_s:.0f} s; min_samples '
          f'{args.min_samples}; a decision is made {lag} samples ({lag * dt * 1e3:g} ms) '
          'after its sample (the zero-phase q\'\'), plus the machine\'s delay (the node\'s '
          'diagnostics).\n')
    for on, timeline in timelines.items():
        print(f'Calibrated on the {on} residuals: '
              f"{_arming(timeline, args.amplitude * params.array('effort_max'))}\n")
    print('| detector | armed (why not) | thresholds | est. false alarms/h | detected | '
          'per joint | decision delay from the pulse start p50 / p99 (ms, stamp + lag) | '
          'false alarms / 10 min | samples held (envelope), clean / pulses |')
    print('|---|---|---|---|---|---|---|---|---|')
    rows = [(f'{on}' + (f' {args.recent_seconds:g} s' if on == A_PRIORI else ' (before)')
             + f', bound {b:g}/h', ContactDetector(
        4, min_samples=args.min_samples, false_alarms_per_hour=b,
        arm_nmse=max(2.0 * nmse, ARM_NMSE), calibrate_on=on,
        recent_s=args.recent_seconds, envelope_margin=args.envelope_margin))
        for on in (A_PRIORI, HELD_OUT) for b in args.bounds]
    rooms = []
    for name, detector in rows:
        calibration = _calibrate(detector, trained)
        rooms.append(f'{name}: ' + _room(calibration, data, pulses, round(0.02 / dt) - lag))
        clean_flags = detect(detector, clean_ext, clean_x)
        held_clean, detector.held = detector.held, 0
        pulse_flags = detect(detector, pulse_ext, pulse_x)
        run = evaluate(clean_flags, pulse_flags, pulse_index, pulses, dt=dt, clean_s=clean_s)
        per_joint = [sum(1 for p in pulses if p.joint == j) for j in range(4)]
        hit = _detected_per_joint(pulse_flags, pulse_index, pulses, dt)
        delays = run.delays_s + lag * dt
        thresholds = ('—' if calibration.thresholds is None
                      else ', '.join(f'{v:.3g}' for v in calibration.thresholds))
        rate = calibration.false_alarms_per_hour
        print(f"| {name} | {'yes' if detector.armed else 'no (' + calibration.why_not + ')'} "
              f"| {thresholds} | {'—' if rate is None else f'{rate:.2g}'} | "
              f'{run.detected}/{run.pulses} | '
              + ', '.join(f'{h}/{t}' for h, t in zip(hit, per_joint))
              + f' | {_ms(delays, 0.5)} / {_ms(delays, 0.99)} | '
              f'{run.false_alarms_per_10_min:.2f} | {held_clean} / {detector.held} |')
    before = 12.0 * spread  # the detector before: 12 robust sigmas, no tail, no envelope
    run = evaluate(np.abs(clean_ext) > before, np.abs(pulse_ext) > before, pulse_index,
                   pulses, dt=dt, clean_s=clean_s)
    print(f"| before: 12 x 1.4826·MAD | (NMSE gate) | {', '.join(f'{v:.3g}' for v in before)} "
          f'| — | {run.detected}/{run.pulses} | | '
          f'{_ms(run.delays_s + lag * dt, 0.5)} / {_ms(run.delays_s + lag * dt, 0.99)} | '
          f'{run.false_alarms_per_10_min:.2f} | |')
    print('\nRoom per joint, largest checked |τ_ext − centre| on the clean run < smallest '
          'pulse\'s within 20 ms (N·m, N·m, N, N·m):\n')
    print('\n'.join(f'- {room}' for room in rooms))
    print(f'\n{time.monotonic() - started:.0f} s wall')
    return 0


Data = dict[str, np.ndarray]
TRAINED_FIELDS = ('residuals', 'inputs', 'blocks', 'nmse', 'prior', 'prior_inputs')


def _simulate(args: argparse.Namespace, params: ScaraParams,
              config: Callable[[int], SimConfig]) -> Data:
    """Learn the stream (a calibration's data every ``contact_calibration_period`` s), run
    the unseen motions, and keep what the detectors are evaluated on."""
    names, seed = params.joint_names, args.seed
    data: Data = {}
    times: list[float] = []

    def keep(t: float, now: Trained) -> None:
        data.update(_fields(now, f'at{len(times)}_'))
        times.append(t)

    trained = train_model(params, seconds=args.seconds, seed=seed, config=config(seed),
                          stream=args.stream, every_s=CALIBRATION_PERIOD, on_every=keep)
    data.update(_fields(trained, ''))
    clean, _ = pulse_record(params, seconds=args.clean_seconds, seed=seed + CLEAN_SEED,
                            config=config(seed + CLEAN_SEED), stream=args.stream)
    pulsed, pulses = pulse_record(params, seconds=args.pulse_seconds, seed=seed + PULSE_SEED,
                                  config=config(seed + PULSE_SEED), amplitude=args.amplitude,
                                  pulse_s=args.pulse_ms / 1e3, spacing_s=1.0,
                                  stream=args.stream)
    _, data['clean_ext'], _ = residuals_of(trained.net, clean, names)
    data['pulse_index'], data['pulse_ext'], _ = residuals_of(trained.net, pulsed, names)
    data['clean_x'], data['pulse_x'] = _inputs(clean, names), _inputs(pulsed, names)
    data['pulses'] = np.array([(p.start, p.length, p.joint, p.effort) for p in pulses],
                              dtype=float).reshape(-1, 4)
    data['times'], data['lag'] = np.array(times), np.array(trained.lag)
    return data


def _fields(trained: Trained, prefix: str) -> Data:
    return {prefix + name: np.asarray(getattr(trained, name)) for name in TRAINED_FIELDS}


def _trained(data: Data, prefix: str) -> Trained:
    """A calibration's data back from :func:`_fields` (without the network)."""
    values = {name: data[prefix + name] for name in TRAINED_FIELDS}
    return Trained(None, values['residuals'], values['inputs'],  # type: ignore[arg-type]
                   values['blocks'].astype(np.int64), float(values['nmse']), int(data['lag']),
                   values['prior'], values['prior_inputs'])


def _load(path: str) -> Data:
    with np.load(path) as archive:
        return {name: archive[name] for name in archive.files}


def _node_detector(args: argparse.Namespace, calibrate_on: str) -> ContactDetector:
    """A detector of the node's defaults (the first ``--bounds``) calibrated on
    ``calibrate_on``."""
    return ContactDetector(4, min_samples=args.min_samples,
                           false_alarms_per_hour=args.bounds[0], calibrate_on=calibrate_on,
                           recent_s=args.recent_seconds, envelope_margin=args.envelope_margin)


def _room(calibration: Calibration, data: Data, pulses: list[Pulse], samples: int) -> str:
    """Per joint, the largest |τ_ext − centre| the calibration checks on the clean run and
    the smallest over the joint's pulses of the largest it checks in the pulse's first
    ``samples`` samples (module docstring: the room for a threshold)."""
    centre, lo, hi = calibration.centre, calibration.lo, calibration.hi
    if centre is None:
        return 'not calibrated'

    def checked(ext: np.ndarray, x: np.ndarray) -> np.ndarray:
        deviation = np.abs(ext - centre)
        if lo is not None and hi is not None:
            deviation[~np.all((x >= lo) & (x <= hi), axis=1)] = 0.0
        return deviation

    clean = checked(data['clean_ext'], data['clean_x']).max(axis=0)
    pulsed, index = checked(data['pulse_ext'], data['pulse_x']), data['pulse_index']
    smallest = np.full(len(centre), np.inf)
    for pulse in pulses:
        rows = (index >= pulse.start) & (index < pulse.start + samples + 1)
        found = pulsed[rows, pulse.joint].max() if rows.any() else 0.0
        smallest[pulse.joint] = min(smallest[pulse.joint], found)
    thresholds = calibration.thresholds
    return '; '.join(f'{c:.3g} < {p:.3g}' + (f' (threshold {t:.3g})' if thresholds is not None
                                            else '')
                     for c, p, t in zip(clean, smallest, thresholds if thresholds is not None
                                        else smallest))


def _calibrate(detector: ContactDetector, trained: Trained) -> Calibration:
    """Calibrate ``detector`` as the node does on ``trained``: the stream's a-priori
    residuals it has checked, the held-out segments."""
    detector.observe(trained.prior, trained.prior_inputs)
    return detector.calibrate(trained.residuals, trained.nmse, inputs=trained.inputs,
                              sample_period_s=1e-3, blocks=trained.blocks)


def _arming(timeline: list[tuple[float, Calibration]], pulses: np.ndarray) -> str:
    """When the detector of the node's defaults was first armed, when its thresholds were
    first all under the pulses (N·m or N per joint), and what each calibration said."""
    armed = [t for t, c in timeline if not c.why_not]

    def ratio(c: Calibration) -> float:
        return float(np.max(c.thresholds / pulses)) if c.thresholds is not None else np.inf

    steps = '; '.join(f'{t:g} s: ' + (c.why_not or f'armed ({c.independent:.0f} draws, '
                                      f'thresholds up to {ratio(c):.2g} x the pulse)')
                      for t, c in timeline)
    if not armed:
        return f'**Not armed** in {timeline[-1][0] if timeline else 0:g} s ({steps}).'
    since = [t for t, c in timeline if t >= armed[0] and c.why_not]
    under = [t for t, c in timeline if not c.why_not and ratio(c) < 1.0]
    return (f'**Armed at {armed[0]:g} s** of stream (a calibration every '
            f'{CALIBRATION_PERIOD:g} s, node defaults), '
            + ('armed at every calibration since' if not since
               else f'disarmed again at {", ".join(f"{t:g}" for t in since)} s')
            + (f', every threshold under its pulse first at **{under[0]:g} s**' if under
               else ', a threshold over its pulse at every calibration')
            + f' ({steps}).')


def _inputs(record: SimRecord, names: tuple[str, ...]) -> np.ndarray:
    """The input [q, q', q''] (K, 12) of each predicted sample, through the input stage."""
    stage = InputStage(JointMap(names, n_joints=4))
    _, X, _ = stage.batch(record.stamp_ns, names, record.q, record.qd, record.effort)
    return np.asarray(X)


def _detected_per_joint(flags: np.ndarray, index: np.ndarray, pulses: list[Pulse],
                        dt: float) -> list[int]:
    hits = [0, 0, 0, 0]
    tail = round(0.05 / dt)
    for pulse in pulses:
        rows = (index >= pulse.start) & (index < pulse.start + pulse.length + tail)
        if flags[rows, pulse.joint].any():
            hits[pulse.joint] += 1
    return hits


if __name__ == '__main__':
    with single_blas_thread():
        sys.exit(main())
