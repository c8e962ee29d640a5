"""A vehicle standing against a taller structure: carved out of the structure's object.

A motorbike parked at right angles to the kerb whose far end touches a hedge or a
wall taller than itself shares one intra-cluster with that structure in every scan
(single linkage joins the screen to the hedge face), so the structure's object swallows
it.  Seen along the street, though, the structure keeps one near face, and over a
short stretch something stands in front of it: the object's near side comes nearer by
more than the inter-scan link distance in a few consecutive scans, with the face seen
again on both sides.  Those scans' points nearer than the face (less one beam
resolution) are the vehicle's cross-section; it is tested as a motorbike (its top
reaching the handlebars, a body raised between its wheels) before it counts.

The functions here are array in, array out; :class:`~tunnelsense.street.ScanClusterer`
calls them on every final object that is not itself a parked vehicle.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "flat_face",
    "long_runs",
    "protrusions",
    "raised_section",
    "scan_near_side",
    "under_gap",
    "widen",
]


def scan_near_side(scan, side, first, last):
    """The near side (m) of an object in every scan ``first .. last``.

    Parameters
    ----------
    scan : ndarray of shape (n_clusters,) of int
        Scan position of every intra-cluster of the object.
    side : ndarray of shape (n_clusters,)
        Nearest depth of every intra-cluster's body (+inf: none).
    first, last : int
        The object's first and last scan positions.

    Returns
    -------
    near : ndarray of shape (last - first + 1,)
        The nearest body depth per scan; NaN where the object shows no body.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._carving import scan_near_side
    >>> scan_near_side(np.array([3, 3, 5]), np.array([7.2, 6.0, np.inf]), 3, 5).tolist()
    [6.0, nan, nan]
    """
    near = np.full(last - first + 1, np.inf)
    np.minimum.at(near, np.asarray(scan) - first, np.asarray(side, dtype=float))
    near[~np.isfinite(near)] = np.nan
    return near


def protrusions(near, margin, length, max_length, *, ends=False, quantile=50.0):
    """Short runs of scans where something stands in front of an object's face.

    The face is the median near side over the object's scans (``quantile``: that
    percentile instead).  A run of consecutive
    scans whose near side is more than ``margin`` nearer than the face, with the
    face seen on both sides of the run (the scans just before and after it show a
    body no nearer than ``face - margin``; ``ends``: on one side at least, the run
    may reach the object's first or last scan), and shorter than ``max_length`` along
    the street, is a protrusion: a vehicle standing against the structure.

    Parameters
    ----------
    near : ndarray of shape (n_scans,)
        Near side (m) of the object per scan (:func:`scan_near_side`; NaN: no body).
    margin : float
        How much nearer (m) than the face counts as in front of it.
    length : ndarray of shape (n_scans + 1,)
        Metres along the street at the start of every scan (and past the last).
    max_length : float
        Longest protrusion (m).
    ends : bool, default=False
        Whether a run may reach the object's ends (the face seen on one side).
    quantile : float, default=50.0
        Percentile of the near sides that gives the face.

    Returns
    -------
    face : float
        The face's depth (m; NaN when the object shows no body).
    runs : list of (int, int)
        First and last index (into ``near``) of every protrusion.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._carving import protrusions
    >>> near = np.array([7.2, 7.3, 7.1, 5.6, 5.8, 7.2, 7.3, 7.2, 5.0])
    >>> face, runs = protrusions(near, 0.5, 0.14 * np.arange(10), 2.4)
    >>> float(face), runs
    (7.2, [(3, 4)])
    """
    near = np.asarray(near, dtype=float)
    if not np.isfinite(near).any():
        return np.nan, []
    face = float(np.nanpercentile(near, quantile))
    with np.errstate(invalid="ignore"):
        front = near < face - margin
        at_face = near >= face - margin
    runs = []
    start = None
    for i, f in enumerate(np.append(front, False)):
        if f and start is None:
            start = i
        elif not f and start is not None:
            a, b = start, i - 1
            start = None
            before = at_face[a - 1] if a > 0 else ends
            after = at_face[b + 1] if b + 1 < len(near) else ends
            inside = before and after and (a > 0 or b + 1 < len(near))
            if inside and length[b + 1] - length[a] < max_length:
                runs.append((a, b))
    return face, runs


def raised_section(points, beams, section, min_clearance, tolerance, *, absent=False):
    """Whether a cross-section is raised between wheels in one scan.

    The lowest beam of the section ends at least ``min_clearance`` above the road
    and the beam just below it returns from farther away (more than
    ``tolerance``): it passed under the body, to the ground or the structure behind.
    Wheelie bins, posts and people stand on the ground.

    Parameters
    ----------
    points : ndarray of shape (n, 2)
        ``(depth, height)`` of the scan's region-of-interest points, in beam order.
    beams : ndarray of shape (n,) of int
        Their beam numbers.
    section : ndarray of shape (n,) of bool
        Which points belong to the cross-section.
    min_clearance, tolerance : float
    absent : bool, default=False
        What a beam below that left no point in the region of interest (it reached
        the road under the body, below the region) says: raised (True) or not.

    Returns
    -------
    raised : bool

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._carving import raised_section
    >>> pts = np.array([[7.2, 0.15], [6.1, 0.5], [6.1, 0.6], [7.3, 1.4]])
    >>> raised_section(pts, np.arange(4), np.array([0, 1, 1, 0], bool), 0.2, 0.1)
    True
    >>> raised_section(pts[1:], np.arange(1, 4), np.array([1, 1, 0], bool), 0.2, 0.1,
    ...                absent=True)
    True
    """
    idx = np.flatnonzero(section)
    if not len(idx):
        return False
    low = idx[np.argmin(beams[idx])]
    if points[low, 1] < min_clearance:
        return False
    below = np.flatnonzero(beams == beams[low] - 1)
    if not len(below):
        return bool(absent)
    return bool(points[below[0], 0] > points[low, 0] + tolerance)


def under_gap(points, beams, under, section, tolerance):
    """Whether the beam just below a cross-section passes under it to the ground.

    The beam next below the section's lowest point returns more than
    ``tolerance`` farther *and* more than ``tolerance`` lower than that point: it
    went through the space under the body (a car's ground clearance) and fell to
    the road or footway beyond the body's near side.  On a face standing on the
    ground (a wall, a hedge) the next beam down ends on the same face, one beam
    spacing lower, or on the ground in front of it; beams reaching into foliage
    end a little farther but not lower.  Unlike :func:`raised_section` no
    clearance in metres is set, but the beam must land more than ``tolerance``
    below the lowest point: the clearance must exceed about ``tolerance`` (two
    beam spacings at the face's depth: about 0.11 m at 0.5 deg and 6.5 m, 0.23 m
    at 1 deg).

    Parameters
    ----------
    points : ndarray of shape (n, 2)
        ``(depth, height)`` of the scan's region-of-interest points, in beam order.
    beams : ndarray of shape (n,) of int
        Their beam numbers.
    under : ndarray of shape (n, 2)
        ``(depth, height)`` where the next beam down from every point ends (NaN:
        no return; it may lie outside the region of interest).
    section : ndarray of shape (n,) of bool
        Which points belong to the cross-section.
    tolerance : float
        Depth and height resolution (m) of the beams there (two beam spacings).

    Returns
    -------
    gap : bool

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._carving import under_gap
    >>> # a car's sill 0.15 m high at 5.0 m; the next beam reaches the road at 5.4 m
    >>> pts = np.array([[5.0, 0.15], [5.0, 0.2], [5.0, 0.25]])
    >>> under_gap(pts, np.arange(3), np.array([[5.4, 0.0], [5.0, 0.15],
    ...           [5.0, 0.2]]), np.ones(3, bool), 0.1)
    True
    >>> # a hedge's foot: the next beam ends in its foliage, farther but not lower
    >>> under_gap(pts, np.arange(3), np.array([[5.25, 0.1], [5.0, 0.15],
    ...           [5.0, 0.2]]), np.ones(3, bool), 0.1)
    False
    """
    idx = np.flatnonzero(section)
    if not len(idx):
        return False
    low = idx[np.argmin(beams[idx])]
    below = under[low]
    with np.errstate(invalid="ignore"):
        return bool((below[0] > points[low, 0] + tolerance)
                    & (below[1] < points[low, 1] - tolerance))


def long_runs(mask, metres, min_length, min_count=1):
    """``mask`` kept only in runs of consecutive True at least ``min_length`` long
    and of at least ``min_count`` scans.

    Parameters
    ----------
    mask : ndarray of shape (n,) of bool
        Per scan, whether it shows the mark (consecutive entries are consecutive
        scans).
    metres : ndarray of shape (n,)
        Length (m) along the street of every scan.
    min_length : float
        Shortest run kept (m along the street: the sum of its scans' ``metres``).
    min_count : int, default=1
        Fewest scans in a run kept, whatever their lengths.

    Returns
    -------
    kept : ndarray of shape (n,) of bool

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._carving import long_runs
    >>> long_runs(np.array([1, 0, 1, 1, 1, 0], bool), np.full(6, 0.2), 0.5).tolist()
    [False, False, True, True, True, False]
    >>> long_runs(np.array([1, 1, 0, 1, 1, 1], bool), np.full(6, 0.45), 0.5,
    ...           min_count=3).tolist()
    [False, False, False, True, True, True]
    """
    mask = np.asarray(mask, dtype=bool)
    out = np.zeros(len(mask), dtype=bool)
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1),
                    strict=True):
        if b - a >= min_count and float(np.sum(metres[a:b])) >= min_length:
            out[a:b] = True
    return out


def widen(near, a, b, depth, length, gap):
    """A protrusion's ends: the scans next to run ``a .. b`` still nearer than
    ``depth`` (past a narrow object's end a scan sees its widest part alone, the
    screen and handlebars), at most ``gap`` metres each way.

    Parameters
    ----------
    near : ndarray of shape (n_scans,)
        Near side (m) per scan (NaN: no body).
    a, b : int
        The run (indices into ``near``).
    depth : float
        The face's depth less the beam resolution (m).
    length : ndarray of shape (n_scans + 1,)
        Metres along the street at the start of every scan.
    gap : float
        Longest widening (m) on each side.

    Returns
    -------
    a, b : int

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._carving import widen
    >>> near = np.array([7.2, 6.9, 6.0, 5.6, 6.95, 6.9, 6.9, 7.2])
    >>> widen(near, 2, 3, 7.0, 0.14 * np.arange(9), 0.3)
    (1, 5)
    """
    lo, hi = a, b
    with np.errstate(invalid="ignore"):
        while lo > 0 and near[lo - 1] < depth and length[a] - length[lo - 1] <= gap:
            lo -= 1
        while (hi + 1 < len(near) and near[hi + 1] < depth
               and length[hi + 2] - length[b + 1] <= gap):
            hi += 1
    return lo, hi


def flat_face(near, flags, face, runs, margin, lengths, evidence, max_share):
    """Whether an object's face, outside the runs in front of it, is a flat
    vertical surface: a wall, a fence or a facade rather than a vehicle.

    A vehicle shows a roof or a body raised between its wheels along its length;
    a wall behind a parked car is a vertical face down to the footway wherever it
    is seen.  The face is flat when the share of its length (its scans no nearer
    than ``face`` less ``margin``, outside ``runs``) whose
    flags hold any bit of ``evidence`` is below ``max_share``.

    Parameters
    ----------
    near : ndarray of shape (n_scans,)
        Near side (m) per scan (:func:`scan_near_side`; NaN: no body).
    flags : ndarray of shape (n_scans,) of int
        Evidence bits of every scan (the OR of its clusters' flags).
    face : float
        The face's depth (m, :func:`protrusions`).
    runs : list of (int, int)
        Runs in front of the face (:func:`protrusions`), left out.
    margin : float
        How much nearer (m) than the face counts as in front of it.
    lengths : ndarray of shape (n_scans,)
        Metres along the street of every scan.
    evidence : int
        Bits of a vehicle body (roof, raised).
    max_share : float
        Largest share of the face's length showing them.

    Returns
    -------
    flat : bool

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._carving import flat_face
    >>> near = np.array([6.6, 6.6, 4.5, 4.5, 6.6, 6.6])
    >>> flags = np.array([2, 2, 5, 5, 2, 2])
    >>> flat_face(near, flags, 6.6, [(2, 3)], 0.5, np.full(6, 0.15), 5, 0.2)
    True
    >>> flat_face(near, np.full(6, 5), 6.6, [(2, 3)], 0.5, np.full(6, 0.15), 5, 0.2)
    False
    """
    near = np.asarray(near, dtype=float)
    if not np.isfinite(face):
        return False
    with np.errstate(invalid="ignore"):
        at_face = near >= face - margin
    for a, b in runs:
        at_face[a:b + 1] = False
    lengths = np.asarray(lengths, dtype=float)
    if not at_face.any():
        return False
    total = float(lengths[at_face].sum())
    shown = (np.asarray(flags)[at_face] & evidence) > 0
    share = (float(lengths[at_face][shown].sum()) / total if total > 0
             else float(np.mean(shown)))
    return share < max_share
