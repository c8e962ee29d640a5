"""Helpers shared by the FIR stages: input dispatch, keypoint labels, bin tables."""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np

from tunnelsense._payload import inside_boxes
from tunnelsense._records import FrameRecord, FrameSequence, ScanRecord, ScanSequence

__all__ = [
    "bin_lut",
    "is_record_input",
    "points_in_boxes",
]

def is_record_input(X) -> bool:
    """Whether ``X`` is meant as frame records (frame mode) rather than a 2-D array.

    A :class:`FrameSequence` or :class:`ScanSequence`, or a list / tuple whose first
    element is a record, selects frame mode (wrong record types are then rejected by
    :func:`tunnelsense.check_frames`).  A 3-D array (a stack of images) is rejected here
    with a message that says what is expected.
    """
    if isinstance(X, FrameSequence | ScanSequence):
        return True
    if isinstance(X, np.ndarray):
        if X.ndim == 3:
            raise TypeError(
                "X must be a sequence of FrameRecord (frame mode) or a 2-D array "
                f"(tabular mode); got an array of shape {X.shape}. Wrap a stack of "
                "images with tunnelsense.FrameSequence.from_array(images)."
            )
        return False
    if isinstance(X, Sequence) and not isinstance(X, str | bytes) and len(X):
        return isinstance(X[0], FrameRecord | ScanRecord)
    return False


def points_in_boxes(rows, cols, boxes) -> np.ndarray:
    """Whether each point ``(row, col)`` lies inside any box ``(left, top, w, h)``.

    A point is inside when ``left <= col < left + width`` and
    ``top <= row < top + height`` (:func:`tunnelsense._payload.inside_boxes`).

    Examples
    --------
    >>> import numpy as np
    >>> points_in_boxes(np.array([5, 50]), np.array([5, 5]), np.array([[0, 0, 10, 10.]]))
    array([ True, False])
    """
    return inside_boxes(cols, rows, boxes).any(axis=1)


def bin_lut(dtype, bins, intensity_range=None, binning="hard"):
    """Lookup tables from every pixel value of ``dtype`` to its histogram bin(s).

    ``binning="hard"``: one table, the bin of every value (values outside
    ``intensity_range`` go to the end bins).  ``binning="linear"``: a pair
    ``(lower_bin, upper_weight)``: a value at bin coordinate ``x`` (bin centres at
    integers) gives weight ``1 - w`` to bin ``floor(x)`` and ``w`` to the next, clipped
    at the ends.  Tables are built once per process and argument set (a 16-bit table
    costs about a millisecond) and returned read-only.

    Examples
    --------
    >>> import numpy as np
    >>> bin_lut(np.uint8, 4)[[0, 63, 64, 255]].tolist()
    [0, 0, 1, 3]
    """
    dtype = np.dtype(dtype)
    if intensity_range is None:
        lo, hi = 0, int(np.iinfo(dtype).max) + 1
    else:
        lo, hi = (int(v) for v in intensity_range)
    return _bin_lut(dtype, int(bins), lo, hi, binning)


@functools.lru_cache(maxsize=16)
def _bin_lut(dtype, bins, lo, hi, binning):
    values = np.arange(int(np.iinfo(dtype).max) + 1, dtype=np.int64)
    if binning == "hard":
        # integer arithmetic: floor((v - lo) * bins / (hi - lo)) exactly
        table = np.clip(((values - lo) * bins) // (hi - lo), 0, bins - 1).astype(np.intp)
        table.flags.writeable = False
        return table
    x = np.clip((values + 0.5 - lo) * bins / (hi - lo) - 0.5, 0, bins - 1)
    b0 = np.minimum(np.floor(x), bins - 2 if bins > 1 else 0)
    lower, weight = b0.astype(np.intp), (x - b0).astype(np.float32)
    lower.flags.writeable = False
    weight.flags.writeable = False
    return lower, weight
