"""What an identification session gives for one sample: all the identifier publishes of it.

:meth:`IdentificationSession.process
<scara_ident_ros.identification.session.IdentificationSession.process>` returns a
:class:`SampleOutcome`: for each method, the :class:`Prediction` of every sample whose input
became complete, with the external torque, the contact flags and the lag already decided.
The node only converts them to messages; nothing flows back from its publishing loop into
the session.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification.input_stage import Input
from scara_ident_ros.identification.skip_reason import SkipReason

__all__ = ['Prediction', 'SampleOutcome']


@dataclass(frozen=True, slots=True)
class Prediction:
    """One method's a-priori prediction of one sample, with what is published beside it.

    Attributes
    ----------
    stamp_ns : int
        The predicted sample's stamp (ns).
    effort : ndarray of shape (n,)
        Predicted effort (N·m or N), joint order, clipped to the effort limits.
    x : ndarray of shape (3n,)
        The sample's input ``[q, q', q'']`` (rad or m, per s, per s²).
    held_out : bool
        A validation sample: predicted, never learnt.
    measured : ndarray of shape (n,) or None
        Measured effort (N·m or N), None if the sample had none.
    external : ndarray of shape (n,) or None
        External torque ``measured − effort`` (N·m or N); None without a measured effort.
    contact : ndarray of bool, shape (n,), or None
        Joints over their contact threshold (all False while detection is not armed); None
        without a measured effort.
    lag_ns : int or None
        How late (ns) the prediction is ready to publish, against the stream's own clock
        (:class:`~scara_ident_ros.identification.stream_clock.StreamClock`); None for the
        predictions made on shutdown.
    """

    stamp_ns: int
    effort: NDArray[np.float64]
    x: NDArray[np.float64]
    held_out: bool
    measured: NDArray[np.float64] | None
    external: NDArray[np.float64] | None
    contact: NDArray[np.bool_] | None
    lag_ns: int | None


@dataclass(frozen=True, slots=True)
class SampleOutcome:
    """The outcome of one sample (or of the samples replayed with it) for every method.

    Attributes
    ----------
    predictions : tuple of tuple of Prediction
        For each method, in the session's order, the predictions now due, oldest first
        (the q'' estimate lets a sample out ``window // 2`` samples late).
    inputs : tuple of Input
        The samples these predictions are of, oldest first (one per prediction).
    skipped : SkipReason or None
        Why the sample given was not used (``WARMING_UP`` while the q'' estimate fills), or
        None.
    warnings : tuple of str
        Lines worth a warning: why a sample was skipped, what the stream lacks.
    """

    predictions: tuple[tuple[Prediction, ...], ...]
    inputs: tuple[Input, ...] = ()
    skipped: SkipReason | None = None
    warnings: tuple[str, ...] = ()

    @classmethod
    def nothing(cls, n_methods: int, warnings: tuple[str, ...] = ()) -> SampleOutcome:
        """No prediction for any of ``n_methods`` methods, with ``warnings``."""
        return cls(((),) * n_methods, warnings=warnings)
