"""Vehicle classes from an object's cross-sections and length (beyond the paper).

What the scans show of a vehicle tells its class (see ``docs/street.md``):

* a **van** (box van, lorry, bus, truck) is taller than the region of interest: its
  near face continues above ``max_height`` (the *wall* evidence of
  :func:`~tunnelsense.street.section_evidence`), or its body stands as high as
  ``van_height`` over most of its length (a car's roof covers less than half of it,
  bonnet and boot are lower); or it is longer than any car (``van_length``: flatbed
  lorries and trailers are long and low);
* a **motorbike** has no top surface as wide as a roof, bonnet or boot in any part of
  its length (handlebars, screen, seat and tank are narrow), and its footprint is
  narrow one way: along the street (one parked at right angles to the kerb, a deep
  cross-section 0.7-0.9 m long) or across it (one parallel to the kerb, shorter than
  a car);
* anything else is a **car**.

Every function here is array in, array out.
"""

from __future__ import annotations

import numpy as np

from tunnelsense.street._census import VEHICLE_CLASSES
from tunnelsense.street._vehicles import length_share

__all__ = ["VEHICLE_CLASSES", "class_features", "faces_end_on", "stands_across",
           "vehicle_class", "weighted_median"]

#: Bits of the per-cluster evidence flags (see ``_objects.BODY_FLAGS``).
ROOF_FLAG, WALL_FLAG = 0b0001, 0b0010


def weighted_median(values, weights):
    """The median of ``values`` weighted by ``weights`` (the plain median where the
    weights are all equal or sum to 0).

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._classes import weighted_median
    >>> weighted_median(np.array([0.9, 1.4, 1.5, 1.6]), np.array([0.0, 0.1, 0.1, 0.1]))
    1.5
    >>> weighted_median(np.array([0.9, 1.4, 1.5, 1.6]), np.ones(4))
    1.45
    """
    values = np.asarray(values, dtype=np.float64)
    weights = np.asarray(weights, dtype=np.float64)
    total = float(weights.sum())
    if total <= 0 or np.all(weights == weights[0]):
        return float(np.median(values))
    order = np.argsort(values, kind="stable")
    v, c = values[order], np.cumsum(weights[order])
    k = int(np.searchsorted(c, total / 2))
    if np.isclose(c[k], total / 2) and k + 1 < len(v):  # halfway between two
        return float((v[k] + v[k + 1]) / 2)
    return float(v[k])


def near_travel(near, position):
    """How far (m) an object's near side moves across the street over its length: the
    least-squares slope of the near side per scan against the distance along the
    street, times the distance it spans (0 with fewer than 3 scans).

    A vehicle parked parallel to the kerb keeps its near side (a row of motorbikes
    nose to tail steps by their offsets from the kerb); one in an angled bay turns
    its flank to the street, and the near side of the scans cutting it advances
    steadily across the street.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._classes import near_travel
    >>> round(near_travel(np.array([3.0, 3.5, 4.0, 4.5]), np.array([0.0, 0.5, 1.0, 1.5])), 2)
    1.5
    >>> near_travel(np.array([5.0, 5.0, 5.0]), np.array([0.0, 1.0, 2.0]))
    0.0
    """
    near = np.asarray(near, dtype=np.float64)
    position = np.asarray(position, dtype=np.float64)
    span = float(np.ptp(position)) if len(position) else 0.0
    if len(near) < 3 or span <= 0:
        return 0.0
    x = position - position.mean()
    slope = float((x * (near - near.mean())).sum() / (x * x).sum())
    return abs(slope) * span


def class_features(scan_flags, scan_top, scan, side, far, length, *, seen=None,
                   metres=None):
    """The cross-section features of one object from its scans and intra-clusters.

    Every feature is per scan, whatever the intra-clusters a scan's cut holds (a
    finer single-linkage cut parts a car's flank from its roof): a scan shows a roof
    when any of its clusters does, and its depth extent runs from the nearest to the
    farthest point of the body in it.

    Parameters
    ----------
    scan_flags : ndarray of shape (n_scans,) of int
        Evidence bits of every scan of the object (roof 1, wall 2; the bitwise or
        over its clusters in the scan).
    scan_top : ndarray of shape (n_scans,)
        The object's top height (m) in every scan of it (its height profile).
    scan : ndarray of shape (n_clusters,) of int
        Scan position of every intra-cluster of the object.
    side, far : ndarray of shape (n_clusters,)
        Nearest and farthest depth (m) of every intra-cluster's body (above kerb
        height; +inf / NaN: none).
    length : float
        The object's length (m along the street, as seen; NaN for a passing
        vehicle, whose seen length follows the two speeds).
    seen : ndarray of shape (n_scans,) of int, default=None
        Scan positions of ``scan_flags`` and ``scan_top`` (those of ``scan``).
    metres : ndarray, default=None
        Metres travelled at every scan position: the features are shares and
        medians over the object's length, not its scans (a car standing still
        sees one cross-section in many scans).  None: every scan counts alike.

    Returns
    -------
    features : dict
        ``roof`` and ``wall`` (fraction of the scans showing a roof-wide top
        surface, a wall above the region of interest), ``top`` (the median of the
        height profile, m: the height of the body over most of its length, which a
        stray high point or a badly estimated roll in a scan or two does not move),
        ``extent`` (the median over the scans of the body's depth extent across the
        street, m; NaN: no body), ``travel`` (how far its near side moves across the
        street over its length, :func:`near_travel`, m) and ``length``.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._classes import class_features
    >>> # three scans; the second cut in two clusters (flank, roof)
    >>> f = class_features(np.array([1, 1, 0]), np.array([1.4, 1.5, 0.9]),
    ...                    np.array([0, 1, 1, 2]), np.array([5.0, 5.0, 5.3, 5.1]),
    ...                    np.array([6.6, 5.1, 6.7, 6.5]), 4.2)
    >>> round(f["roof"], 3), f["top"], round(f["extent"], 2)
    (0.667, 1.4, 1.6)
    """
    scan_flags = np.asarray(scan_flags, dtype=np.int64)
    scan = np.asarray(scan, dtype=np.int64)
    side = np.asarray(side, dtype=np.float64)
    far = np.asarray(far, dtype=np.float64)
    extent = np.empty(0)
    travel = 0.0
    body = np.isfinite(side) & np.isfinite(far)
    if body.any():
        order = np.argsort(scan[body], kind="stable")
        s, lo, hi = scan[body][order], side[body][order], far[body][order]
        starts = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])
        near = np.minimum.reduceat(lo, starts)
        extent = np.maximum.reduceat(hi, starts) - near
        along = (np.cumsum(np.asarray(metres, dtype=np.float64))[s[starts]]
                 if metres is not None else s[starts].astype(np.float64))
        travel = near_travel(near, along)
    if metres is None or seen is None:
        w_scan = np.ones(len(scan_flags))
        w_body = np.ones(len(extent))
    else:
        w_scan = np.asarray(metres, dtype=np.float64)[np.asarray(seen, dtype=np.int64)]
        w_body = (np.asarray(metres, dtype=np.float64)[s[starts]] if len(extent)
                  else np.empty(0))
    return {
        "roof": length_share((scan_flags & ROOF_FLAG) > 0, w_scan) if len(w_scan)
        else 0.0,
        "wall": length_share((scan_flags & WALL_FLAG) > 0, w_scan) if len(w_scan)
        else 0.0,
        "top": weighted_median(scan_top, w_scan) if len(scan_top) else np.nan,
        "extent": weighted_median(extent, w_body) if len(extent) else np.nan,
        "travel": travel,
        "length": float(length),
    }


def vehicle_class(features, *, van_height=1.8, van_wall=0.2, van_length=7.0,
                  motorbike_roof=0.25, motorbike_width=1.2, min_car_length=2.4):
    """The class of a vehicle (``"car"``, ``"van"`` or ``"motorbike"``).

    Parameters
    ----------
    features : dict
        As :func:`class_features` returns.
    van_height : float, default=1.8
        Lowest height (m) of a van's body over most of its length (the median of
        its height profile): a car's roof, even an SUV's, covers less than half of
        its length, and vans, lorries and buses rise above it, most above the region
        of interest.
    van_wall : float, default=0.2
        Smallest fraction of the scans whose near face continues above the region
        of interest for a van (its roof is above the scans' ceiling).
    van_length : float, default=7.0
        Longest car (m, with room for two cars merged into one object); a longer
        vehicle is a van, lorry or trailer.
    motorbike_roof : float, default=0.25
        Largest fraction of the scans showing a roof-wide top surface of a
        motorbike (a few scans where a top box, the seat or the kerb behind widen
        its top); a car shows its roof, bonnet and boot in most of its scans.
    motorbike_width : float, default=1.2
        Narrowest car (m): the smallest city cars are 1.5 m wide and longer than
        2.4 m; a vehicle narrower than this one way (its length along the street, or
        its depth extent across it while its near side moves less than this across
        the street: a car in an angled bay, cut obliquely, shows short cross-sections
        along a near side that advances across the street) and without a roof is a
        motorbike.
    min_car_length : float, default=2.4
        Shortest car (m); a vehicle without a roof shorter than this is a motorbike,
        unless it is at least ``motorbike_width`` long and its depth extent across
        the street at least this (a car seen end on, in a bay at right angles to
        the kerb: its width along the street, its length across it; a motorbike is
        never 1.2 m wide both ways).

    Returns
    -------
    vehicle_class : str

    Examples
    --------
    >>> from tunnelsense.street._classes import vehicle_class
    >>> vehicle_class({"roof": 0.8, "wall": 0.0, "top": 1.5, "extent": 1.7,
    ...                "length": 4.3})
    'car'
    >>> vehicle_class({"roof": 0.3, "wall": 0.7, "top": 2.0, "extent": 1.9,
    ...                "length": 5.2})
    'van'
    >>> vehicle_class({"roof": 0.0, "wall": 0.0, "top": 1.3, "extent": 2.0,
    ...                "length": 0.8})  # at right angles to the kerb
    'motorbike'
    """
    f = features
    if f["wall"] >= van_wall or f["top"] >= van_height or f["length"] > van_length:
        return "van"
    # a body at least motorbike_width along the street and min_car_length across
    # it is a car seen end on (in a bay at right angles): no motorbike is that big
    end_on = bool(np.isfinite(f["extent"]) and f["extent"] >= min_car_length
                  and f["length"] >= motorbike_width)
    narrow = bool((f["length"] < min_car_length and not end_on) or (
        np.isfinite(f["extent"]) and f["extent"] < motorbike_width
        and f.get("travel", 0.0) < motorbike_width))
    if f["roof"] <= motorbike_roof and narrow:
        return "motorbike"
    return "car"


def stands_across(scan, side, far, cum, *, width=1.2, min_car_length=2.4, depth=0.8,
                  longest=7.0):
    """Whether one object's body stands across the street or obliquely to it, as a
    car in a bay at right angles or at 45 degrees to the kerb does and traffic
    never does (traffic drives along the street).

    Oblique: its near side moves across the street over its length by at least
    ``width`` (:func:`near_travel`; a vehicle driving along the street keeps it),
    and it is no longer along the street than ``longest`` (one vehicle: cars in a
    row of bays that single linkage joined are no one car).
    Across: shorter along the street than ``min_car_length`` while its
    cross-sections are at least ``depth`` deep (the median over its scans; a car
    seen end on shows its width along the street and its length across it).

    Parameters
    ----------
    scan : ndarray of shape (n_clusters,) of int
        Scan position of every intra-cluster of the object.
    side, far : ndarray of shape (n_clusters,)
        Nearest and farthest depth (m) of every intra-cluster's body (+inf / NaN:
        none).
    cum : ndarray
        Metres from the window's start to every scan position (``cum[p]``).
    width : float, default=1.2
        Smallest travel of the near side (m) of an oblique body.
    min_car_length : float, default=2.4
        Shortest car (m) along the street.
    depth : float, default=0.8
        Smallest depth (m) of the cross-sections of a body across the street.
    longest : float, default=7.0
        Longest oblique body (m along the street; ``van_length``).

    Returns
    -------
    across : bool

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._classes import stands_across
    >>> cum = np.arange(40) * 0.15
    >>> s = np.arange(30)  # 4.5 m along the street, near side 2.5 -> 4.0 m
    >>> bool(stands_across(s, np.linspace(2.5, 4.0, 30), np.full(30, 4.5), cum))
    True
    >>> bool(stands_across(s, np.full(30, 1.6), np.full(30, 3.1), cum))  # traffic
    False
    >>> bool(stands_across(s[:12], np.full(12, 3.0), np.full(12, 4.4), cum))  # end on
    True
    """
    scan = np.asarray(scan, dtype=np.int64)
    side = np.asarray(side, dtype=np.float64)
    far = np.asarray(far, dtype=np.float64)
    body = np.isfinite(side) & np.isfinite(far)
    if not body.any():
        return False
    first, last = int(scan.min()), int(scan.max())
    length = float(cum[last + 1] - cum[first])
    s, lo = scan[body], side[body]
    order = np.argsort(s, kind="stable")
    s, lo = s[order], lo[order]
    starts = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])
    near = np.minimum.reduceat(lo, starts)
    along = np.asarray(cum, dtype=np.float64)[s[starts]]
    if near_travel(near, along) >= width:
        return length <= longest
    if length >= min_car_length:
        return False
    extent = np.maximum.reduceat(far[body][order], starts) - near
    return bool(np.median(extent) >= depth)


def faces_end_on(scan, flags, cum, *, width=1.2, min_car_length=2.4, share=0.5):
    """Whether an object is the end face of a tall vehicle seen end on: a van in a bay
    at right angles to the kerb, whose body behind its face is out of sight.

    Its face stands taller than the region of interest (the wall evidence) along
    at least ``share`` of its length, and it is at least ``width`` but less than
    ``min_car_length`` long along the street.  Traffic drives along the street:
    a vehicle that tall driving past is seen at least as long as it is (over
    ``min_car_length``) unless it overtakes the probe car at more than twice its
    speed.

    Parameters
    ----------
    scan : ndarray of shape (n_clusters,) of int
        Scan position of every intra-cluster of the object.
    flags : ndarray of shape (n_clusters,) of int
        The evidence flags of every intra-cluster.
    cum : ndarray
        Metres from the window's start to every scan position (``cum[p]``).
    width : float, default=1.2
        Shortest face (m along the street; ``motorbike_width``).
    min_car_length : float, default=2.4
        Shortest car (m along the street).
    share : float, default=0.5
        Smallest share of its length showing a face taller than the region.

    Returns
    -------
    end_on : bool

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._classes import faces_end_on
    >>> cum = np.arange(40) * 0.15
    >>> s = np.arange(13)  # 1.95 m along the street, a tall face in every scan
    >>> bool(faces_end_on(s, np.full(13, 0b10), cum))
    True
    >>> bool(faces_end_on(np.arange(30), np.full(30, 0b10), cum))  # 4.5 m: a van
    False
    """
    scan = np.asarray(scan, dtype=np.int64)
    first, last = int(scan.min()), int(scan.max())
    cum = np.asarray(cum, dtype=np.float64)
    length = float(cum[last + 1] - cum[first])
    if not width <= length < min_car_length:
        return False
    wall = np.zeros(last - first + 1, dtype=bool)
    wall[scan[(np.asarray(flags) & WALL_FLAG) > 0] - first] = True
    metres = np.diff(cum[first:last + 2])
    total = float(metres.sum())
    seen = float(metres[wall].sum()) / total if total > 0 else float(wall.mean())
    return bool(seen >= share)
