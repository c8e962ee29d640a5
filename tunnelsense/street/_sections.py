"""What one scan shows of an object: the cross-section evidence of a vehicle body.

The scan plane cuts every object across the street.  What a vertical scanner mounted
above the traffic sees of that cut differs between vehicles and the other things at
the kerb (beyond the paper, see ``docs/street.md``):

* **roof**: a car (or the bonnet and boot of a van) is lower than the sensor and
  1.5-1.9 m wide, so the beams reach over its near side onto a horizontal top surface
  that spans most of its width in depth.  Pedestrians (heads 0.2 m, shoulders
  0.45 m), bins (0.6 m), bollards and posts (0.15 m) have no top that wide.
* **wall**: a van, lorry or bus is taller than the region of interest: its near face
  continues above ``max_height`` (the beam just above the cluster's highest beam hits
  the same surface, within ``cut`` in depth, above ``max_height``).  Nothing at the
  kerb that a pedestrian-sized object explains continues above 2 m.
* **raised**: a motorbike or a car stands on wheels; between them its body hangs
  above the road: the cluster's lowest point is at least ``min_clearance`` above the
  road and the beam just below it passes under the body (it returns from farther
  away, the road beneath); or a beam just below any point of the cluster at least
  ``min_clearance`` high reaches the road (below ``min_clearance``) beyond it (a
  motorbike whose cluster also holds the kerb behind it).  Pedestrians, bins and
  bollards stand on the ground; a
  cluster whose lower part is hidden by something nearer is not raised (the beam
  below returns from nearer).
"""

from __future__ import annotations

import numpy as np

__all__ = ["lowest_marks", "passed_under", "section_evidence"]

#: How much farther (m) the beam below a raised body must return than the body.
_UNDER_MARGIN = 0.1


def section_evidence(depth, height, cluster, beam, above, below, *, n_clusters=None,
                     roof_band=0.15, roof_width=0.8, max_height=2.0, cut=0.6,
                     min_clearance=0.2, min_roof_height=0.0):
    """Per intra-cluster: does it show a vehicle's roof, wall or raised body?

    Parameters
    ----------
    depth, height : ndarray of shape (n_points,)
        Region-of-interest points (m).
    cluster : ndarray of shape (n_points,) of int
        Intra-cluster number (0 ... n_clusters - 1) of every point, numbered over all
        scans (clusters never span two scans).
    beam : ndarray of shape (n_points,) of int
        Beam number of every point (beams fan from the bottom up).
    above, below : ndarray of shape (n_points, 2)
        ``(depth, height)`` of the return of the next beam up and down in the same
        scan (NaN where that beam has no return or does not exist).
    n_clusters : int, default=None
        Number of clusters; ``cluster.max() + 1`` when None.
    roof_band : float, default=0.15
        Points within this height (m) below a cluster's top make its top surface.
    roof_width : float, default=0.8
        Smallest depth extent (m) of a top surface that counts as a roof.
    min_roof_height : float, default=0.0
        Lowest top (m) of a roof: a kerb and the sidewalk behind it (0.1-0.3 m) are
        flat and wide, but no vehicle's bonnet or roof is that low.
    max_height : float, default=2.0
        Ceiling of the region of interest (m).
    cut : float, default=0.6
        Largest depth step (m) between the highest point and the return above it for
        the surface to continue above the ceiling (the single-linkage cut).
    min_clearance : float, default=0.2
        Lowest bottom (m above the road) of a raised body.

    Returns
    -------
    roof, wall, raised, hidden : ndarray of shape (n_clusters,) of bool
        ``hidden``: the beam just below the cluster returned from something nearer
        (the lower part is hidden; whether the body is raised is unknown).

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street import section_evidence
    >>> # a car roof 1.4 m wide seen from above, and a pedestrian standing on the road
    >>> d = np.array([4.6, 4.6, 4.7, 5.2, 5.8, 6.0, 6.0, 6.05])
    >>> h = np.array([0.3, 0.9, 1.45, 1.5, 1.5, 0.12, 1.0, 1.75])
    >>> c = np.array([0, 0, 0, 0, 0, 1, 1, 1])
    >>> b = np.array([10, 14, 18, 19, 20, 30, 34, 38])
    >>> nan = np.full((8, 2), np.nan)
    >>> below = nan.copy(); below[0] = (5.5, 0.0); below[5] = (5.9, 0.05)
    >>> roof, wall, raised, hidden = section_evidence(d, h, c, b, nan, below)
    >>> roof.tolist(), wall.tolist(), raised.tolist(), hidden.tolist()
    ([True, False], [False, False], [True, False], [False, False])
    """
    depth = np.asarray(depth, dtype=np.float64)
    height = np.asarray(height, dtype=np.float64)
    cluster = np.asarray(cluster, dtype=np.int64)
    beam = np.asarray(beam, dtype=np.int64)
    k = int(cluster.max()) + 1 if n_clusters is None and len(cluster) else (
        int(n_clusters or 0))
    if k == 0:
        e = np.zeros(0, dtype=bool)
        return e, e.copy(), e.copy(), e.copy()
    idx = np.arange(len(cluster))
    # roof: depth extent of the points near the top
    top = np.full(k, -np.inf)
    np.maximum.at(top, cluster, height)
    sel = height >= top[cluster] - roof_band
    lo = np.full(k, np.inf)
    hi = np.full(k, -np.inf)
    np.minimum.at(lo, cluster[sel], depth[sel])
    np.maximum.at(hi, cluster[sel], depth[sel])
    roof = ((hi - lo) >= roof_width) & (top >= min_roof_height)
    # the highest and lowest beams of every cluster
    key = cluster * (int(beam.max()) + 2) + beam
    first = np.full(k, len(idx))
    last = np.full(k, -1)
    order = np.argsort(key, kind="stable")
    cs = cluster[order]
    starts = np.r_[True, cs[1:] != cs[:-1]]
    ends = np.r_[cs[1:] != cs[:-1], True]
    first[cs[starts]] = order[starts]
    last[cs[ends]] = order[ends]
    has = last >= 0
    wall = np.zeros(k, dtype=bool)
    raised = np.zeros(k, dtype=bool)
    hidden = np.zeros(k, dtype=bool)
    t, b = last[has], first[has]
    above = np.asarray(above, dtype=np.float64)
    below = np.asarray(below, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        wall[has] = (above[t, 1] >= max_height) & (np.abs(above[t, 0] - depth[t]) <= cut)
        # a beam under the body reaches the road beyond it: under the lowest point,
        # or under any point (a motorbike beside a kerb that joins its cluster)
        raised[has] = (height[b] >= min_clearance) & (
            below[b, 0] > depth[b] + _UNDER_MARGIN)
        under = ((height >= min_clearance) & (below[:, 0] > depth + _UNDER_MARGIN)
                 & (below[:, 1] < min_clearance))
        hidden[has] = below[b, 0] < depth[b] - _UNDER_MARGIN
    np.logical_or.at(raised, cluster[under], True)
    return roof, wall, raised, hidden


def passed_under(height, cluster, below_passes, *, n_clusters, min_clearance=0.2):
    """Per intra-cluster: does a beam pass under it, returning nothing within range?

    A beam just below a cluster's lowest point, at least ``min_clearance`` high,
    that returns nothing within range (it passed everything; a dropout is not that)
    shows the space under the cluster empty as far as the sensor reaches (under a
    person's body, between the legs, the lowest point is a foot on the ground): seen from the road, a motorbike
    across the kerb, its screen and body over the gap between its wheels.  This is
    weaker evidence than a raised body (the beam may pass under an overhang, or over
    a car's bonnet at the edge of a roof), so the detector counts it only for an
    object too short for anything but a motorbike across the kerb, seen whole.

    Parameters
    ----------
    height : ndarray of shape (n_points,)
        Region-of-interest heights (m).
    cluster : ndarray of shape (n_points,) of int
        Intra-cluster number of every point.
    below_passes : ndarray of shape (n_points,) of bool
        Whether the next beam down returned nothing within range.
    n_clusters : int
    min_clearance : float, default=0.2

    Returns
    -------
    passed : ndarray of shape (n_clusters,) of bool

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street import passed_under
    >>> passed_under(np.array([0.8, 1.1, 0.05, 0.5]), np.array([0, 0, 1, 1]),
    ...              np.array([True, False, False, True]), n_clusters=2).tolist()
    [True, False]
    """
    height = np.asarray(height, dtype=np.float64)
    cluster = np.asarray(cluster, dtype=np.int64)
    passed = np.zeros(int(n_clusters), dtype=bool)
    if not len(cluster):
        return passed
    lowest = np.lexsort((height, cluster))  # by cluster, then height
    lowest = lowest[np.r_[True, cluster[lowest][1:] != cluster[lowest][:-1]]]
    passes = np.asarray(below_passes, dtype=bool)[lowest]
    passed[cluster[lowest]] = passes & (height[lowest] >= min_clearance)
    return passed


def lowest_marks(points, beams, scan, under, section, n_scans, min_clearance,
                 tolerance):
    """Per scan, what the beam below a cross-section's lowest point shows.

    The many-scan form of :func:`~tunnelsense.street._carving.raised_section`
    (with ``absent=True``) and :func:`~tunnelsense.street._carving.under_gap`: in
    every scan the section's lowest point is its point of smallest beam number
    (the first of them).  ``raised``: that point stands at least
    ``min_clearance`` high and the first point of the next beam down in the region
    of interest lies more than ``tolerance`` farther, or there is none.  ``gap``:
    where the next beam down ends (``under``) lies more than ``tolerance`` farther
    *and* lower than that point.  A scan without section points is neither.

    Parameters
    ----------
    points : ndarray of shape (n, 2)
        ``(depth, height)`` of the scans' region-of-interest points, scan after scan,
        each scan's in beam order.
    beams : ndarray of shape (n,) of int
        Their beam numbers.
    scan : ndarray of shape (n,) of int
        Their scans (``0 .. n_scans - 1``, non-decreasing).
    under : ndarray of shape (n, 2)
        ``(depth, height)`` where the next beam down from every point ends (NaN:
        no return).
    section : ndarray of shape (n,) of bool
        Which points belong to the cross-section.
    n_scans : int
    min_clearance, tolerance : float

    Returns
    -------
    raised, gap : ndarray of shape (n_scans,) of bool

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._sections import lowest_marks
    >>> pts = np.array([[5.0, 0.15], [5.0, 0.2], [6.1, 0.5], [7.3, 1.4]])
    >>> under = np.array([[5.4, 0.0], [5.0, 0.15], [7.3, 0.1], [6.1, 0.5]])
    >>> raised, gap = lowest_marks(pts, np.array([0, 1, 0, 1]), np.array([0, 0, 1, 1]),
    ...                            under, np.array([1, 1, 1, 0], bool), 2, 0.2, 0.1)
    >>> raised.tolist(), gap.tolist()
    ([False, True], [True, True])
    """
    points = np.asarray(points, dtype=float)
    beams = np.asarray(beams, dtype=np.int64)
    scan = np.asarray(scan, dtype=np.int64)
    raised = np.zeros(n_scans, dtype=bool)
    gap = np.zeros(n_scans, dtype=bool)
    idx = np.flatnonzero(section)
    if not len(idx):
        return raised, gap
    # the first point of smallest beam number in every scan's section
    order = idx[np.lexsort((idx, beams[idx], scan[idx]))]
    low = order[np.r_[True, scan[order[1:]] != scan[order[:-1]]]]
    s = scan[low]
    with np.errstate(invalid="ignore"):
        gap[s] = ((under[low, 0] > points[low, 0] + tolerance)
                  & (under[low, 1] < points[low, 1] - tolerance))
    # the first point of the next beam down in the same scan (any point)
    span = int(beams.max() - min(int(beams.min()), 0)) + 2
    key = scan * span + (beams - min(int(beams.min()), 0) + 1)
    by_key = np.argsort(key, kind="stable")
    want = scan[low] * span + (beams[low] - min(int(beams.min()), 0))
    at = np.searchsorted(key[by_key], want)
    found = at < len(key)
    found[found] = key[by_key[at[found]]] == want[found]
    below = by_key[np.minimum(at, len(key) - 1)]
    high = points[low, 1] >= min_clearance
    raised[s] = high & (~found | (points[below, 0] > points[low, 0] + tolerance))
    return raised, gap
