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

__all__ = ["protrusions", "raised_section", "scan_near_side", "widen"]


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


def protrusions(near, margin, length, max_length):
    """Short runs of scans where something stands in front of an object's face.

    The face is the median near side over the object's scans.  A run of consecutive
    scans whose near side is more than ``margin`` nearer than the face, with the
    face seen on both sides of the run (the scans just before and after it show a
    body no nearer than ``face - margin``), and shorter than ``max_length`` along
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
    face = float(np.nanmedian(near))
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
            inside = a > 0 and b + 1 < len(near) and at_face[a - 1] and at_face[b + 1]
            if inside and length[b + 1] - length[a] < max_length:
                runs.append((a, b))
    return face, runs


def raised_section(points, beams, section, min_clearance, tolerance):
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
    """
    idx = np.flatnonzero(section)
    if not len(idx):
        return False
    low = idx[np.argmin(beams[idx])]
    if points[low, 1] < min_clearance:
        return False
    below = np.flatnonzero(beams == beams[low] - 1)
    return bool(len(below) and points[below[0], 0] > points[low, 0] + tolerance)


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
