"""Validation of what stages take: ``check_frames`` and ``check_scans``."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from tunnelsense._records._frames import FrameRecord
from tunnelsense._records._scans import ScanRecord
from tunnelsense._records._sequences import FrameSequence, ScanSequence

__all__ = ["check_frames", "check_scans"]


def _as_records(X, record_type, container, name):
    if isinstance(X, container):
        return list(X)
    if isinstance(X, np.ndarray | str | bytes | Mapping):
        raise TypeError(
            f"{name} must be a sequence of {record_type.__name__} "
            f"(for example a {container.__name__}); got {type(X).__name__}"
            + (f" of shape {X.shape}" if isinstance(X, np.ndarray) else "")
        )
    try:
        records = list(X)
    except TypeError:
        raise TypeError(
            f"{name} must be a sequence of {record_type.__name__}; "
            f"got {type(X).__name__}"
        ) from None
    for i, r in enumerate(records):
        if not isinstance(r, record_type):
            raise TypeError(
                f"{name} must be a sequence of {record_type.__name__}; "
                f"element {i} is {type(r).__name__}"
            )
    return records


def _check_y(y, n, width, name_of_kind, dtype):
    if y is None:
        return None
    if isinstance(y, np.ndarray) and y.dtype != object and y.ndim != 3:
        raise ValueError(
            f"y must hold one array per {name_of_kind}; got an array of shape {y.shape}"
        )
    try:
        y = list(y)
    except TypeError:
        raise TypeError(
            f"y must be a sequence with one array per {name_of_kind}; "
            f"got {type(y).__name__}"
        ) from None
    if len(y) != n:
        raise ValueError(
            f"y has {len(y)} entries but X has {n} {name_of_kind}s: "
            f"expected one per {name_of_kind}"
        )
    out = []
    for i, yi in enumerate(y):
        try:
            a = np.asarray(yi, dtype=dtype)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"y[{i}] is not numeric: {exc}") from None
        if a.size == 0:
            a = a.reshape(0, width)
        if a.ndim != 2 or a.shape[1] != width:
            raise ValueError(
                f"y[{i}] must have shape (k, {width}); got shape {a.shape}"
            )
        if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
            raise ValueError(f"y[{i}] contains NaN or infinity")
        out.append(a)
    return out


def check_frames(X, y=None):
    """Validate frame records (and per-frame boxes) for a frame stage.

    Parameters
    ----------
    X : sequence of FrameRecord
        A :class:`FrameSequence` or any sequence of :class:`FrameRecord` (for example
        the plain list scikit-learn makes for a CV fold).
    y : sequence of array-like of shape (k_i, 4), default=None
        Per frame, the indicator boxes ``(left, top, width, height)``.

    Returns
    -------
    records : list of FrameRecord
    y : list of ndarray of shape (k_i, 4), float64, or None

    Raises
    ------
    TypeError
        ``X`` is not a sequence of :class:`FrameRecord`.
    ValueError
        ``y`` does not hold one ``(k, 4)`` finite numeric array per frame.
    """
    records = _as_records(X, FrameRecord, FrameSequence, "X")
    return records, _check_y(y, len(records), 4, "frame", np.float64)


def check_scans(X, y=None):
    """Validate scan records (and per-scan targets) for a scan stage.

    Parameters
    ----------
    X : sequence of ScanRecord
        A :class:`ScanSequence` or any sequence of :class:`ScanRecord`.
    y : sequence of array-like of shape (k_i, 2), default=None
        Per scan, ``(object id, label code)`` of the objects in view.

    Returns
    -------
    records : list of ScanRecord
    y : list of ndarray of shape (k_i, 2), int64, or None
    """
    records = _as_records(X, ScanRecord, ScanSequence, "X")
    for i, r in enumerate(records):
        if r.ranges.ndim != 1:
            raise ValueError(
                f"X[{i}] ({r.run!r}, scan {r.scan}): ranges must be 1-D; "
                f"got shape {r.ranges.shape}"
            )
    return records, _check_y(y, len(records), 2, "scan", np.int64)
