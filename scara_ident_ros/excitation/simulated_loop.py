"""The loop ``excitation -> simulator -> /joint_states`` in one process, synchronously.

What the ``excitation`` node sends a simulator with ``trajectory:=external``, without DDS
and without a clock: the simulated arm holds the middle of its ranges at rest; the node
reads that position as its start, plans (:class:`ExcitationPlan`: approach, then the
sequence) with its margins and scales, puts the plan's origin ``start_delay`` ahead and
sends a chunk (:func:`make_chunk`, the plan from one point before now to ``horizon`` ahead,
then a stop) every ``chunk_period``; the simulator's follower takes each chunk at the sample
it is sent (no latency) and its computed torque + PD tracks it. The stream starts with the
first chunk. Every figure of the loop that does not depend on the machine (what motion the
identifier learns) can be measured on this record; what DDS and a busy machine add (late
chunks, fewer learning updates) cannot.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.dynamics.joint_limits import JointLimits
from scara_ident_ros.excitation.chunks import make_chunk
from scara_ident_ros.excitation.plan import ExcitationPlan
from scara_ident_ros.sim import SimConfig, SimRecord, Simulator
from scara_ident_ros.sim.trajectory_follower import TrajectoryFollower

__all__ = ['LoopSettings', 'SimulatedLoop', 'simulate_loop']

NS_PER_S = 1_000_000_000


@dataclass(frozen=True)
class LoopSettings:
    """The ``excitation`` node's parameters that shape the motion, with their defaults.

    The one place the defaults are written: the node declares its parameters with them, the
    dry run's options and the loop here default to them (``config/excitation.yaml`` repeats
    them; the tests check it).

    Attributes
    ----------
    position_margin : float
        Fraction of each joint's range kept clear at both ends.
    velocity_scale, acceleration_scale : float
        Fractions of the velocity and acceleration limits the motion keeps to.
    seed : int
        Seed of the sequence excitation.
    point_period, chunk_period, horizon, start_delay : float
        Time between two points of a chunk, between two chunks, from a chunk's send time
        to its stop, and from the first chunk to the plan's origin (s).
    """

    position_margin: float = 0.1
    velocity_scale: float = 0.5
    acceleration_scale: float = 0.5
    seed: int = 0
    point_period: float = 0.01
    chunk_period: float = 0.25
    horizon: float = 1.0
    start_delay: float = 0.5


@dataclass(frozen=True)
class SimulatedLoop:
    """The stream of a simulated loop and what it was sent.

    Attributes
    ----------
    record : SimRecord
        The samples ``/joint_states`` would carry, from the first chunk on (stamps from 0).
    plan : ExcitationPlan
        The node's plan (its limits the margined ones).
    origin_ns : int
        Stamp of plan time 0 (ns).
    chunks : int
        Chunks sent.
    """

    record: SimRecord
    plan: ExcitationPlan
    origin_ns: int
    chunks: int

    def plan_times(self) -> np.ndarray:
        """Plan time of each sample (N,) (s), negative before the origin."""
        return np.asarray((self.record.stamp_ns - self.origin_ns) / NS_PER_S, dtype=float)


def simulate_loop(params: ScaraParams, limits: JointLimits, *, seconds: float,
                  settings: LoopSettings | None = None,
                  config: SimConfig | None = None,
                  external: np.ndarray | None = None) -> SimulatedLoop:
    """Simulate ``seconds`` of the loop on the SCARA ``params``.

    Parameters
    ----------
    params : ScaraParams
        The simulated arm (its joints in the order of ``limits``).
    limits : JointLimits
        The arm's limits as the node loads them (from its URDF), without margins.
    seconds : float
        Length of the stream from the first chunk (s); ``round(seconds / dt)`` samples.
    settings : LoopSettings, optional
        The node's parameters; default its defaults.
    config : SimConfig, optional
        The simulator's settings; default ``SimConfig(seed=settings.seed)`` (1 kHz, no noise).
    external : ndarray of shape (samples, n), optional
        External effort (N·m or N) applied at each sample (a contact's,
        :meth:`Simulator.apply_external`); rows past its end apply none.
    """
    s = LoopSettings() if settings is None else settings
    if tuple(limits.names) != tuple(params.joint_names):
        raise ValueError(f'limits of {list(limits.names)}, arm of {list(params.joint_names)}')
    if s.horizon < 2.0 * s.chunk_period:
        raise ValueError(f'horizon ({s.horizon:g} s) must be at least 2 chunk_period')
    cfg = SimConfig(seed=s.seed) if config is None else config
    margined = limits.with_margins(s.position_margin, s.velocity_scale, s.acceleration_scale)
    follower = TrajectoryFollower(params.joint_names, params.position_centre)
    simulator = Simulator(params, follower, cfg)
    plan = ExcitationPlan(margined, simulator.state[0], seed=s.seed)
    origin_ns = simulator.stamp_ns + round(s.start_delay * NS_PER_S)
    period_ns = round(s.chunk_period * NS_PER_S)
    next_send, sent = simulator.stamp_ns, 0
    rows = []
    applied: np.ndarray | None = None
    for index in range(max(0, round(seconds / cfg.dt))):
        if external is not None:
            row = external[index] if index < len(external) else np.zeros(external.shape[1])
            if applied is None or not np.array_equal(row, applied):
                simulator.apply_external(row)
                applied = row
        now_ns = simulator.stamp_ns
        if now_ns >= next_send:
            t = (now_ns - origin_ns) / NS_PER_S
            chunk = make_chunk(plan, t - s.point_period, max(t + s.horizon, 0.0),
                               s.point_period, margined)
            reason = follower.command(limits.names, origin_ns,
                                      [round(x * NS_PER_S) for x in chunk.times.tolist()],
                                      chunk.q.tolist(), chunk.qd.tolist(),
                                      chunk.qdd.tolist(), now_ns)
            if reason is not None:
                raise RuntimeError(f'the follower refused chunk {sent}: {reason}')
            next_send += period_ns
            sent += 1
        rows.append(simulator.advance())
    n = len(params.joint_names)
    stamps = np.array([row[0] for row in rows], dtype=np.int64)
    columns = [np.array([row[i] for row in rows], dtype=float).reshape(len(rows), n)
               for i in range(1, 5)]
    return SimulatedLoop(SimRecord(stamps, *columns), plan, origin_ns, sent)
