"""Objects from object-clusters: three-region merging, splitting and labelling.

Paper section III-F and, beyond the paper, the splitting of vehicles parked nose to
tail and the rejection of objects that show no vehicle body (see ``docs/street.md``).
Every function here is array in, array out, on positions within a window of
consecutive scans: ``cum[p]`` is the distance (m) travelled up to scan ``p``,
``near[p]`` the mean depth of the nearest intra-cluster of scan ``p`` and
``follows[p]`` whether scan ``p`` directly follows scan ``p - 1``.
"""

from __future__ import annotations

import numpy as np

from tunnelsense.street._clustering import concat

__all__ = [
    "ObjectProfiles",
    "bridged",
    "depth_region",
    "extend_occluded",
    "hidden_ends",
    "is_vehicle",
    "merge_fragments",
    "split_objects",
    "split_profile",
]

#: Bits of the per-cluster evidence flags that show a vehicle body: roof, wall, raised.
BODY_FLAGS = 0b0111
#: Shortest visible part (m) of a vehicle cut short by an occluder.
MIN_VISIBLE = 0.5


def depth_region(depth, edges):
    """Region index (0, 1, 2 for I, II, III) of mean depths, split at ``edges``.

    Examples
    --------
    >>> from tunnelsense.street._objects import depth_region
    >>> depth_region([2.5, 5.0, 7.0], (4.0, 6.6)).tolist()
    [0, 1, 2]
    """
    return np.searchsorted(edges, depth, side="right")


class ObjectProfiles:
    """Per object aggregates and per (object, scan) height profiles.

    Parameters
    ----------
    objects : ndarray of shape (n_clusters,) of int
        Object number (0 ... n_objects - 1) of every intra-cluster.
    position : ndarray of shape (n_clusters,) of int
        Scan position of every intra-cluster.
    depth, top, n_points : ndarray of shape (n_clusters,)
        Mean depth, top height and number of points of every intra-cluster.
    flags : ndarray of shape (n_clusters,) of int8, default=None
        Cross-section evidence bits of every intra-cluster (``BODY_FLAGS``).
    """

    def __init__(self, objects, position, depth, top, n_points, flags=None):
        self.position = position
        self.n = n = int(objects.max()) + 1 if len(objects) else 0
        self.scan_flags_ = np.empty(0, dtype=np.int8)
        if n == 0:
            empty = np.empty(0, dtype=np.int64)
            self.scan_position = self.first = self.last = empty
            self.rows = np.zeros(1, dtype=np.int64)
            self.scan_top = self.start_depth = self.end_depth = np.empty(0)
            self.n_points = self.depth = self.top = np.empty(0)
            return
        order = np.lexsort((position, objects))
        obj, pos = objects[order], position[order]
        # one row per (object, scan)
        starts = np.flatnonzero(concat(True, (obj[1:] != obj[:-1]) | (pos[1:] != pos[:-1])))
        weight = n_points[order]
        scan_weight = np.add.reduceat(weight, starts)
        scan_depth = np.add.reduceat(weight * depth[order], starts) / np.maximum(
            scan_weight, 1)
        self.scan_top = np.maximum.reduceat(top[order], starts)
        if flags is not None:
            self.scan_flags_ = np.bitwise_or.reduceat(flags[order], starts)
        scan_obj, self.scan_position = obj[starts], pos[starts]
        first_row = np.flatnonzero(concat(True, scan_obj[1:] != scan_obj[:-1]))
        last_row = concat(first_row[1:], len(scan_obj)) - 1
        self.rows = concat(first_row, len(scan_obj))
        self.first = self.scan_position[first_row]
        self.last = self.scan_position[last_row]
        self.start_depth = scan_depth[first_row]
        self.end_depth = scan_depth[last_row]
        self.n_points = np.bincount(objects, weights=n_points, minlength=n)
        self.depth = np.bincount(objects, weights=n_points * depth, minlength=n) / (
            np.maximum(self.n_points, 1))
        self.top = np.maximum.reduceat(self.scan_top, first_row)

    def profile(self, o):
        """Scan positions and top heights of object ``o``'s scans."""
        a, b = self.rows[o], self.rows[o + 1]
        return self.scan_position[a:b], self.scan_top[a:b]

    def flags(self, o):
        """Evidence bits of object ``o``'s scans."""
        return self.scan_flags_[self.rows[o]:self.rows[o + 1]]


def bridged(end_depth, start_depth, after, before, cum, near, *, link_distance,
            merge_gap, occlusion_margin, bridge_occluded):
    """The merge rule for a fragment starting after another one ends.

    The first ends before scan ``after``, the second starts at scan ``before``.
    They join when the first's last and the second's first mean depths differ by less
    than ``link_distance`` and the gap between them (``cum[before] - cum[after]``
    metres) is at most ``merge_gap``, or (``bridge_occluded``) every scan of the gap
    shows something at least ``occlusion_margin`` nearer.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._objects import bridged
    >>> rule = dict(link_distance=0.5, merge_gap=0.5, occlusion_margin=1.0,
    ...             bridge_occluded=True)
    >>> cum = np.arange(8) * 1.5  # metres travelled up to every scan
    >>> near = np.array([5.0, 5.0, 2.5, 2.4, 5.2, 5.2, 5.2])
    >>> bridged(5.0, 5.2, 2, 4, cum, near, **rule)  # a passing vehicle hid the gap
    True
    >>> near[3] = np.inf
    >>> bridged(5.0, 5.2, 2, 4, cum, near, **rule)
    False
    """
    if not abs(end_depth - start_depth) < link_distance:
        return False
    if cum[before] - cum[after] <= merge_gap:
        return True
    hidden = near[after:before] < min(end_depth, start_depth) - occlusion_margin
    return bool(bridge_occluded and np.all(hidden))


def merge_fragments(prof, region, cum, near, follows, *, reach, **rule):
    """Three-region merging: union-find root of every fragment (object-cluster).

    Fragment ``b`` (later start) joins fragment ``a`` of the same stretch of scans and
    the same region when they overlap in time over at least half of the shorter one
    (the paper's rule), or when ``b`` starts after ``a`` ends and :func:`bridged`
    joins them; fragments starting more than ``reach`` metres apart never join.
    ``rule`` holds the keywords of :func:`bridged`.

    Parameters
    ----------
    prof : ObjectProfiles
        The fragments.
    region : ndarray of shape (n_fragments,) of int
        Region of every fragment's mean depth (:func:`depth_region`).
    cum, near, follows : ndarray
        The window's distances, nearest depths and scan continuity.
    reach : float
        ``max_length + merge_gap``.

    Returns
    -------
    root : ndarray of shape (n_fragments,) of int64
        The smallest fragment of every fragment's merged object-cluster.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._objects import (ObjectProfiles, depth_region,
    ...                                          merge_fragments)
    >>> # two fragments of a car 0.2 m apart, and a passing vehicle nearer
    >>> prof = ObjectProfiles(np.array([0, 0, 0, 1, 1, 2]), np.array([0, 1, 2, 4, 5, 5]),
    ...                       np.array([5.0, 5.0, 5.0, 5.1, 5.1, 2.0]), np.full(6, 1.4),
    ...                       np.full(6, 20.0))
    >>> merge_fragments(prof, depth_region(prof.depth, (4.0, 6.6)), np.arange(7) * 0.2,
    ...                 np.array([5.0, 5.0, 5.0, np.inf, 2.0, 2.0]),
    ...                 np.array([False, True, True, True, True, True]), reach=25.5,
    ...                 link_distance=0.5, merge_gap=0.5, occlusion_margin=1.0,
    ...                 bridge_occluded=True).tolist()
    [0, 0, 2]
    """
    first, last = prof.first, prof.last
    stretch = np.cumsum(~follows) - 1
    parent = np.arange(prof.n)

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    order = np.lexsort((first, region, stretch[first]))
    for j in range(1, prof.n):
        b = order[j]
        for a in order[j - 1::-1]:
            if stretch[first[a]] != stretch[first[b]] or region[a] != region[b]:
                break
            if cum[first[b]] - cum[first[a]] > reach:
                break
            overlap = min(last[a], last[b]) - max(first[a], first[b]) + 1
            if overlap > 0:
                shorter = min(last[a] - first[a], last[b] - first[b]) + 1
                join = overlap >= 0.5 * shorter
            else:
                lo, hi = (a, b) if last[a] < first[b] else (b, a)
                join = bridged(prof.end_depth[lo], prof.start_depth[hi], last[lo] + 1,
                               first[hi], cum, near, **rule)
            if join:
                ra, rb = find(a), find(b)
                if ra != rb:
                    parent[max(ra, rb)] = min(ra, rb)
    return np.array([find(i) for i in range(prof.n)], dtype=np.int64)


def split_profile(top, step, *, min_length=2.0, ratio=0.6):
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
        Top height (m) of the object in each of its scans (NaN where not seen).
    step : float
        Distance (m) travelled between two scans.
    min_length : float, default=2.0
        Shortest part (m) a split may leave.
    ratio : float, default=0.6
        Largest valley-to-peak ratio that splits.

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
    top = np.asarray(top, dtype=np.float64)
    top = np.where(np.isnan(top), 0.0, top)
    n = len(top)
    k = max(int(np.ceil(min_length / max(step, 1e-9))), 1)
    if n < 2 * k + 1:
        return []
    left = np.maximum.accumulate(top)
    right = np.maximum.accumulate(top[::-1])[::-1]
    idx = np.arange(k, n - k)
    peak = np.minimum(left[idx - 1], right[idx + 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        score = np.where(peak > 0, top[idx] / peak, np.inf)
    j = int(np.argmin(score))
    if not score[j] <= ratio:
        return []
    cut = int(idx[j])
    # the valley scan goes with its higher neighbour (a bumper with its own body)
    start = cut + 1 if top[cut - 1] > top[cut + 1] else cut
    start = min(max(start, k), n - k)
    a = split_profile(top[:start], step, min_length=min_length, ratio=ratio)
    b = split_profile(top[start:], step, min_length=min_length, ratio=ratio)
    return [*a, start, *(start + c for c in b)]


def split_objects(prof, objects, cum, near, *, min_length, ratio, link_distance):
    """Split objects with a two-hump height profile; the new object of every cluster.

    Scans of an object's span where it has no cluster count as height 0 (a gap
    between two vehicles), unless something nearer hid it (then unknown).
    ``objects`` and ``prof.position`` are per intra-cluster, as in ``prof``.
    """
    new = objects.copy()
    next_object = prof.n
    for o in range(prof.n):
        first, last = prof.first[o], prof.last[o]
        span = last - first + 1
        if cum[last + 1] - cum[first] < 2 * min_length:
            continue
        top = np.zeros(span)
        seen, seen_top = prof.profile(o)
        top[near[first:last + 1] < prof.depth[o] - link_distance] = np.nan
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


def hidden_ends(near, follows, first, last, depth, cum, cap):
    """Scans right before ``first`` and after ``last`` (within one stretch of
    consecutive scans) whose nearest cluster is nearer than ``depth``; each walk stops
    once it covers ``cap`` metres (no decision looks farther).

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._objects import hidden_ends
    >>> near = np.array([5.0, 2.0, 2.0, 5.0, 5.0])  # something nearer in scans 1, 2
    >>> hidden_ends(near, np.array([False, True, True, True, True]), 3, 4, 4.0,
    ...             np.arange(6) * 0.5, 4.0)
    (2, 0)
    """
    before = 0
    p = first - 1
    while (p >= 0 and follows[p + 1] and near[p] < depth
           and cum[first] - cum[p + 1] < cap):
        before += 1
        p -= 1
    after = 0
    p = last + 1
    while (p < len(near) and follows[p] and near[p] < depth
           and cum[p] - cum[last + 1] < cap):
        after += 1
        p += 1
    return before, after


def is_vehicle(seen, flags, depth, hidden_length, cum, near, *, min_length, max_length,
               link_distance, min_body_fraction):
    """Whether an object (its scans ``seen``, sorted) can be one vehicle.

    Long enough in all and without a break (a scan of its span counts as seen when
    something at least ``link_distance`` nearer hid it), or, cut short by an occluder
    (``hidden_length`` metres hidden at its ends), long enough with the hidden part;
    not longer than ``max_length``; a vehicle body (roof, wall or raised body) in at
    least ``min_body_fraction`` of its scans.
    """
    length = cum[seen[-1] + 1] - cum[seen[0]]
    cut_short = hidden_length > 0 and length >= MIN_VISIBLE
    vehicle = length <= max_length and (
        length >= min_length or (cut_short and length + hidden_length >= min_length))
    if vehicle:
        covered = near[seen[0]:seen[-1] + 1] < depth - link_distance
        covered[seen - seen[0]] = True
        edges = concat(-1, np.flatnonzero(~covered), len(covered)) + seen[0]
        longest = (cum[edges[1:]] - cum[edges[:-1] + 1]).max()
        seen_length = (cum[seen + 1] - cum[seen]).sum()
        if cut_short:
            vehicle = bool(seen_length >= MIN_VISIBLE
                           and longest + hidden_length >= min_length)
        else:
            vehicle = bool(min(longest, seen_length) >= min_length)
    body = float(np.mean((flags & BODY_FLAGS) > 0))
    return bool(vehicle and body >= min_body_fraction)


def extend_occluded(cum, first, last, lowest, highest, occluded_length):
    """Extend an object cut short by an occluder into the hidden scans.

    Half of the missing length goes before the object, half after (more on one side
    when the other has no room); never beyond the scans ``lowest .. highest``.

    Returns
    -------
    first, last : int
        The extended scan positions.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._objects import extend_occluded
    >>> extend_occluded(np.arange(21) * 0.2, 8, 12, 4, 12, 2.0)
    (4, 12)
    """
    want = occluded_length - (cum[last + 1] - cum[first])
    if want <= 0:
        return first, last
    room_before = cum[first] - cum[lowest]
    room_after = cum[highest + 1] - cum[last + 1]
    take_before = min(room_before, max(want / 2, want - room_after))
    take_after = min(room_after, want - take_before)
    if take_before > 0:
        first = max(int(np.searchsorted(cum, cum[first] - take_before, side="left")),
                    lowest)
    if take_after > 0:
        last = min(int(np.searchsorted(cum, cum[last + 1] + take_after,
                                       side="left")) - 1, highest)
    return first, last
