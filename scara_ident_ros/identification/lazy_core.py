"""The online core, built once the joints are known: from settings or the first valid sample.

Without ``joint_names`` the identifier learns the joints of the first valid message: until
then there is no network to predict with (its size is the number of joints), and the
samples skipped meanwhile are counted apart, then added to the core's counters.
:class:`LazyCore` holds that state; :class:`CoreSettings` is what the core is built from,
by :func:`~scara_ident_ros.identification.identifier_builder.build_identifier`.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

from scara_ident_ros.dynamics.joint_limits import JointLimits
from scara_ident_ros.estimator import Estimator
from scara_ident_ros.identification.core_settings import (ONLINE_METHODS, PHYSICAL_METHODS,
                                                          CoreSettings)
from scara_ident_ros.identification.differentiator import AccelerationEstimate
from scara_ident_ros.identification.identifier_builder import (background_learner,
                                                               build_identifier, make_model)
from scara_ident_ros.identification.input_stage import InputStage
from scara_ident_ros.identification.joint_map import JointMap
from scara_ident_ros.identification.online_identifier import Counts, OnlineIdentifier
from scara_ident_ros.identification.sample_check import FloatArrayLike, SampleCheck, joint_bounds
from scara_ident_ros.identification.skip_reason import SkipReason

__all__ = ['CoreSettings', 'LazyCore', 'ONLINE_METHODS', 'PHYSICAL_METHODS', 'Skipped']


class Skipped(NamedTuple):
    """A sample before the core was built: why it was skipped, and what to do (or '')."""

    reason: SkipReason
    note: str = ''


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
    """

    def __init__(self, limits: JointLimits, network: Estimator | None = None, *,
                 urdf: str = '', urdf_source: str = 'robot_description') -> None:
        self.limits = limits
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

    def build(self, names: Sequence[str], settings: CoreSettings,
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
            missing = self.limits.missing(names)
            if missing:
                return (f'no joint limits for {missing} (limits are known for '
                        f'{list(self.limits.names)}, from {self.limits.source}): set '
                        'urdf_file, robot_config or position_min, position_max, '
                        'velocity_max, acceleration_max, effort_max and joint_names')
            if settings.method in PHYSICAL_METHODS and not self.urdf:
                return (f'method {settings.method} needs the robot\'s URDF: set urdf_file or '
                        'robot_description')
            network = self._fresh(names, settings)
        bounds = (None if self.limits.missing(names)
                  else joint_bounds(self.limits.select(names), settings.limit_margin))
        self.network, self.names = network, names
        self.core = build_identifier(names, settings, model=network,
                                     differentiator=differentiator, bounds=bounds,
                                     stage=stage, background=background)
        counts = self.core.counts
        counts.processed += self.early.processed
        for reason, skipped in self.early.skipped.items():
            counts.skipped[reason] += skipped
        return ''

    def _fresh(self, names: list[str], settings: CoreSettings) -> Estimator:
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

    def first(self, settings: CoreSettings, differentiator: AccelerationEstimate,
              stamp_ns: int, names: Sequence[str], position: FloatArrayLike,
              velocity: FloatArrayLike, effort: FloatArrayLike, *,
              background: bool = False) -> Skipped | None:
        """Build for the joints of this sample if it is valid (None); else count it skipped.

        A sample without effort fixes the joints too (it is predicted, not learnt); one
        naming fewer than ``settings.min_joints`` joints does not.
        """
        n_joints = self.network.n_outputs if self.network is not None else None
        check = SampleCheck(JointMap(n_joints=n_joints), need_effort=False)
        reason = check.check(stamp_ns, names, position, velocity, effort)
        note = ''
        if not isinstance(reason, SkipReason) and len(names) < settings.min_joints:
            reason = SkipReason.JOINT_COUNT
            note = (f'waiting for a message naming at least {settings.min_joints} joints '
                    f'(min_joints); this one names {list(names)}')
        if not isinstance(reason, SkipReason):
            note = self.build(names, settings, differentiator, background=background)
            if not note:
                return None
            reason = SkipReason.UNKNOWN_JOINT
        self.early.processed += 1
        self.early.skipped[reason] += 1
        return Skipped(reason, note)
