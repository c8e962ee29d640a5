"""Splitting vehicles merged into one object (beyond the paper).

Nose to tail: an object's height profile along the track (its top height in every
scan) has one hump per vehicle: roof, with bonnet and boot lower at its ends.  Two
humps with a valley between them are two vehicles; a stretch hidden by something
nearer is a gap only where the seen profile falls into it and rises out of it.

In echelon (bays at an angle to the kerb): an object's near side along the track
(its nearest body depth in every scan) has one valley per vehicle, the corner it
turns to the street; two valleys with a ridge between them are two vehicles.
"""

from __future__ import annotations

import numpy as np

from tunnelsense.street._clustering import concat
from tunnelsense.street._history import metres_from

__all__ = ["split_echelon", "split_near_side", "split_objects", "split_profile"]


def _fill_hidden(top, band):
    """Hidden (NaN) runs of a height profile: a gap (0) where the seen profile falls
    into them and rises out of them (a vehicle's profile has one hump), else the
    lower of their seen neighbours; and which scans may not be a split point."""
    top = top.copy()
    unknown = np.isnan(top)
    if not unknown.any():
        return top, unknown
    known = np.flatnonzero(~unknown)
    if not len(known):
        return np.zeros_like(top), np.ones(len(top), dtype=bool)
    edges = np.flatnonzero(np.diff(concat(0, unknown.astype(np.int8), 0)))
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        left, right = top[:a][~unknown[:a]], top[b:][~unknown[b:]]
        if len(left) and len(right):
            falls = left[-1] < left.max() - band
            rises = right[0] < right.max() - band
            if falls and rises:
                top[a:b] = 0.0
                unknown[a:b] = False
                continue
        top[a:b] = min(left[-1] if len(left) else np.inf,
                       right[0] if len(right) else np.inf)
    return top, unknown


def split_profile(top, step, *, min_length=2.0, ratio=0.6, band=0.15):
    """Where to split an object whose height profile has two humps.

    Two vehicles parked nose to tail and merged into one object show, along the track,
    two humps of the top height (roofs, 1.2-2 m) with a valley between them (bumpers,
    0.3-0.7 m, or the road seen through the gap).  A single vehicle has one hump:
    its low parts (bumpers, bonnet, boot) are at its ends.

    The split point is the scan of lowest ``top / min(left peak, right peak)`` among
    the scans that leave at least ``min_length`` metres on both sides; it is accepted
    when that ratio is at most ``ratio``.  Applied recursively to both parts.

    Parameters
    ----------
    top : ndarray of shape (n_scans,)
        Top height (m) of the object in each of its scans (NaN where hidden: a
        hidden run is a gap where the seen profile falls into it and rises out of it
        by more than ``band``, else never the split point).
    step : float
        Distance (m) travelled between two scans.
    min_length : float, default=2.0
        Shortest part (m) a split may leave.
    ratio : float, default=0.6
        Largest valley-to-peak ratio that splits.
    band : float, default=0.15
        How far (m) below its side's peak a profile must fall into a hidden run for
        that run to be a gap.

    Returns
    -------
    cuts : list of int
        Scan offsets where a new object starts (sorted).

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street import split_profile
    >>> car = np.r_[0.5, 0.9, 0.9, 1.4, 1.45, 1.4, 1.0, 0.5]
    >>> split_profile(np.r_[car, car], step=0.6)
    [8]
    >>> split_profile(car, step=0.6)
    []
    """
    top = raw = np.asarray(top, dtype=np.float64)
    top, unknown = _fill_hidden(top, band)
    n = len(top)
    k = max(int(np.ceil(min_length / max(step, 1e-9))), 1)
    if n < 2 * k + 1:
        return []
    left = np.maximum.accumulate(top)
    right = np.maximum.accumulate(top[::-1])[::-1]
    idx = np.arange(k, n - k)
    peak = np.minimum(left[idx - 1], right[idx + 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        score = np.where((peak > 0) & ~unknown[idx], top[idx] / peak, np.inf)
    j = int(np.argmin(score))
    if not score[j] <= ratio:
        return []
    cut = int(idx[j])
    # the valley scan goes with its higher neighbour (a bumper with its own body)
    start = cut + 1 if top[cut - 1] > top[cut + 1] else cut
    start = min(max(start, k), n - k)
    a = split_profile(raw[:start], step, min_length=min_length, ratio=ratio, band=band)
    b = split_profile(raw[start:], step, min_length=min_length, ratio=ratio, band=band)
    return [*a, start, *(start + c for c in b)]


def split_objects(prof, objects, cum, near, *, min_length, ratio, link_distance,
                  horizon=None, step=None, gap=None):
    """Split objects with a two-hump height profile; the new object of every cluster.

    Scans of an object's span where it has no cluster count as height 0 (a gap
    between two vehicles), unless something nearer hid it (then unknown).  With
    ``horizon`` (per scan, the lowest height at which the beams passing every
    ``step`` metres of depth cross it, see
    :func:`~tunnelsense.street._geometry.horizon`), such a scan is unknown only
    where no beam passes the object's depth below the seen tops on either side: a
    beam ending on a nearer object says nothing, one passing over the object's place
    shows the gap.
    ``objects`` and ``prof.position`` are per intra-cluster, as in ``prof``.
    ``gap`` (per scan position, optional): metres of lost scans before it that
    count to its stretch in ``cum``; not an object's that starts there
    (:func:`~tunnelsense.street._history.metres_from`).
    """
    new = objects.copy()
    next_object = prof.n
    all_cum = cum
    for o in range(prof.n):
        first, last = prof.first[o], prof.last[o]
        span = last - first + 1
        cum = metres_from(all_cum, gap, first)
        if cum[last + 1] - cum[first] < 2 * min_length:
            continue
        top = np.zeros(span)
        seen, seen_top = prof.profile(o)
        if horizon is None:
            top[near[first:last + 1] < prof.depth[o] - link_distance] = np.nan
        else:  # hidden where the beams pass above the seen tops on either side
            j = min(max(int(np.ceil(prof.depth[o] / step)), 1), horizon.shape[1]) - 1
            k = np.searchsorted(seen - first, np.arange(span))
            side = np.maximum(seen_top[np.maximum(k - 1, 0)],
                              seen_top[np.minimum(k, len(seen) - 1)])
            top[horizon[first:last + 1, j] >= side] = np.nan
        top[seen - first] = seen_top
        cuts = split_profile(top, (cum[last + 1] - cum[first]) / span,
                             min_length=min_length, ratio=ratio)
        if not cuts:
            continue
        mine = np.flatnonzero(objects == o)
        part = np.searchsorted(np.asarray(cuts), prof.position[mine] - first,
                               side="right")
        new[mine] = np.where(part == 0, o, next_object + part - 1)
        next_object += len(cuts)
    return new


def _face_length(s, start, end, i, tol):
    """Length (m along the track) of the run of scans around ``i`` whose near side
    ``s`` stays within ``tol`` of ``s[i]`` (scan ``k`` covers ``start[k]..end[k]``)."""
    near = s >= s[i] - tol
    lo = i
    while lo > 0 and near[lo - 1]:
        lo -= 1
    hi = i
    while hi < len(s) - 1 and near[hi + 1]:
        hi += 1
    return float(end[hi] - start[lo])


def split_near_side(side, along, *, min_length, travel):
    """Where to split an object whose near side shows two vehicles in echelon.

    A vehicle in a bay at an angle to the kerb turns a corner to the street: along
    the track its near side (nearest body depth of every scan) comes forward along
    one end and steps back along its flank, one valley.  Neighbours in a row of such
    bays overlap along the street, so one scan can cut two of them and they join
    into one object; its near side then has a ridge between two valleys: it steps
    back across the street along one vehicle's flank and comes forward again at the
    next one's end.  A vehicle parked along the kerb keeps its near side.

    The split point is the scan of the highest ridge that rises at least ``travel``
    above the nearest near side on both sides, leaving at least ``min_length``
    metres on each; its scan goes with the side it continues.  Applied recursively
    to both parts.  A ridge is a corner: the near side falls away from it along a
    flank on one side and steps forward at the next vehicle's end on the other.
    One whose near side stays within ``travel / 4`` of it for ``travel / 2`` metres
    or more along the track is a face along the street (a hedge or wall seen
    between two vehicles in front of it), never a split point.

    Parameters
    ----------
    side : ndarray of shape (n_scans,)
        Near side (m) of the object in each of its scans (NaN: no body seen).
    along : ndarray of shape (n_scans + 1,)
        Distance (m) along the track at the start of every scan and past the last.
    min_length : float
        Shortest part (m along the track) a split may leave.
    travel : float
        How far (m) the near side must step back across the street from each
        valley to the ridge.

    Returns
    -------
    cuts : list of int
        Scan offsets where a new object starts (sorted).

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._splitting import split_near_side
    >>> car = np.r_[4.2, 3.8, 3.4, 3.0, 3.3, 3.6, 3.9, 4.2, 4.5, 4.8, 5.1]
    >>> split_near_side(np.r_[car, car], np.arange(23) * 0.4, min_length=2.4,
    ...                 travel=1.0)
    [11]
    >>> split_near_side(car, np.arange(12) * 0.4, min_length=2.4, travel=1.0)
    []
    """
    side = np.asarray(side, dtype=np.float64)
    along = np.asarray(along, dtype=np.float64)
    n = len(side)
    seen = np.flatnonzero(np.isfinite(side))
    if len(seen) < 3:
        return []
    s = side[seen]
    left = np.minimum.accumulate(s)
    right = np.minimum.accumulate(s[::-1])[::-1]
    idx = np.arange(1, len(seen) - 1)
    rise = np.minimum(s[idx] - left[idx - 1], s[idx] - right[idx + 1])
    room = ((along[seen[idx]] - along[0] >= min_length)
            & (along[n] - along[seen[idx] + 1] >= min_length))
    rise = np.where(room, rise, -np.inf)
    for j in np.flatnonzero(rise >= travel):
        if _face_length(s, along[seen], along[seen + 1], int(idx[j]),
                        travel / 4) >= travel / 2:
            rise[j] = -np.inf  # a face along the street (a hedge), no corner
    j = int(np.argmax(rise))
    if not rise[j] >= travel:
        return []
    i = int(idx[j])
    # the ridge scan goes with the neighbour whose near side it continues
    start = seen[i] + 1 if abs(s[i] - s[i - 1]) <= abs(s[i] - s[i + 1]) else seen[i]
    a = split_near_side(side[:start], along[:start + 1], min_length=min_length,
                        travel=travel)
    b = split_near_side(side[start:], along[start:], min_length=min_length,
                        travel=travel)
    start = int(start)
    return [*a, start, *(start + c for c in b)]


def split_echelon(objects, position, side, far, first, last, cum, *, min_length,
                  depth, gap=None):
    """Split objects whose near side shows vehicles in echelon; the new object of
    every cluster.

    Only an object whose bodies are deep across the street (the median over its
    scans of the body's depth extent at least ``depth``: a car seen obliquely, not a
    hedge or wall) is split, where its near side steps back by at least half that
    median extent on both sides of a ridge (a car's step, from the object itself:
    see :func:`split_near_side`), each part at least ``min_length`` long.

    Parameters
    ----------
    objects, position : ndarray of shape (n_clusters,) of int
        Object number and scan position (from the window's start) of every cluster.
    side, far : ndarray of shape (n_clusters,)
        Nearest and farthest body depth (m) of every cluster (inf/NaN: no body).
    first, last : ndarray of shape (n_objects,) of int
        First and last scan position of every object.
    cum : ndarray
        Distance (m) along the track at the start of every scan of the window.
    min_length : float
        Shortest part (m) a split may leave (a car).
    depth : float
        Smallest median body extent (m) across the street of an object to split.
    gap : ndarray of shape (n_positions,), optional
        Metres of lost scans right before every scan position, which count to its
        stretch in ``cum`` but not to an object that starts there.

    Returns
    -------
    objects : ndarray of shape (n_clusters,) of int64
    """
    new = objects.copy()
    next_object = len(first)
    near = np.where(np.isfinite(side), side, np.nan)
    all_cum = cum
    for o in range(len(first)):
        lo, hi = int(first[o]), int(last[o])
        cum = metres_from(all_cum, gap, lo)
        if cum[hi + 1] - cum[lo] < 2 * min_length:
            continue
        mine = np.flatnonzero(objects == o)
        pos = position[mine] - lo
        scan_side = np.full(hi - lo + 1, np.inf)
        np.fmin.at(scan_side, pos, near[mine])
        scan_far = np.full(hi - lo + 1, -np.inf)
        np.fmax.at(scan_far, pos, far[mine])
        with np.errstate(invalid="ignore"):
            extent = scan_far - scan_side
        extent = extent[np.isfinite(extent)]
        if not len(extent) or not np.median(extent) >= depth:
            continue
        scan_side[~np.isfinite(scan_side)] = np.nan
        cuts = split_near_side(scan_side, cum[lo:hi + 2] - cum[lo],
                               min_length=min_length, travel=np.median(extent) / 2)
        if not cuts:
            continue
        part = np.searchsorted(np.asarray(cuts), pos, side="right")
        new[mine] = np.where(part == 0, o, next_object + part - 1)
        next_object += len(cuts)
    return new
