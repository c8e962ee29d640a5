"""The order of a stream's records: the one order check and the grouping by tour.

The records of one tour (run) arrive in increasing frame (scan) order, each once;
:func:`check_next_key` checks that, for batch and streaming alike, and
:func:`tour_groups` and :func:`stream_order` put records held in memory into that
order (see :mod:`tunnelsense._streaming`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["check_next_key", "stream_order", "tour_groups"]


def _key_names(record):
    """What the two parts of a record's key are called: (tour, frame) or (run, scan)."""
    return ("run", "scan") if hasattr(record, "scan") else ("tour", "frame")


def check_next_key(last, record):
    """Check that ``record`` may follow the record whose key is ``last``; return its key.

    The one order check of the package: the records of one tour (run) arrive in
    increasing frame (scan) order, each once; a record of another tour may follow
    any record.

    Parameters
    ----------
    last : tuple or None
        The key ``(tour, frame)`` (or ``(run, scan)``) of the previous record.
    record : FrameRecord or ScanRecord

    Returns
    -------
    key : tuple
        ``record.key``.

    Raises
    ------
    ValueError
        When ``record`` repeats or precedes ``last`` in the same tour.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import FrameRecord
    >>> from tunnelsense._stream_order import check_next_key
    >>> img = np.zeros((2, 2), np.uint8)
    >>> check_next_key(("a", 1), FrameRecord("a", 2, img))
    ('a', 2)
    >>> check_next_key(("a", 2), FrameRecord("a", 2, img))
    Traceback (most recent call last):
    ...
    ValueError: frame 2 of tour 'a' came twice: the records of one tour must arrive once each, in increasing frame order
    """
    key = record.key
    if last is not None and key[0] == last[0] and key[1] <= last[1]:
        tour, frame = _key_names(record)
        if key[1] == last[1]:
            raise ValueError(
                f"{frame} {key[1]} of {tour} {key[0]!r} came twice: the records of "
                f"one {tour} must arrive once each, in increasing {frame} order"
            )
        raise ValueError(
            f"the records of one {tour} must arrive once each, in increasing {frame} "
            f"order: {key} came after {last}"
        )
    return key


def tour_groups(records, *, sort_tours=False):
    """Indices of ``records`` grouped by tour (run) and sorted by frame (scan).

    Parameters
    ----------
    records : sequence of FrameRecord or ScanRecord
    sort_tours : bool, default=False
        Order the groups by the tours' names (as strings) rather than by their first
        appearance.

    Returns
    -------
    groups : list of ndarray of int
        One array of record indices per tour, in frame order.

    Raises
    ------
    ValueError
        When a key ``(tour, frame)`` appears twice (:func:`check_next_key`).

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import FrameRecord
    >>> from tunnelsense._stream_order import tour_groups
    >>> img = np.zeros((2, 2), np.uint8)
    >>> X = [FrameRecord(t, f, img) for t, f in [("b", 2), ("a", 1), ("b", 1)]]
    >>> [g.tolist() for g in tour_groups(X)]
    [[2, 0], [1]]
    >>> [g.tolist() for g in tour_groups(X, sort_tours=True)]
    [[1], [2, 0]]
    """
    keys = [r.key for r in records]
    by_tour: dict = {}
    for i, key in enumerate(keys):
        by_tour.setdefault(key[0], []).append(i)
    tours = sorted(by_tour, key=str) if sort_tours else list(by_tour)
    groups = []
    for tour in tours:
        idx = np.asarray(by_tour[tour], dtype=np.intp)
        frames = np.fromiter((keys[i][1] for i in idx), np.int64, len(idx))
        idx = idx[np.argsort(frames, kind="stable")]
        last = None
        for i in idx.tolist():
            last = check_next_key(last, records[i])
        groups.append(idx)
    return groups


def stream_order(records, *, sort_tours=False):
    """The order in which a stream state sees ``records``: by tour, then by frame.

    Parameters
    ----------
    records : sequence of FrameRecord or ScanRecord
    sort_tours : bool, default=False
        As in :func:`tour_groups`.

    Returns
    -------
    order : ndarray of int
        Indices of ``records``; ``records[order]`` is a valid stream.

    Raises
    ------
    ValueError
        When a key ``(tour, frame)`` appears twice (:func:`check_next_key`).
    """
    groups = tour_groups(records, sort_tours=sort_tours)
    return np.concatenate(groups) if groups else np.empty(0, np.intp)
