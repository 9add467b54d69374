"""The online core, built once the joints are known: from settings or the first valid sample.

Without ``joint_names`` the identifier learns the joints of the first valid message: until
then there is no network to predict with (its size is the number of joints), and the
samples skipped meanwhile are counted apart, then added to the core's counters.
:class:`LazyCore` holds that state; the
:class:`~scara_ident_ros.identification.identifier_settings.IdentifierSettings` are what
the core is built from, by
:func:`~scara_ident_ros.identification.identifier_builder.build_identifier`.

When the robot's files lack some limits of the joints (a URDF has no acceleration limit,
nothing for a continuous joint), the network's scaling is completed from the stream's first
second (:class:`~scara_ident_ros.identification.stream_scaling.StreamScaling`): those
samples are kept and, once the core is built, :meth:`LazyCore.take_replay` hands them back
to be predicted and learnt like any other. Only joints that no file knows are
``unknown_joint``.
"""
from __future__ import annotations

import copy
from collections.abc import Sequence
from typing import NamedTuple

from scara_ident_ros.dynamics.joint_limits import JointLimits
from scara_ident_ros.dynamics.urdf_limits import UrdfLimits
from scara_ident_ros.estimator import Estimator
from scara_ident_ros.identification.identifier_settings import IdentifierSettings
from scara_ident_ros.identification.parameters import ONLINE_METHODS, PHYSICAL_METHODS
from scara_ident_ros.identification.differentiator import AccelerationEstimate
from scara_ident_ros.identification.identifier_builder import (background_learner,
                                                               build_identifier, make_model)
from scara_ident_ros.identification.input_stage import InputStage
from scara_ident_ros.identification.joint_map import JointMap
from scara_ident_ros.identification.learner_methods import LEARNER_METHODS
from scara_ident_ros.identification.online_identifier import Counts, OnlineIdentifier
from scara_ident_ros.identification.sample_check import (Bounds, FloatArrayLike, SampleCheck,
                                                         joint_bounds)
from scara_ident_ros.identification.skip_reason import SkipReason
from scara_ident_ros.identification.stream_scaling import StreamScaling, stream_joints

__all__ = ['LazyCore', 'ONLINE_METHODS', 'PHYSICAL_METHODS', 'RawSample', 'UNSCALED_METHODS',
           'Skipped']

_JOINT_REASONS = (SkipReason.UNKNOWN_JOINT, SkipReason.MISSING_JOINT,
                  SkipReason.DUPLICATE_JOINT)
#: Methods whose model is not scaled by the joint limits (a network's is)
UNSCALED_METHODS = ('physical', *LEARNER_METHODS)


class Skipped(NamedTuple):
    """A sample before the core was built: why it was skipped, and what to do (or '');
    reason None: kept while the stream completes the limits (:meth:`LazyCore.first`)."""

    reason: SkipReason | None
    note: str = ''


class RawSample(NamedTuple):
    """A joint-state sample as it came (see :meth:`LazyCore.first`), kept to be replayed."""

    stamp_ns: int
    names: tuple[str, ...]
    position: FloatArrayLike
    velocity: FloatArrayLike
    effort: FloatArrayLike


class LazyCore:
    """The network and online core, or what came before them.

    Parameters
    ----------
    limits : JointLimits
        Scale a fresh network and bound the samples of the joints they name.
    network : Estimator, optional
        A warm start (checked with :func:`~scara_ident_ros.identification.warm_start.
        check_warm_start` to be a model of the settings' method); else a fresh model of
        the settings' method is made.
    urdf_limits : UrdfLimits, optional
        The URDF's limits: its joints that ``limits`` lacks get the rest from the stream.

    Attributes
    ----------
    network : Estimator or None
        The warm start, or the model once built.
    core : OnlineIdentifier or None
        Once the joints are known.
    names : list of str
        The joints, once the core is built (else empty).
    early : Counts
        Samples skipped before the core was built.
    limits_note : str
        Which limits scale the network and where each came from, once built (one line).
    """

    def __init__(self, limits: JointLimits, network: Estimator | None = None, *,
                 urdf: str = '', urdf_source: str = 'robot_description',
                 urdf_limits: UrdfLimits | None = None) -> None:
        self.limits = limits
        self.urdf_limits = urdf_limits
        self.scaling: StreamScaling | None = None  # while the stream completes the limits
        self.replay: list[RawSample] = []  # the samples it took, until taken back
        self.limits_note = ''
        self._stream_bounds: tuple[Bounds | None] | None = None  # once the stream gave some
        self.urdf, self.urdf_source = urdf, urdf_source
        self.network = network
        self.core: OnlineIdentifier | None = None
        self.names: list[str] = []
        self.early = Counts()

    @property
    def counts(self) -> Counts:
        """The core's counters, or the early ones until it is built."""
        return self.core.counts if self.core is not None else self.early

    def reset(self) -> None:
        """Forget the network, the core and the early counters (fresh weights next build)."""
        self.close()
        self.network, self.core, self.names, self.early = None, None, [], Counts()
        self.scaling, self.replay = None, []

    def build(self, names: Sequence[str], settings: IdentifierSettings,
              differentiator: AccelerationEstimate, *, stage: InputStage | None = None,
              background: bool = False) -> str:
        """Build the core for ``names``; return '' or, if some joint lacks limits (and there
        is no warm start), why not. The early counters are added to the core's.

        ``stage``: an input stage shared with other cores (see :class:`OnlineIdentifier`);
        ``background``: the ``lm`` trainer learns in a process of its own
        (:class:`~scara_ident_ros.identification.background_lm.BackgroundLM`).
        """
        names = list(names)
        network = self.network
        if network is None:
            lacking, unknown = stream_joints(self.limits, self.urdf_limits, names)
            if unknown and settings.method not in LEARNER_METHODS:  # they need no limits
                urdf = self.urdf_limits.names if self.urdf_limits is not None else ()
                known = [*self.limits.names,
                         *(name for name in urdf if name not in self.limits.names)]
                return (f'no joint limits for {unknown} (limits are known for {known}, from '
                        f'{self.limits.source}'
                        + (f' and {self.urdf_limits.source}' if self.urdf_limits else '')
                        + '): set urdf_file, robot_config or position_min, position_max, '
                        'velocity_max, acceleration_max, effort_max and joint_names')
            if lacking and settings.method not in UNSCALED_METHODS:
                return (f'the scaling of {lacking} comes from the stream: build from '
                        'samples (LazyCore.first)')
            if settings.method in PHYSICAL_METHODS and not self.urdf:
                return (f'method {settings.method} needs the robot\'s URDF: set urdf_file or '
                        'robot_description')
            network = self._fresh(names, settings)
        if self.scaling is not None:  # the stream completed the limits: bound the files' only
            self._stream_bounds = (self.scaling.bounds(settings.limit_margin),)
        if self._stream_bounds is not None:
            bounds = self._stream_bounds[0]
        else:
            bounds = (None if self.limits.missing(names)
                      else joint_bounds(self.limits.select(names), settings.limit_margin))
        if not self.limits_note and not self.limits.missing(names):
            self.limits_note = f'joint limits of {names} from {self.limits.source}'
        if not self.limits_note:
            self.limits_note = (f'joint limits of {names}: none for {self.limits.missing(names)}'
                                ' (physical model: its URDF needs none)')
        self.network, self.names = network, names
        self.core = build_identifier(names, settings, model=network,
                                     differentiator=differentiator, bounds=bounds,
                                     stage=stage, background=background)
        counts = self.core.counts
        counts.processed += self.early.processed
        for reason, skipped in self.early.skipped.items():
            counts.skipped[reason] += skipped
        return ''

    def _fresh(self, names: list[str], settings: IdentifierSettings) -> Estimator:
        """A fresh model of ``settings.method`` for the joints ``names``
        (:func:`~scara_ident_ros.identification.identifier_builder.make_model`)."""
        return make_model(names, settings, self.limits, urdf=self.urdf,
                          urdf_source=self.urdf_source)

    def close(self) -> None:
        """End the core's trainers that run beside the stream (their last weights are the
        network's)."""
        learner = background_learner(self.core.trainer if self.core is not None else None)
        if learner is not None:
            learner.close()

    def needs_stream(self, names: Sequence[str], method: str) -> bool:
        """Whether the network's scaling of ``names`` needs the stream (the files lack some
        limits of them, no file lacks all, and there is no warm start to take it from)."""
        lacking, unknown = stream_joints(self.limits, self.urdf_limits, names)
        return (self.network is None and method not in UNSCALED_METHODS and bool(lacking)
                and not unknown)

    def adopt_limits(self, other: LazyCore) -> None:
        """Take ``other``'s limits, as the stream completed them (another method of the
        same stream: one scaling and one set of bounds for all)."""
        self.limits, self._stream_bounds = other.limits, other._stream_bounds
        self.limits_note = other.limits_note

    def take_replay(self) -> list[RawSample]:
        """The samples taken while the stream completed the limits (once: then empty), to
        be pushed through the core, oldest first."""
        replay, self.replay = self.replay, []
        return replay

    def first(self, settings: IdentifierSettings, differentiator: AccelerationEstimate,
              stamp_ns: int, names: Sequence[str], position: FloatArrayLike,
              velocity: FloatArrayLike, effort: FloatArrayLike, *,
              background: bool = False, wanted: Sequence[str] = ()) -> Skipped | None:
        """Build for the joints of this sample if it is valid (None); else count it skipped.

        A sample without effort fixes the joints too (it is predicted, not learnt); one
        naming fewer than ``settings.min_joints`` joints does not. ``wanted``: the joints
        to build for (``joint_names``), if known.

        When the files lack some limits of the joints (:meth:`needs_stream`), valid samples
        are kept until :data:`~scara_ident_ros.identification.stream_scaling.SCALING_SPAN_S`
        of them complete the limits; meanwhile the result is ``Skipped(None, note)`` (not
        counted, a note on the first one), and after the build :meth:`take_replay` holds
        them, this one last.
        """
        if self.scaling is not None:
            return self._scale(settings, differentiator, stamp_ns, names, position, velocity,
                               effort, background=background)
        n_joints = self.network.n_outputs if self.network is not None else None
        check = SampleCheck(JointMap(list(wanted) or None, n_joints=n_joints),
                            need_effort=False)
        derive = (settings.derive_velocity == 'auto' and len(velocity) == 0
                  and len(position) != 0)  # the input stage derives q' from q
        reason = check.check(stamp_ns, names, position,
                             [0.0] * len(position) if derive else velocity, effort)
        note = ''
        if not isinstance(reason, SkipReason) and len(names) < settings.min_joints:
            reason = SkipReason.JOINT_COUNT
            note = (f'waiting for a message naming at least {settings.min_joints} joints '
                    f'(min_joints); this one names {list(names)}')
        if not isinstance(reason, SkipReason):
            joints = list(wanted) or list(names)
            if self.needs_stream(joints, settings.method):
                self.scaling = StreamScaling(
                    self.limits, self.urdf_limits, joints, copy.deepcopy(differentiator),
                    max_gap_ns=round(settings.max_gap * 1e9),
                    derive_velocity=settings.derive_velocity == 'auto')
                return self._scale(settings, differentiator, stamp_ns, names, position,
                                   velocity, effort, background=background)
            note = self.build(joints, settings, differentiator, background=background)
            if not note:
                return None
            reason = SkipReason.UNKNOWN_JOINT
        self.early.processed += 1
        self.early.skipped[reason] += 1
        return Skipped(reason, note)

    def _scale(self, settings: IdentifierSettings, differentiator: AccelerationEstimate,
               stamp_ns: int, names: Sequence[str], position: FloatArrayLike,
               velocity: FloatArrayLike, effort: FloatArrayLike, *,
               background: bool) -> Skipped | None:
        """A sample while the stream completes the limits (see :meth:`first`)."""
        scaling = self.scaling
        assert scaling is not None
        reason = scaling.add(stamp_ns, names, position, velocity, effort)
        if reason is not None:
            self.early.processed += 1
            self.early.skipped[reason] += 1
            return Skipped(reason, f'a sample naming {list(names)} while the scaling of '
                           f'{list(scaling.names)} is taken from the stream'
                           if reason in _JOINT_REASONS else '')
        self.replay.append(RawSample(stamp_ns, tuple(names), position, velocity, effort))
        if not scaling.ready:
            return (Skipped(None, f'taking the scaling of {scaling.lacking} (limits the '
                            'robot\'s files lack) from the first samples of the stream')
                    if scaling.samples == 1 else Skipped(None))
        self.limits = scaling.limits()
        self.limits_note = f'joint limits of {list(scaling.names)}: {self.limits.source}'
        note = self.build(scaling.names, settings, differentiator, background=background)
        self.scaling = None
        if note:  # cannot happen: every joint's limits are complete now
            raise RuntimeError(note)
        return None
