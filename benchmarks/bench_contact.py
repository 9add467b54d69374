"""Contact detection from the identified model against a fixed raw-effort threshold.

An FFS network learns ``--seconds`` of ``scara_sim``'s default stream (``sequence``, 1 kHz,
sensor noise: position 1e-4, velocity 1e-3, effort 0.5 % of its limit) online as the
identifier does, then is frozen; the contact detector takes its thresholds from the held-out
residuals. On motion never learnt: ``--clean-seconds`` without contact (false alarms) and
``--pulse-seconds`` with external effort pulses (``--amplitude`` of a random joint's effort
limit for ``--pulse-ms``, about every 1.5 s) injected into the simulated dynamics (detection
rate, delay). The raw-effort baseline is set to the detector's false-alarm count on the clean
run (:mod:`scara_ident_ros.paper.contact`). One row per ``--sigmas`` value.

    .venv/bin/python benchmarks/bench_contact.py [--seconds 120] [--clean-seconds 600]
        [--pulse-seconds 300] [--sigmas 6 8 10] [--min-samples 1]

CI-sized: ``--seconds 20 --clean-seconds 10 --pulse-seconds 10``.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

from scara_ident_ros.blas_threads import single_blas_thread
from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.paper.contact import (baseline_flags, detect, evaluate, matched_baseline,
                                           pulse_record, residuals_of, train_model)
from scara_ident_ros.paper.learning_curves import noisy_config
from scara_ident_ros.identification.contact_detector import ContactDetector, robust_spread
from scara_ident_ros.nodes.identifier import PARAMETERS
from scara_ident_ros.resources import config_path

CLEAN_SEED, PULSE_SEED = 100, 200  # offsets of the unseen runs' seeds from the stream's
ARM_NMSE = next(spec.default for spec in PARAMETERS if spec.name == 'contact_arm_nmse')


def _ms(values: np.ndarray, q: float) -> str:
    return f'{np.quantile(values, q) * 1e3:.0f}' if values.size else '—'


def main() -> int:
    """Train, run the unseen motions, print a Markdown table."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--seconds', type=float, default=120.0, help='s of stream learnt')
    parser.add_argument('--clean-seconds', type=float, default=600.0)
    parser.add_argument('--pulse-seconds', type=float, default=300.0)
    parser.add_argument('--amplitude', type=float, default=0.1,
                        help="pulse size, fraction of the joint's effort limit")
    parser.add_argument('--pulse-ms', type=float, default=100.0)
    parser.add_argument('--sigmas', type=float, nargs='+', default=[6.0, 8.0, 10.0, 12.0, 16.0])
    parser.add_argument('--min-samples', type=int, default=1)
    parser.add_argument('--seed', type=int, default=0)
    args = parser.parse_args()
    params = ScaraParams.from_yaml(config_path('scara.yaml'))
    names = params.joint_names
    started = time.monotonic()
    seed = args.seed
    net, held_residuals, nmse, lag = train_model(
        params, seconds=args.seconds, seed=seed, config=noisy_config(params, seed))
    clean, _ = pulse_record(params, seconds=args.clean_seconds, seed=seed + CLEAN_SEED,
                            config=noisy_config(params, seed + CLEAN_SEED))
    noisy = noisy_config(params, seed + PULSE_SEED)
    pulsed, pulses = pulse_record(params, seconds=args.pulse_seconds, seed=seed + PULSE_SEED,
                                  config=noisy, amplitude=args.amplitude,
                                  pulse_s=args.pulse_ms / 1e3, spacing_s=1.0)
    _, clean_ext, clean_effort = residuals_of(net, clean, names)
    pulse_index, pulse_ext, pulse_effort = residuals_of(net, pulsed, names)
    dt = noisy.dt
    clean_s = len(clean_ext) * dt
    spread = robust_spread(held_residuals)
    print(f'### Contact detection: FFS learnt {args.seconds:g} s (validation NMSE {nmse:.3g}), '
          f'seed {seed}, load average {os.getloadavg()[0]:.1f}\n')
    print('Held-out residual spread 1.4826·MAD per joint: '
          + ', '.join(f'{v:.3g}' for v in spread)
          + f' (N·m, N·m, N, N·m); pulses {args.amplitude:.0%} of the effort limit = '
          + ', '.join(f'{args.amplitude * v:.3g}' for v in params.array('effort_max'))
          + f', {args.pulse_ms:g} ms; {len(pulses)} pulses in {args.pulse_seconds:g} s; '
          f'clean run {clean_s:.0f} s; min_samples {args.min_samples}; the prediction '
          f'follows its sample by {lag} samples ({lag * dt * 1e3:g} ms); the node would '
          f"{'' if nmse < ARM_NMSE else 'not '}arm detection at contact_arm_nmse "
          f'{ARM_NMSE:g}.\n')
    print('| contact_sigma | detected | delay median [p90] (ms, stamp) | false alarms / 10 min '
          '| raw-effort baseline: detected | its delay median (ms) | its false alarms / 10 min |')
    print('|---|---|---|---|---|---|---|')
    for sigma in args.sigmas:
        # armed whatever the NMSE: the rows measure the frozen model (the node arms it
        # only below contact_arm_nmse, said above)
        detector = ContactDetector(4, sigma=sigma, arm_nmse=max(2.0 * nmse, ARM_NMSE),
                                   min_samples=args.min_samples)
        detector.calibrate(held_residuals, nmse)
        clean_flags = detect(detector, clean_ext)
        detector.reset()
        detector.calibrate(held_residuals, nmse)
        run = evaluate(clean_flags, detect(detector, pulse_ext), pulse_index, pulses, dt=dt,
                       clean_s=clean_s)
        thresholds = matched_baseline(clean_effort, run.false_alarms)
        base = evaluate(baseline_flags(clean_effort, thresholds),
                        baseline_flags(pulse_effort, thresholds), pulse_index, pulses, dt=dt,
                        clean_s=clean_s)
        print(f'| {sigma:g} | {run.detected}/{run.pulses} ({run.rate:.1%}) | '
              f'{_ms(run.delays_s, 0.5)} [{_ms(run.delays_s, 0.9)}] | '
              f'{run.false_alarms_per_10_min:.2f} | {base.detected}/{base.pulses} '
              f'({base.rate:.1%}) | {_ms(base.delays_s, 0.5)} | '
              f'{base.false_alarms_per_10_min:.2f} |')
    print(f'\n{time.monotonic() - started:.0f} s wall')
    return 0


if __name__ == '__main__':
    with single_blas_thread():
        sys.exit(main())
