"""A training set's frames sampled in time: what ``train tunnel`` decodes and fits."""

from __future__ import annotations

import math
import numbers

from tunnelsense.exceptions import InputFormatError

__all__ = ["sample_in_time", "sampling_stride"]


def sampling_stride(frame_rate, sample_rate) -> int:
    """Every how many frames a tour at ``frame_rate`` is sampled to reach at least
    ``sample_rate`` frames per second: ``floor(frame_rate / sample_rate)``, at least
    1; 1 when ``sample_rate`` is None.

    Examples
    --------
    >>> from tunnelsense._records._sampling import sampling_stride
    >>> sampling_stride(30.0, 6.0), sampling_stride(15.0, 6.0), sampling_stride(9.0, 6.0)
    (5, 2, 1)
    >>> sampling_stride(30.0, None)
    1
    """
    if sample_rate is None:
        return 1
    return max(1, math.floor(float(frame_rate) / float(sample_rate) + 1e-9))


def sample_in_time(X, y, groups, sample_rate):
    """The frames of each tour taken at about ``sample_rate`` per second, as a
    recording at that rate would hold them.

    In each tour (``groups``) every ``k``-th frame by frame number is kept
    (:func:`sampling_stride` of the tour's frame rate; a tour whose frames carry
    none is refused: sampling in time needs the time), counting from the tour's
    first frame; a kept frame is
    renumbered ``(frame - first) // k + 1`` and carries the rate ``rate / k``, so
    that the stages that count frames (trajectory gaps and lengths) see the sample
    as a recording at that rate and a gap of the tour stays a gap.  The images are
    not touched (a lazy image stays undecoded).

    Parameters
    ----------
    X : sequence of FrameRecord
        Frames in tour order, as :func:`~tunnelsense.to_xy` gives them.
    y : list
        Per frame targets, aligned with ``X``.
    groups : sequence of int
        The tour of each frame.
    sample_rate : float or None
        Frames per second to keep at least; None keeps every frame unchanged.

    Returns
    -------
    X, y, groups : list, list, list
        The kept frames, their targets and tours.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import FrameRecord
    >>> from tunnelsense._records._sampling import sample_in_time
    >>> X = [FrameRecord("t", f, np.zeros((2, 2), np.uint8), {"frame_rate": 30.0})
    ...      for f in range(1, 12)]
    >>> Xs, ys, gs = sample_in_time(X, list(range(11)), [0] * 11, 6.0)
    >>> [r.frame for r in Xs], ys, Xs[0].payload["frame_rate"]
    ([1, 2, 3], [0, 5, 10], 6.0)
    """
    from tunnelsense._payload import FRAME_RATE, frame_rate_of  # noqa: PLC0415

    if sample_rate is None:
        return X, y, groups
    if not (isinstance(sample_rate, numbers.Real) and not isinstance(sample_rate, bool)
            and math.isfinite(sample_rate) and sample_rate > 0):
        raise ValueError("sample_rate must be None or a positive number of frames per "
                         f"second; got {sample_rate!r}")
    kept_X, kept_y, kept_groups = [], [], []
    first, stride, rate = {}, {}, {}
    for record, target, group in zip(X, y, groups, strict=True):
        if group not in first:
            first[group] = record.frame
            rate[group] = frame_rate_of(record)
            if not rate[group]:
                raise InputFormatError(
                    f"tour {record.tour!r}: its frames carry no frame rate (a "
                    "MOTChallenge tour's seqinfo.ini frameRate); sample_rate needs it")
            stride[group] = sampling_stride(rate[group], sample_rate)
        offset = record.frame - first[group]
        if offset % stride[group]:
            continue
        if stride[group] > 1:
            record = type(record)(record.tour, offset // stride[group] + 1, record.source,
                                  {**record.payload,
                                   FRAME_RATE: rate[group] / stride[group]})
        kept_X.append(record)
        kept_y.append(target)
        kept_groups.append(group)
    return kept_X, kept_y, kept_groups
