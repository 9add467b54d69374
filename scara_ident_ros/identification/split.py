"""Training and validation samples from one recording: whole time blocks, spread over it.

The one validation split of batch training: ``scara-ident train`` early-stops on it and
``scara-ident tables`` (:mod:`scara_ident_ros.paper.retraining`) reports on it, with the
same defaults. The online identifier holds out blocks of its stream as they come
(:class:`~scara_ident_ros.identification.holdout.Holdout`).

Why blocks and not single samples: neighbouring samples at 1 kHz are nearly identical, so a
random per-sample split would validate on copies of the training data and early stopping
would never see overfitting. Why not the last part of the recording: a
recording of several excitations ends with another motion than the rest, so its validation
error measures an extrapolation the training cannot improve, and early stopping fires
while Levenberg–Marquardt is still adapting its damping.

Blocks interleaved with the training motion measure interpolation: the motion around them
was learnt. A user predicts what the arm does next. :func:`later_split` holds out the motion
that comes *after* the training motion (the end of a recording, or the last of several
recordings, held out whole: forward chaining with one fold, leave the latest recording out);
``scara-ident train`` chooses its model, stops its networks and gates its hybrid on that.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from scara_ident_ros.errors import ScaraIdentError
from scara_ident_ros.identification.dataset import Dataset
from scara_ident_ros.nn.validation_blocks import VALIDATION_FRACTION, choose_blocks

__all__ = ['LATER_FRACTION', 'SplitError', 'VALIDATION_BLOCK_S', 'VALIDATION_FRACTION',
           'alternate_blocks', 'block_index', 'block_split', 'later_split']

VALIDATION_BLOCK_S = 1.0  # s, length of the validation time blocks
#: Share of a recording's time, at its end, held out as later motion (:func:`later_split`).
LATER_FRACTION = 0.3


class SplitError(ScaraIdentError, ValueError):
    """The samples fill too few blocks for a validation split (one-line message)."""


def block_index(stamp_ns: npt.ArrayLike, *, block_s: float,
                start_ns: int | None = None) -> npt.NDArray[np.int64]:
    """The time block of each sample: ``(stamp − start) // block``.

    ``stamp_ns`` (N,) are not before ``start_ns`` (default the first stamp); ``block_s``
    is rounded to whole nanoseconds. Returns block numbers (N,) of int64.
    """
    stamps = np.asarray(stamp_ns, dtype=np.int64)
    block_ns = round(block_s * 1e9)
    if not block_ns > 0:
        raise ValueError(f'block length must be positive, got {block_s} s')
    if start_ns is None:
        start_ns = int(stamps[0]) if stamps.shape[0] else 0
    return (stamps - np.int64(start_ns)) // np.int64(block_ns)


def block_split(data: Dataset, validation_fraction: float, *,
                block_s: float = VALIDATION_BLOCK_S, seed: int = 0) -> tuple[Dataset, Dataset]:
    """Split samples into training and validation blocks spread over the recording.

    The samples are cut into blocks of ``block_s`` seconds from the first stamp; blocks
    without samples (pauses in the recording) do not count. Of the K blocks with samples,
    m = round(fraction·K) (at least 1, at most K − 1) validate: the K blocks are cut into
    m strata of consecutive blocks, as equal as can be, and one block of each stratum,
    drawn with ``seed``, validates. So m/K is within 1/K of the fraction, every stratum of
    the recording has a validation block, and the split depends on nothing but the stamps,
    the fraction, ``block_s`` and ``seed``.

    Returns
    -------
    train, validation : Dataset
        The samples of the training and of the validation blocks, in time order, named
        ``'train'`` and ``'validation'``; ``validation`` is empty when the fraction is 0.

    Raises
    ------
    ValueError
        If the fraction is outside [0, 1) or ``block_s`` is not positive.
    SplitError
        If the fraction is positive but the samples fill fewer than 2 blocks.
    """
    if not 0.0 <= validation_fraction < 1.0:
        raise ValueError(f'validation fraction must be in [0, 1), got {validation_fraction}')
    blocks = block_index(data.stamp_ns, block_s=block_s)
    if len(data) == 0 or validation_fraction == 0.0:
        return data.take(slice(None), 'train'), data.take(slice(0, 0), 'validation')
    present = np.unique(blocks)
    k = int(present.shape[0])
    if k < 2:
        raise SplitError(f'{data.seconds:.3g} s of samples fill {k} block of {block_s:g} s; '
                         'a validation split needs at least 2')
    chosen = choose_blocks(present, validation_fraction, seed)
    mask = np.isin(blocks, chosen)
    return data.take(~mask, 'train'), data.take(mask, 'validation')


def alternate_blocks(data: Dataset, *, block_s: float = VALIDATION_BLOCK_S,
                     start_ns: int | None = None) -> tuple[Dataset, Dataset]:
    """Deal the time blocks that hold samples alternately into two sets.

    The hybrid's validation blocks in two: one to early-stop its network on, the other to
    gate its correction on (a gate checked on the samples that chose the network's
    iteration would trust it too much). ``block_s`` and ``start_ns`` as
    :func:`block_index`'s (``start_ns``: the recording's first stamp, so that blocks are
    those of :func:`block_split`).

    Returns
    -------
    first, second : Dataset
        The samples of the 1st, 3rd, ... block with samples, and of the 2nd, 4th, ...; in
        time order. With fewer than 2 blocks, ``second`` is empty.
    """
    blocks = block_index(data.stamp_ns, block_s=block_s, start_ns=start_ns)
    present = np.unique(blocks)
    mask = np.isin(blocks, present[1::2])
    return data.take(~mask, data.name), data.take(mask, data.name)


def later_split(data: Dataset, fraction: float = LATER_FRACTION, *,
                recording: npt.ArrayLike | None = None) -> tuple[Dataset, Dataset]:
    """Split samples into earlier and later motion: what a model learns, what it predicts.

    With one recording, the samples stamped in the last ``fraction`` of its time span are
    the later motion. With several (``recording``: a label per sample, in the order the
    recordings were made), the last recording is held out whole and ``fraction`` is unused.

    Parameters
    ----------
    data : Dataset
        Samples in time order (N,).
    fraction : float
        Share of the time span held out, in (0, 1).
    recording : array_like of shape (N,), optional
        The recording each sample comes from (any labels; the last label is the latest).

    Returns
    -------
    earlier, later : Dataset
        Named ``'earlier'`` and ``'later'``; no sample is in both.

    Raises
    ------
    ValueError
        If ``fraction`` is outside (0, 1) or ``recording`` does not label every sample.
    SplitError
        If either part would hold fewer than 2 samples.
    """
    if not 0.0 < fraction < 1.0:
        raise ValueError(f'later-motion fraction must be in (0, 1), got {fraction}')
    if recording is not None:
        labels = np.asarray(recording).reshape(-1)
        if labels.shape != (len(data),):
            raise ValueError(f'need a recording label per sample ({len(data)}), got '
                             f'{labels.shape}')
        mask = labels == labels[-1] if len(data) else np.zeros(0, dtype=bool)
        what = 'the last recording'
    else:
        stamps = data.stamp_ns
        span = int(stamps[-1] - stamps[0]) if len(data) else 0
        cut = int(stamps[0]) + span - round(fraction * span) if len(data) else 0
        mask = stamps >= cut
        what = f'the last {fraction:.0%} of {data.seconds:.3g} s'
    earlier, later = data.take(~mask, 'earlier'), data.take(mask, 'later')
    if len(earlier) < 2 or len(later) < 2:
        raise SplitError(f'{what} leaves {len(earlier)} earlier and {len(later)} later '
                         'samples; need at least 2 of each')
    return earlier, later
