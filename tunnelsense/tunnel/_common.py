"""Helpers shared by the FIR stages: input dispatch and keypoint labels."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from tunnelsense._records import FrameRecord, FrameSequence, ScanRecord, ScanSequence

__all__ = ["is_record_input", "keypoints_of", "points_in_boxes"]

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
