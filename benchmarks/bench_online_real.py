"""A real recording through the identifier's session, in stream order, without ROS.

What ``scara-ident play RECORDING`` into ``identifier`` does to the samples, minus the
transport and the timing: every row of the recording (``../shared/realdata``) goes through
:class:`~scara_ident_ros.identification.session.IdentificationSession` with the identifier's
defaults (``config/identifier.yaml``) and the settings given, the ``lm`` trainer in the
message path (``lm_background: false``, so the figures do not depend on the machine's
load). Prints the summary: every sample accounted for (processed = predicted + skipped by
reason), the prequential NMSE and the held-out (validation) NMSE per joint, scored at the
end with the frozen model.

Usage::

    .venv/bin/python benchmarks/bench_online_real.py ../shared/realdata/tiago \\
        --set urdf_file=tiago.urdf validation_block=100 lm_interval=40 \\
        [--joints torso_lift_joint arm_1_joint ...]

A run over TIAGo (8,022 samples) takes 1–11 min on a loaded 2-core machine.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from scara_ident_ros.bag.recording_file import read_recording  # noqa: E402
from scara_ident_ros.identification.identifier_settings import IdentifierSettings  # noqa: E402,E501
from scara_ident_ros.identification.reports import MethodReport  # noqa: E402
from scara_ident_ros.identification.session import IdentificationSession  # noqa: E402

CONFIG = Path(__file__).resolve().parents[1] / 'config' / 'identifier.yaml'


def settings(changes: dict[str, Any]) -> IdentifierSettings:
    """The identifier's defaults, ``lm`` in the message path, with ``changes``."""
    return IdentifierSettings.from_yaml(CONFIG).replace(**{'lm_background': False, **changes})


def run(path: str, changes: dict[str, Any], joints: list[str] | None, *,
        live_velocity: bool = False, paced: bool = False
        ) -> tuple[MethodReport, float, tuple[float, float]]:
    """Feed the recording at ``path`` sample by sample; return the session's summary, the
    seconds it took and the per-sample cost (median, p99; ms).

    ``live_velocity``: a recording without velocities is fed without them (the input
    stage derives q', ``derive_velocity``); else as ``play`` publishes it, with q' derived
    from the whole recording. ``paced``: at the recording's own timing (a learner process
    then learns as it would beside a live stream), else as fast as the session goes.
    """
    series = read_recording(path, derive=not live_velocity)
    if joints:
        series = series.select(joints)
    session = IdentificationSession(settings(changes))
    names = list(series.names)
    start = time.perf_counter()
    absent = bool(live_velocity and np.isnan(series.velocity).all())
    cost = np.empty(len(series))
    t0 = int(series.stamp_ns[0])
    for i in range(len(series)):
        if paced:
            ahead = (int(series.stamp_ns[i]) - t0) * 1e-9 - (time.perf_counter() - start)
            if ahead > 0:
                time.sleep(ahead)
        began = time.perf_counter()
        session.process(int(series.stamp_ns[i]), names, series.position[i],
                        () if absent else series.velocity[i], series.effort[i])
        cost[i] = time.perf_counter() - began
    session.flush()
    session.close()  # a learner process hands its last state back
    summary = session.summary(fresh=True)
    return summary, time.perf_counter() - start, (float(np.median(cost) * 1e3),
                                                   float(np.percentile(cost, 99) * 1e3))


def _value(text: str) -> Any:
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('recording')
    parser.add_argument('--set', nargs='*', default=[], metavar='NAME=VALUE',
                        help='identifier parameters (JSON values)')
    parser.add_argument('--joints', nargs='*', default=None)
    parser.add_argument('--live-velocity', action='store_true',
                        help='feed a recording without velocities without them')
    parser.add_argument('--paced', action='store_true',
                        help="feed at the recording's own timing")
    args = parser.parse_args()
    changes = {key: _value(value) for key, value in
               (item.split('=', 1) for item in args.set)}
    summary, seconds, cost_ms = run(args.recording, changes, args.joints,
                                    live_velocity=args.live_velocity, paced=args.paced)
    if summary.validation_nmse_total is None:
        print(f'no model was built, or no held-out sample: {summary.as_dict()}',
              file=sys.stderr)
        return 1
    learning = summary.learning
    print(f'| {args.recording} | {changes} | {summary.processed} | '
          f'{summary.predicted} | {summary.skipped.total} {summary.skipped.as_dict()} | '
          f'{learning.learn_dropped if learning else 0} | '
          f'{learning.updates if learning else "–"} | '
          f'{cost_ms[0]:.3f} / {cost_ms[1]:.2f} ms | {summary.held_out} | '
          + ', '.join(f'{v:.3g}' for v in summary.validation_nmse or ())
          + f' | {summary.validation_nmse_total:.3g} | {seconds:.0f} s, load '
          f'{os.getloadavg()[0]:.1f} |')
    print(f'prequential NMSE per joint: {summary.nmse}', file=sys.stderr)
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
