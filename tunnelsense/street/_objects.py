"""Objects from object-clusters: their profiles and the three-region merge.

Paper section III-E (the three regions) and, beyond the paper, the join rule of the
merge written once in :func:`bridged` (see ``docs/street.md``); whether an object is a
vehicle is decided in ``_vehicles``, the splitting of vehicles parked nose to tail in
``_splitting``.  Every function here is array in, array out, on positions within a window of
consecutive scans: ``cum[p]`` is the distance (m) travelled up to scan ``p``,
``near[p]`` the mean depth of the nearest intra-cluster of scan ``p`` and
``follows[p]`` whether scan ``p`` follows scan ``p - 1`` (directly, or across
missing scans linked over).
"""

from __future__ import annotations

import numpy as np

from tunnelsense.street._clustering import concat, seen_past

__all__ = [
    "ObjectProfiles",
    "bridged",
    "depth_region",
    "merge_fragments",
    "near_side",
    "see_through",
]

#: Bits of the per-cluster evidence flags that show a vehicle body: roof, wall, raised.
BODY_FLAGS = 0b0111
#: Bit of the per-cluster evidence flags of a raised body (between the wheels).
RAISED_FLAG = 0b0100
#: Bit of the per-cluster evidence flags of a cluster whose lower part is hidden.
HIDDEN_FLAG = 0b1000
#: Bit of the per-cluster evidence flags of a cluster a beam passes under
#: (:func:`~tunnelsense.street.passed_under`): counts as raised for a motorbike
#: across the kerb only.
PASSED_FLAG = 0b10000
#: Bit of the per-cluster evidence flags of a cluster seen hanging in the air: its
#: lowest point above the clearance, the beam just below it passing farther
#: (a motorbike's screen and handlebars; walls, hedges and people stand on the
#: ground).
SUSPENDED_FLAG = 0b100000
#: Lowest height (m) of the points that give a cluster's near side: above kerbs,
#: sidewalks and the road edge of a cambered road, on a vehicle's flank.
SIDE_HEIGHT = 0.3


def depth_region(depth, edges):
    """Region index (0, 1, 2 for I, II, III) of mean depths, split at ``edges``
    (two depths, or one pair per depth: shape (n, 2)).

    Examples
    --------
    >>> from tunnelsense.street._objects import depth_region
    >>> depth_region([2.5, 5.0, 7.0], (4.0, 6.6)).tolist()
    [0, 1, 2]
    """
    edges = np.asarray(edges, dtype=np.float64)
    if edges.ndim == 1:
        return np.searchsorted(edges, depth, side="right")
    depth = np.asarray(depth, dtype=np.float64)  # one pair of edges per depth
    return (edges[..., 0] <= depth).astype(np.int64) + (edges[..., 1] <= depth)


def near_side(objects, side, n_objects):
    """Median over its intra-clusters of the nearest depth: an object's near side.

    ``side`` is the nearest depth of every intra-cluster's body (+inf: none, e.g. a
    kerb); an object without any is NaN.

    A vehicle's near side (its flank facing the street) stays where it is parked
    whatever its width, whereas its mean depth moves away with the roof and bonnet
    seen from above: a car half up on the sidewalk (near side 6.2-6.6 m) averages
    beyond 6.6 m.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._objects import near_side
    >>> near_side(np.array([0, 0, 0, 1, 2]), np.array([6.3, 6.4, 9.0, 2.0, np.inf]),
    ...           3).tolist()
    [6.4, 2.0, nan]
    """
    known = np.isfinite(side)  # clusters with a body above the kerb
    objects, side = objects[known], side[known]
    order = np.lexsort((side, objects))
    counts = np.bincount(objects, minlength=n_objects)
    starts = np.cumsum(counts) - counts
    if not len(side):
        return np.full(n_objects, np.nan)
    sv, last = side[order], len(side) - 1
    lo = sv[np.minimum(starts + np.maximum(counts - 1, 0) // 2, last)]
    hi = sv[np.minimum(starts + counts // 2, last)]
    return np.where(counts > 0, (lo + hi) / 2, np.nan)


def receding_side(objects, side, n_objects, q=90.0):
    """How far back an object's near side reaches: the ``q``-th percentile over its
    intra-clusters of the nearest depth (NaN: none with a body).

    A vehicle in a bay at an angle turns its flank to the street, and the near
    side of the scans cutting it recedes along that flank towards the kerb; a van
    taller than the sensor shows no roof, so its cross-sections are no deeper than
    that flank, and this is how far into the parking lane it is seen to stand.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._objects import receding_side
    >>> side = np.linspace(3.0, 5.0, 11)
    >>> receding_side(np.zeros(11, dtype=np.int64), side, 2).round(2).tolist()
    [4.8, nan]
    """
    out = np.full(n_objects, np.nan)
    known = np.isfinite(side)
    for o in np.unique(objects[known]):
        out[o] = np.percentile(side[known & (objects == o)], q)
    return out


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
    span : ndarray of shape (n_clusters, 3), default=None
        Nearest and farthest depth of every intra-cluster's body (NaN: none) and
        the depth its occluder stands at (see
        :func:`~tunnelsense.street._clustering.seen_past`); with
        ``flags``, gives every object's first and last scan's extent and whether it
        was seen past an occluder (``start_seen``, ``end_seen``, see :func:`bridged`).
    """

    def __init__(self, objects, position, depth, top, n_points, flags=None, span=None):
        self.position = position
        self.start_seen = self.end_seen = None
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
        if span is not None and flags is not None:
            with np.errstate(invalid="ignore"):
                lo = np.fmin.reduceat(span[order, 0], starts)
                hi = np.fmax.reduceat(span[order, 1], starts)
                occ = np.fmax.reduceat(span[order, 2], starts)
            hidden = (self.scan_flags_ & HIDDEN_FLAG) > 0
            ext = np.column_stack([lo, hi, occ])
            self.start_seen = (ext[first_row], hidden[first_row])
            self.end_seen = (ext[last_row], hidden[last_row])

    def seen(self, a, b):
        """The ``seen`` and ``tops`` arguments of :func:`bridged` for ``a`` ending
        before ``b``."""
        if self.start_seen is None:
            return {}
        return dict(seen=(self.end_seen[0][a], self.end_seen[1][a],
                          self.start_seen[0][b], self.start_seen[1][b]),
                    tops=(self.top[a], self.top[b]))

    def profile(self, o):
        """Scan positions and top heights of object ``o``'s scans."""
        a, b = self.rows[o], self.rows[o + 1]
        return self.scan_position[a:b], self.scan_top[a:b]

    def flags(self, o):
        """Evidence bits of object ``o``'s scans."""
        return self.scan_flags_[self.rows[o]:self.rows[o + 1]]


def _held(seen, link_distance, short):
    """Whether one end's extent holds the other's: seen past an occluder (see
    :func:`~tunnelsense.street._clustering.seen_past`), or across a short gap (the
    ends of one object seen from another side: a motorbike across the kerb, whose
    screen alone shows at its sides)."""
    span = np.array([seen[0][:2], seen[2][:2]])
    one, two = np.array([0]), np.array([1])
    if seen_past(one, two, span, np.array([seen[1], seen[3]]), link_distance,
                 np.array([seen[0][2], seen[2][2]]))[0]:
        return True
    return bool(short and seen_past(one, two, span, np.ones(2, dtype=bool),
                                    link_distance)[0])


def see_through(horizon, step, depth, top, fraction=0.5):
    """Whether every scan of a gap sees through it: beams pass ``depth`` below
    ``fraction`` of ``top`` (the lower top of the two fragments beside the gap).

    A gap between two fragments that the beams see through, below the bodies'
    height, is the space between two vehicles standing close (a motorbike across
    the kerb beside a car), not a stretch of one body that returned nothing
    (dropouts prove nothing: they do not enter the horizon).

    Parameters
    ----------
    horizon : ndarray of shape (n_gap_scans, n_depths)
        The gap scans' rows of :func:`~tunnelsense.street._geometry.horizon`.
    step : float
        Its depth step (m).
    depth : float
        The fragments' depth (m).
    top : float
        The lower of the two fragments' tops (m).
    fraction : float, default=0.5

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._objects import see_through
    >>> h = np.array([[0.0, 0.1, 0.2], [0.0, 0.2, 0.3]])  # the road seen at 2 m
    >>> see_through(h, 1.0, 2.0, 1.2), see_through(h[:, :2] + 1.0, 1.0, 2.0, 1.2)
    (True, False)
    """
    if not len(horizon):
        return False
    j = min(max(int(np.ceil(depth / step)), 1), horizon.shape[1]) - 1
    return bool(np.all(horizon[:, j] < fraction * top))


def bridged(end_depth, start_depth, after, before, cum, near, *, link_distance,
            merge_gap, occlusion_margin, bridge_occluded, alike=True, seen=None,
            horizon=None, step=None, tops=None, bridge_gap=None):
    """The merge rule for a fragment starting after another one ends.

    The first ends before scan ``after``, the second starts at scan ``before``.
    They join when the first's last and the second's first mean depths differ by less
    than ``link_distance`` and the gap between them (``cum[before] - cum[after]``
    metres) is at most ``merge_gap`` (with ``horizon``, unless every scan of the gap
    sees through it, :func:`see_through`: two vehicles standing close), or (``bridge_occluded``, and the two ``alike``:
    both show a body above kerb height or neither does) every scan of the gap shows
    something at least ``occlusion_margin`` nearer.  With ``seen`` (the first's last
    and the second's first scan: ``(span and occluder, hidden)`` each, see
    :func:`~tunnelsense.street._clustering.seen_past`), an end seen only past an
    occluder (or, across a gap of at most ``merge_gap``, either end) may instead
    lie within the other end's depth extent.  With ``horizon``
    (its depth grid ``step``, see :func:`~tunnelsense.street._geometry.horizon`) and
    ``tops`` (the top heights of the two fragments), a gap scan is hidden only where
    no beam passes the fragments' depth below both tops (two roofs with a gap the
    beams see into are two vehicles): behind is not hidden.  A hidden gap longer
    than ``bridge_gap`` metres (a whole vehicle may stand in it) is never bridged.

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
    short = cum[before] - cum[after] <= merge_gap
    if not abs(end_depth - start_depth) < link_distance and not (
            seen is not None and _held(seen, link_distance, short)):
        return False
    if short:  # unless the beams see through the gap: two vehicles standing close
        return not (horizon is not None and tops is not None and before > after
                    and see_through(horizon[after:before], step,
                                    min(end_depth, start_depth), min(tops)))
    if bridge_gap is not None and cum[before] - cum[after] > bridge_gap:
        return False
    depth = min(end_depth, start_depth)
    hidden = near[after:before] < depth - occlusion_margin
    if horizon is not None and tops is not None:
        j = min(max(int(np.ceil(depth / step)), 1), horizon.shape[1]) - 1
        hidden = hidden & (horizon[after:before, j] >= min(tops))
    return bool(bridge_occluded and alike and np.all(hidden))


def merge_fragments(prof, region, cum, near, follows, *, reach, gap_regions=None,
                    blockers=None, **rule):
    """Three-region merging: union-find root of every fragment (object-cluster).

    Fragment ``b`` (later start) joins fragment ``a`` of the same stretch of scans and
    the same region when they overlap in time over at least half of the shorter one
    (the paper's rule), or when ``b`` starts after ``a`` ends and :func:`bridged`
    joins them (``alike`` when both or neither rise above ``SIDE_HEIGHT``);
    fragments starting more than ``reach`` metres apart never join.
    ``rule`` holds the keywords of :func:`bridged`; its ``bridge_gap`` applies in
    the regions where ``gap_regions`` (one bool per region) is True only (those
    of vehicles: a wall or hedge is one object across any hidden gap).

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
    blockers : ndarray of shape (k, 4) of int, default=None
        ``(first, last, region, body)`` of fragments already final: like the
        fragments given, they bar a bridge across them (so that the merge does
        not depend on when a fragment became final).

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
    body = prof.top >= SIDE_HEIGHT  # a kerb or sidewalk is never bridged to a body
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
                # never across another fragment of the region lying in the gap
                between = ((region == region[a]) & (first > last[lo])
                           & (last < first[hi]) & body)
                if blockers is not None and len(blockers):
                    between = concat(between, (
                        (blockers[:, 2] == region[a]) & (blockers[:, 0] > last[lo])
                        & (blockers[:, 1] < first[hi]) & (blockers[:, 3] > 0)))
                gap = dict(rule)
                if gap_regions is not None and not gap_regions[region[a]]:
                    gap["bridge_gap"] = None
                join = not (rule.get("horizon") is not None and between.any()) and (
                    bridged(prof.end_depth[lo], prof.start_depth[hi], last[lo] + 1,
                            first[hi], cum, near, alike=body[a] == body[b],
                            **prof.seen(lo, hi), **gap))
            if join:
                ra, rb = find(a), find(b)
                if ra != rb:
                    parent[max(ra, rb)] = min(ra, rb)
    return np.array([find(i) for i in range(prof.n)], dtype=np.int64)
