"""Intra-scan and inter-scan clustering (paper sections III-D, III-E).

*Intra-scan*: the returns of one scan inside the region of interest are grouped by
single linkage (nearest-neighbour hierarchical clustering) and the tree is cut at
``cut`` (0.6 m).  Cutting a single-linkage tree at ``cut`` gives exactly the connected
components of the graph joining every two points at most ``cut`` apart, which is what
:func:`single_linkage` computes, for many scans at once:

1. points are taken in beam order; consecutive points at most ``cut`` apart are joined
   into *chains* (every chain lies in one component);
2. two chains of the same scan whose bounding boxes come within ``cut`` are compared
   point against point (only the points within ``cut`` of the other chain's box), and
   joined when some pair is at most ``cut`` apart;
3. connected components of the chain graph are the clusters.

Step 2 makes it exact: splitting on gaps between consecutive beams alone (step 1) is
*not* single linkage (two legs, a wall beside a narrow occluder, no-return beams).

*Inter-scan*: an intra-cluster joins the inter-cluster of a cluster of the previous
scan when their mean depths differ by less than ``link_distance`` (0.5 m); an
inter-cluster that finds nothing to link in the next scan is finished (an
*object-cluster*).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "components",
    "concat",
    "expand_ranges",
    "first_appearance",
    "link_pairs",
    "link_scans",
    "seen_past",
    "single_linkage",
]

_CHUNK = 4_000_000  # largest number of point pairs compared at once


def components(n, a, b):
    """Connected components of the graph of ``n`` nodes and edges ``a - b``.

    Hooking and pointer jumping in NumPy: a few passes even for long chains (the
    links of an object-cluster join consecutive scans), without the set-up cost of a
    sparse matrix, which dominates on the small graphs of a stream's decisions.

    Returns
    -------
    labels : ndarray of shape (n,) of int64
        The smallest node of every node's component.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._clustering import components
    >>> components(5, np.array([3, 1]), np.array([4, 3])).tolist()
    [0, 1, 2, 1, 1]
    """
    labels = np.arange(n)
    if len(a) == 0:
        return labels
    while True:
        la, lb = labels[a], labels[b]
        differ = la != lb
        if not differ.any():
            return labels
        la, lb = la[differ], lb[differ]
        low = np.minimum(la, lb)
        np.minimum.at(labels, la, low)  # hook the larger root under the smaller label
        np.minimum.at(labels, lb, low)
        while True:  # pointer jumping: every node to its root
            jumped = labels[labels]
            if np.array_equal(jumped, labels):
                break
            labels = jumped


def concat(*parts):
    """``np.r_`` of 1-d arrays and scalars, without its per-call indexing overhead.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._clustering import concat
    >>> concat(True, np.array([False, True])).tolist()
    [True, False, True]
    """
    return np.concatenate([np.atleast_1d(p) for p in parts])


def expand_ranges(starts, counts):
    """Concatenation of ``arange(s, s + c)`` for every start/count (vectorized).

    Returns
    -------
    index, owner : ndarray of int64
        The concatenated ranges, and which start/count each value comes from.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._clustering import expand_ranges
    >>> [a.tolist() for a in expand_ranges(np.array([5, 0]), np.array([2, 3]))]
    [[5, 6, 0, 1, 2], [0, 0, 1, 1, 1]]
    """
    total = int(counts.sum())
    if total == 0:
        return np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)
    owner = np.repeat(np.arange(len(counts)), counts)
    offs = np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)
    return np.repeat(starts, counts) + offs, owner


def _cross_linked(x, y, a_idx, a_own, b_idx, b_own, n_pairs, cut):
    """For every pair ``p``, whether some point of ``a_idx[a_own == p]`` is within
    ``cut`` of some point of ``b_idx[b_own == p]`` (both sorted by owner)."""
    hit = np.zeros(n_pairs, dtype=bool)
    if len(a_idx) == 0 or len(b_idx) == 0:
        return hit
    b_count = np.bincount(b_own, minlength=n_pairs)
    b_start = np.cumsum(b_count) - b_count
    per_a = b_count[a_own]
    # process the a-points in chunks to bound memory
    cum = np.cumsum(per_a)
    lo = 0
    while lo < len(a_idx):
        done = cum[lo - 1] if lo else 0
        hi = int(np.searchsorted(cum, done + _CHUNK, side="right"))
        hi = max(hi, lo + 1)
        cnt = per_a[lo:hi]
        bi, owner = expand_ranges(b_start[a_own[lo:hi]], cnt)
        ai = a_idx[lo:hi][owner]
        bj = b_idx[bi]
        dx = x[ai] - x[bj]
        dy = y[ai] - y[bj]
        close = np.sqrt(dx * dx + dy * dy) <= cut
        hit[a_own[lo:hi][owner[close]]] = True
        lo = hi
    return hit


def _single_linkage_groups(x, y, group, cut):
    """Single-linkage labels of points grouped in contiguous ``group`` runs.

    Returns labels numbered from 0 within every group, in order of first appearance.
    """
    n = len(x)
    if n == 0:
        return np.empty(0, dtype=np.int64)
    # 1. chains of consecutive points
    dx = np.diff(x)
    dy = np.diff(y)
    link = (np.sqrt(dx * dx + dy * dy) <= cut) & (group[1:] == group[:-1])
    new_chain = concat(True, ~link)
    chain = np.cumsum(new_chain) - 1
    starts = np.flatnonzero(new_chain)
    n_chains = len(starts)
    lengths = np.diff(concat(starts, n))
    xmin = np.minimum.reduceat(x, starts)
    xmax = np.maximum.reduceat(x, starts)
    ymin = np.minimum.reduceat(y, starts)
    ymax = np.maximum.reduceat(y, starts)
    cgroup = group[starts]
    # 2. candidate chain pairs of the same group with boxes within cut
    grp_change = concat(True, cgroup[1:] != cgroup[:-1])
    grp_first = np.flatnonzero(grp_change)
    grp_size = np.diff(concat(grp_first, n_chains))
    grp_end = np.repeat(grp_first + grp_size, grp_size)  # one past the group's last
    partners = grp_end - np.arange(n_chains) - 1
    bi, ai = expand_ranges(np.arange(n_chains) + 1, partners)
    ea = np.empty(0, dtype=np.int64)
    eb = np.empty(0, dtype=np.int64)
    if len(ai):
        margin = cut * (1 + 1e-9)
        gapx = np.maximum(xmin[bi] - xmax[ai], xmin[ai] - xmax[bi])
        gapy = np.maximum(ymin[bi] - ymax[ai], ymin[ai] - ymax[bi])
        keep = (gapx <= margin) & (gapy <= margin)
        ai, bi = ai[keep], bi[keep]
        if len(ai):
            # points of a within cut of b's box, and vice versa
            pa, own_a = expand_ranges(starts[ai], lengths[ai])
            pb, own_b = expand_ranges(starts[bi], lengths[bi])
            ina = (
                (x[pa] >= xmin[bi][own_a] - margin)
                & (x[pa] <= xmax[bi][own_a] + margin)
                & (y[pa] >= ymin[bi][own_a] - margin)
                & (y[pa] <= ymax[bi][own_a] + margin)
            )
            inb = (
                (x[pb] >= xmin[ai][own_b] - margin)
                & (x[pb] <= xmax[ai][own_b] + margin)
                & (y[pb] >= ymin[ai][own_b] - margin)
                & (y[pb] <= ymax[ai][own_b] + margin)
            )
            hit = _cross_linked(
                x, y, pa[ina], own_a[ina], pb[inb], own_b[inb], len(ai), cut
            )
            ea, eb = ai[hit], bi[hit]
    # 3. components of the chain graph, numbered by first appearance within each group
    glob = first_appearance(components(n_chains, ea, eb)[chain])
    pgroup_first = concat(True, group[1:] != group[:-1])
    base = np.maximum.accumulate(np.where(pgroup_first, glob, 0))
    return glob - base


def single_linkage(points, cut=0.6, *, groups=None):
    """Flat single-linkage clusters of 2-D points, the tree cut at ``cut``.

    Equal (up to relabelling) to
    ``scipy.cluster.hierarchy.fcluster(single(points), cut, criterion="distance")``:
    two points share a cluster when a path of steps at most ``cut`` long joins them.
    Fast when the points come in scan (beam) order, exact in any order.

    Parameters
    ----------
    points : array-like of shape (n_points, 2)
        ``(depth, height)`` in metres, finite.
    cut : float, default=0.6
        Cut height of the dendrogram (m); the paper's 600 mm.
    groups : array-like of shape (n_points,) of int, default=None
        Cluster several scans at once: points of different groups are never joined.
        Each group must be contiguous (for example the scan number, non-decreasing).

    Returns
    -------
    labels : ndarray of shape (n_points,) of int64
        Cluster number, from 0 within each group, in order of first appearance.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street import single_linkage
    >>> pts = np.array([[2.0, 0.5], [5.0, 0.5], [2.0, 1.0], [5.3, 1.0], [2.5, 0.2]])
    >>> single_linkage(pts, 0.6).tolist()
    [0, 1, 0, 1, 0]
    """
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise ValueError(f"points must have shape (n_points, 2); got shape {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise ValueError("points must be finite (drop no-return beams first)")
    if not (np.isfinite(cut) and cut >= 0):
        raise ValueError(f"cut must be a finite number >= 0; got {cut!r}")
    if groups is None:
        g = np.zeros(len(pts), dtype=np.int64)
    else:
        g = np.asarray(groups)
        if g.shape != (len(pts),):
            raise ValueError(
                f"groups must have shape ({len(pts)},) like points; got {g.shape}"
            )
        change = concat(True, g[1:] != g[:-1]) if len(g) else np.empty(0, bool)
        if len(np.unique(g)) != int(change.sum()):
            raise ValueError("groups must be contiguous (each group in one run)")
        g = np.cumsum(change) - 1
    return _single_linkage_groups(pts[:, 0].copy(), pts[:, 1].copy(), g, float(cut))


def seen_past(earlier, later, span, hidden, link_distance, occluder=None):
    """Whether a cluster seen only past a nearer occluder belongs with its neighbour.

    A beam that ends on a nearer object says nothing about what lies behind it: a
    cluster whose lower part is hidden (``hidden``: the beam just below it returned
    from something nearer) shows only the part of its object that the beams passing
    over the occluder reach, so its mean depth is biased away from the sensor.  It
    links with a cluster of the neighbouring scan when every point of it lies within
    that cluster's depth extent, widened by ``link_distance``: the beams reaching it
    end where the other scan sees a body.

    Parameters
    ----------
    earlier, later : ndarray of int
        Candidate pairs of clusters of consecutive scans.
    span : ndarray of shape (n_clusters, 2)
        Nearest and farthest depth (m) of every cluster's body (its points above
        kerb height; NaN where it has none: a kerb or the sidewalk never links so).
    hidden : ndarray of shape (n_clusters,) of bool
        Whether the cluster's lower part is hidden.
    link_distance : float
        The inter-scan link distance (m).
    occluder : ndarray of shape (n_clusters,), default=None
        Depth (m) at which the beam just below every cluster ends; when given, the
        occluder must stand ``link_distance`` nearer than the other cluster's near
        side (something behind a vehicle, hidden by that very vehicle, is not
        part of it).

    Returns
    -------
    link : ndarray of bool, one per pair

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._clustering import seen_past
    >>> # a bonnet seen past a passing car (at 2 m), the whole parked car in the next
    >>> # scan, and a hedge top seen over that parked car (hidden by it, at 5 m)
    >>> span = np.array([[5.1, 6.1], [4.4, 6.2], [6.3, 6.6]])
    >>> hidden = np.array([True, False, True])
    >>> occluder = np.array([2.0, np.nan, 5.0])
    >>> seen_past(np.array([0, 2]), np.array([1, 1]), span, hidden, 0.5,
    ...           occluder).tolist()
    [True, False]
    """
    a, b = span[earlier], span[later]
    with np.errstate(invalid="ignore"):
        a_in_b = (a[:, 0] >= b[:, 0] - link_distance) & (a[:, 1] <= b[:, 1] + link_distance)
        b_in_a = (b[:, 0] >= a[:, 0] - link_distance) & (b[:, 1] <= a[:, 1] + link_distance)
        if occluder is not None:
            a_in_b &= occluder[earlier] < b[:, 0] - link_distance
            b_in_a &= occluder[later] < a[:, 0] - link_distance
    return (hidden[earlier] & a_in_b) | (hidden[later] & b_in_a)


def end_of(earlier, later, span, top, tolerance, suspended=None):
    """Whether one cluster of a pair is an end of the other's object.

    The scans past an object's end see only its widest part: the screen and
    handlebars of a motorbike parked across the kerb, a mirror.  Such a cluster is
    narrow, its body lies within the other's depth extent (widened by
    ``tolerance``) and its top is the other's (within ``tolerance``): the beams
    reach the same highest part of one object from both scans.  Its mean depth,
    though, says little (the rest of the object is missing), and beside the
    footway it would link with the footway instead.

    Parameters
    ----------
    earlier, later : ndarray of int
        Candidate pairs of clusters of consecutive scans.
    span : ndarray of shape (n_clusters, 2)
        Nearest and farthest depth (m) of every cluster's body (NaN: none).
    top : ndarray of shape (n_clusters,)
        Highest point (m) of every cluster.
    tolerance : float or ndarray of shape (n_clusters,)
        Depth and height tolerance (m), per cluster or one for all (the depth
        and height resolution of the beams at the cluster).
    suspended : ndarray of shape (n_clusters,) of bool, default=None
        Whether every cluster hangs in the air (its lowest point above the
        ground, the beam below it passing farther); when given, only such a
        cluster is an end (a wall or hedge standing on the ground, narrower than
        a car joined to it, is not the car's end).

    Returns
    -------
    link : ndarray of bool, one per pair

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._clustering import end_of
    >>> # the screen alone (6.64-6.72 m, 1.27 m high) past a motorbike's body
    >>> # (5.8-6.7 m, 1.27 m high); a hedge top behind it (7.0-7.3 m, 1.5 m)
    >>> span = np.array([[6.64, 6.72], [5.8, 6.7], [7.0, 7.3]])
    >>> top = np.array([1.27, 1.27, 1.5])
    >>> end_of(np.array([0, 2]), np.array([1, 1]), span, top, 0.1).tolist()
    [True, False]
    """
    tol = np.broadcast_to(np.asarray(tolerance, float), top.shape)
    a, b = span[earlier], span[later]
    ta, tb = top[earlier], top[later]
    t = np.maximum(tol[earlier], tol[later])
    with np.errstate(invalid="ignore"):
        wa, wb = a[:, 1] - a[:, 0], b[:, 1] - b[:, 0]
        same_top = np.abs(ta - tb) <= t
        a_in_b = (wa < wb) & (a[:, 0] >= b[:, 0] - t) & (a[:, 1] <= b[:, 1] + t)
        b_in_a = (wb < wa) & (b[:, 0] >= a[:, 0] - t) & (b[:, 1] <= a[:, 1] + t)
    if suspended is not None:
        a_in_b &= suspended[earlier]
        b_in_a &= suspended[later]
    return same_top & (a_in_b | b_in_a)


def link_pairs(position, mean_depth, follows, link_distance=0.5, *, span=None,
               hidden=None, occluder=None, top=None, ground_height=None,
               end_tolerance=None, suspended=None):
    """Inter-scan links: the pairs of intra-clusters of consecutive scans that link.

    Parameters are those of :func:`link_scans`; ``position`` must be non-decreasing.
    With ``span`` and ``hidden`` (see :func:`seen_past`), a cluster seen only past
    a nearer occluder also links with the cluster of the neighbouring scan whose
    depth extent holds it.

    With ``top`` (height of every cluster's highest point) and ``ground_height``
    (beyond the paper), a cluster lying wholly below ``ground_height`` (a kerb, the
    footway: a surface near road level) never links with one that rises above it,
    so the footway does not carry a vehicle standing on it into what stands behind.

    Returns
    -------
    earlier, later : ndarray of shape (n_links,) of int64
        Indices of the linked clusters, ``earlier`` in the scan before ``later``'s.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._clustering import link_pairs
    >>> link_pairs(np.array([0, 0, 1]), np.array([2.0, 5.0, 5.3]),
    ...            np.array([False, True]))
    (array([1]), array([2]))
    """
    pos = np.asarray(position, dtype=np.int64)
    depth = np.asarray(mean_depth, dtype=np.float64)
    n_positions = len(follows)
    count = np.bincount(pos, minlength=n_positions)
    start = np.cumsum(count) - count
    prev_count = concat(0, count[:-1])
    prev_start = concat(0, start[:-1])
    # every cluster against all clusters of the previous scan, if it follows
    n_prev = np.where(np.asarray(follows, dtype=bool), prev_count, 0)[pos]
    earlier, later = expand_ranges(prev_start[pos], n_prev)
    close = np.abs(depth[earlier] - depth[later]) < link_distance
    if span is not None and hidden is not None:
        close |= seen_past(earlier, later, span, hidden, link_distance, occluder)
    if span is not None and top is not None and end_tolerance is not None:
        close |= end_of(earlier, later, span, np.asarray(top, float), end_tolerance,
                        suspended)
    if top is not None and ground_height is not None:
        ground = np.asarray(top, float) < ground_height
        close &= ground[earlier] == ground[later]
    return earlier[close], later[close]


def link_scans(position, mean_depth, follows, link_distance=0.5):
    """Inter-scan clustering: object-cluster number of every intra-cluster.

    Parameters
    ----------
    position : ndarray of shape (n_clusters,) of int
        Index of each intra-cluster's scan in the scan order (non-decreasing).
    mean_depth : ndarray of shape (n_clusters,)
        Mean depth (m) of each intra-cluster.
    follows : ndarray of shape (n_positions,) of bool
        ``follows[p]`` is True when scan ``p`` follows scan ``p - 1`` in the same
        run, directly or across a stretch of missing scans the detector links over
        (``max_missing_length``); linking never crosses a False.
    link_distance : float, default=0.5
        Clusters of consecutive scans link when their mean depths differ by less.

    Returns
    -------
    objects : ndarray of shape (n_clusters,) of int64
        Object-cluster number, from 0, in order of first appearance.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street import link_scans
    >>> link_scans(np.array([0, 0, 1, 2, 3]), np.array([2.0, 5.0, 5.3, 5.6, 5.9]),
    ...            np.array([False, True, True, False])).tolist()
    [0, 1, 1, 1, 2]
    """
    pos = np.asarray(position, dtype=np.int64)
    if len(pos) == 0:
        return np.empty(0, dtype=np.int64)
    if np.any(np.diff(pos) < 0):
        raise ValueError("position must be non-decreasing (clusters in scan order)")
    labels = components(len(pos), *link_pairs(pos, mean_depth, follows, link_distance))
    return first_appearance(labels)


def first_appearance(labels):
    """Renumber labels from 0 in order of first appearance.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._clustering import first_appearance
    >>> first_appearance(np.array([7, 2, 7, 5])).tolist()
    [0, 1, 0, 2]
    """
    _, first, inverse = np.unique(labels, return_index=True, return_inverse=True)
    renumber = np.empty(len(first), dtype=np.int64)
    renumber[np.argsort(first)] = np.arange(len(first))
    return renumber[inverse.ravel()]
