"""Helpers shared by the FIR stages: input dispatch and keypoint labels."""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np

from tunnelsense._records import FrameRecord, FrameSequence, ScanRecord, ScanSequence

__all__ = [
    "bin_lut",
    "frame_image",
    "is_record_input",
    "keypoints_of",
    "points_in_boxes",
]

_KEYPOINT_DTYPE = np.int32


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


def keypoints_of(record: FrameRecord, index: int, stage: str) -> np.ndarray:
    """The ``(n, 3)`` keypoints of a record's payload, or a clear error."""
    try:
        kp = record.payload["keypoints"]
    except KeyError:
        raise ValueError(
            f"X[{index}] ({record.tour!r}, frame {record.frame}) has no "
            f"payload['keypoints']: {stage} needs frame records that went through "
            "IntensityKeypointSampler first"
        ) from None
    kp = np.asarray(kp)
    if kp.ndim != 2 or kp.shape[1] != 3:
        raise ValueError(
            f"X[{index}] ({record.tour!r}, frame {record.frame}): payload['keypoints'] "
            f"must have shape (n, 3) (row, col, intensity); got shape {kp.shape}"
        )
    return kp


def points_in_boxes(rows, cols, boxes) -> np.ndarray:
    """Whether each point ``(row, col)`` lies inside any box ``(left, top, w, h)``.

    A point is inside when ``left <= col < left + width`` and
    ``top <= row < top + height`` (pixel centres of the box's pixels).

    Examples
    --------
    >>> import numpy as np
    >>> points_in_boxes(np.array([5, 50]), np.array([5, 5]), np.array([[0, 0, 10, 10.]]))
    array([ True, False])
    """
    rows = np.asarray(rows)
    cols = np.asarray(cols)
    inside = np.zeros(rows.shape, dtype=bool)
    for left, top, width, height in np.asarray(boxes, dtype=np.float64).reshape(-1, 4):
        inside |= (cols >= left) & (cols < left + width) & (rows >= top) & (
            rows < top + height
        )
    return inside


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


def frame_image(record, index) -> np.ndarray:
    """The record's image, checked to be a 2-D ``uint8`` or ``uint16`` array."""
    image = record.image
    if (
        not isinstance(image, np.ndarray)
        or image.ndim != 2
        or image.dtype not in (np.uint8, np.uint16)
    ):
        raise ValueError(
            f"X[{index}] ({record.tour!r}, frame {record.frame}): the image must be a "
            "2-D uint8 or uint16 array"
        )
    return image
