"""Whether an object is one vehicle: its length, its body, its ends.

Paper section III-F regards an object-cluster of a region as a vehicle; beyond the
paper, an object must also be long enough and show a vehicle body (see
``docs/street.md``).  The rules here decide that for one object: the scans that hide
its ends (:func:`hidden_ends`) and its length with them, the vehicle test
(:func:`is_vehicle`; a motorbike's body raised or hanging, a motorbike across the
kerb), the scans past its ends that still see its top (:func:`end_match`) and its
extension into the hidden scans (:func:`extend_occluded`).  As in ``_objects``, every
function is array in, array out, on positions within a window of consecutive scans.
"""

from __future__ import annotations

import numpy as np

from tunnelsense.street._clustering import concat
from tunnelsense.street._objects import (
    BODY_FLAGS,
    HIDDEN_FLAG,
    PASSED_FLAG,
    RAISED_FLAG,
    SUSPENDED_FLAG,
)

__all__ = [
    "HIDDEN_TOP_FRACTION",
    "beams_below",
    "end_match",
    "extend_occluded",
    "hidden_ends",
    "is_vehicle",
    "length_share",
    "seen_share",
]

#: Shortest visible part (m) of a vehicle cut short by an occluder.
MIN_VISIBLE = 0.5
#: Share of an object's top below which a beam crossing its depth proves it absent
#: from that scan (:func:`hidden_ends`): the lowest part of a vehicle's body along
#: its length (a car's bonnet or boot, a motorbike's seat) stands higher.  Fixed,
#: not a parameter: it is a property of vehicle shapes, relative to the object's own
#: measured top, not of the sensor, the street or the scan rate (a bonnet or boot
#: at 0.8-1.0 m of a 1.4-1.6 m car, a seat at 0.8 m of a 1.1-1.3 m motorbike, a
#: van's body nearly its whole height), so no setting of a street or sensor should
#: move it; half leaves room below the lowest of them for a top measured over the
#: roof or mirrors, while a beam that low still crosses where a body would stand.
HIDDEN_TOP_FRACTION = 0.5


def hidden_ends(near, follows, first, last, depth, cum, cap, absent=None):
    """Scans right before ``first`` and after ``last`` (within one stretch of
    consecutive scans) whose nearest cluster is nearer than ``depth``; each walk stops
    once it covers ``cap`` metres (no decision looks farther).

    With ``absent`` (per scan, whether a beam proves the object absent there:
    :func:`beams_below`), a scan hides the object only where it is not absent: a
    beam that passes over the occluder and crosses the object's depth low enough
    (down to the kerb line behind it) says that the object is not there, so each
    walk also stops at such a scan.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._vehicles import hidden_ends
    >>> near = np.array([5.0, 2.0, 2.0, 5.0, 5.0])  # something nearer in scans 1, 2
    >>> follows = np.array([False, True, True, True, True])
    >>> hidden_ends(near, follows, 3, 4, 4.0, np.arange(6) * 0.5, 4.0)
    (2, 0)
    >>> # a beam over the occluder proves the object absent from scan 1
    >>> absent = np.array([False, True, False, False, False])
    >>> hidden_ends(near, follows, 3, 4, 4.0, np.arange(6) * 0.5, 4.0, absent)
    (1, 0)
    """
    if absent is None:
        absent = np.zeros(len(near), dtype=bool)
    before = 0
    p = first - 1
    while (p >= 0 and follows[p + 1] and near[p] < depth and not absent[p]
           and cum[first] - cum[p + 1] < cap):
        before += 1
        p -= 1
    after = 0
    p = last + 1
    while (p < len(near) and follows[p] and near[p] < depth and not absent[p]
           and cum[p] - cum[last + 1] < cap):
        after += 1
        p += 1
    return before, after


def beams_below(horizon, step, depth, top, fraction=HIDDEN_TOP_FRACTION):
    """Per scan, whether a beam crosses ``depth`` below ``fraction`` of ``top``: an
    object that tall standing there would have returned it, so it is not there.

    ``fraction`` of an object's top is the lowest part of a vehicle's body along
    its length (a car's bonnet or boot, a motorbike's seat stand higher); beams
    passing over a nearer occluder still prove this (they return from beyond
    ``depth``, from the kerb line or the footway), and dropouts prove nothing (they
    do not enter the horizon).

    Parameters
    ----------
    horizon : ndarray of shape (n_scans, n_depths)
        :func:`~tunnelsense.street._geometry.horizon` of the scans.
    step : float
        Its depth step (m).
    depth : float
        The object's depth (m).
    top : float
        The object's top height (m).
    fraction : float, default=HIDDEN_TOP_FRACTION

    Returns
    -------
    absent : ndarray of shape (n_scans,) of bool

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._vehicles import beams_below
    >>> h = np.array([[1.6, 1.5], [1.6, 0.2], [0.1, np.inf]])  # 2nd: road seen at 2 m
    >>> beams_below(h, 1.0, 2.0, 1.2).tolist()
    [False, True, False]
    """
    j = min(max(int(np.ceil(depth / step)), 1), horizon.shape[1]) - 1
    return horizon[:, j] < fraction * top


def length_share(mask, lengths):
    """The share of the length (m) of some scans that those where ``mask`` holds
    cover (the share of the scans where they cover none: the car stood still).

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._vehicles import length_share
    >>> mask = np.array([True, True, True, False])
    >>> length_share(mask, np.array([0.0, 0.0, 0.1, 0.3])), length_share(mask, np.zeros(4))
    (0.25, 0.75)
    """
    total = float(np.sum(lengths))
    if total > 0:
        return float(np.sum(lengths[mask]) / total)
    return float(np.mean(mask))


def seen_share(flags, evidence, lengths, where_seen=True, min_scans=2):
    """The share of an object's length showing ``evidence`` (bits of ``flags``),
    of the length where it could be seen.

    A scan whose lower part something nearer hides (``HIDDEN_FLAG``: the beam just
    below the object ends on the occluder) cannot show a body raised between wheels
    or hanging in the air, nor a beam passing under it; it says nothing either way,
    unless it shows the evidence.  Such scans are left out of the share when
    ``where_seen`` and at least ``min_scans`` scans show the evidence (one scan's
    evidence is too little to stand for the object); otherwise the share is of
    all its length.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._vehicles import seen_share
    >>> flags = np.array([0b1000, 0b1000, 0b1000, 0b0100, 0b0100, 0b0000])
    >>> round(seen_share(flags, 0b0100, np.full(6, 0.15), where_seen=False), 3)
    0.333
    >>> round(seen_share(flags, 0b0100, np.full(6, 0.15)), 3)
    0.667
    >>> round(seen_share(flags[2:], 0b0100, np.full(4, 0.15), min_scans=3), 3)
    0.5
    """
    shows = (flags & evidence) > 0
    informative = shows | ((flags & HIDDEN_FLAG) == 0)
    if not where_seen or shows.sum() < min_scans:
        return length_share(shows, lengths)
    return length_share(shows[informative], lengths[informative])


def is_vehicle(seen, flags, depth, hidden_length, cum, near, *, min_length, max_length,
               link_distance, min_body_fraction, min_car_length=0.0,
               min_raised_fraction=0.0, min_across_length=None, min_across_raised=0.5,
               top=np.inf, min_across_top=0.0, inside=True, end_length=0.0,
               where_seen=False):
    """Whether an object (its scans ``seen``, sorted) can be one vehicle.

    Long enough in all and without a break (a scan of its span counts as seen when
    something at least ``link_distance`` nearer hid it), or, cut short by an occluder
    (``hidden_length`` metres hidden at its ends), long enough with the hidden part;
    not longer than ``max_length``; a vehicle body (roof, wall or raised body) in at
    least ``min_body_fraction`` of its scans.  Shorter than ``min_car_length`` (with
    the hidden part) it can only be a motorbike: a body raised above the road between
    its wheels, or hanging in the air (``SUSPENDED_FLAG``: its lowest point above the
    clearance, the beam below it passing farther), in at least
    ``min_raised_fraction`` of its scans (communal bins, wheelie bins and people
    stand on the ground); those scans count as body.  Shorter than ``min_length`` but
    at least ``min_across_length`` long, seen whole (nothing hides its ends), it is a
    motorbike at right angles to the kerb when at least ``min_across_raised`` of its
    scans show a body raised between wheels or a beam passing under it
    (``PASSED_FLAG``) and its ``top`` reaches
    ``min_across_top`` (handlebars and screen; ``None``: never); a beam passing
    under it counts as that evidence only when it lies ``inside`` its stretch of
    consecutive scans (a run's first or last scans cut what they show: a van's end
    is not a motorbike).  ``end_length`` (m) is the length of the scans past its
    ends that see its top joined to something behind (:func:`end_match`); it
    counts to the length of a motorbike across the kerb.  ``where_seen``: an
    object seen shorter than ``min_car_length`` (it can only be a motorbike) takes
    the shares of its body (raised, hanging or any body evidence), of its raised or
    hanging body and of the beams passing under it over the length where they could
    be seen (:func:`seen_share`).
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
    # shares of the object's length, not of its scans: a car standing still sees
    # one cross-section in many scans
    lengths = cum[seen + 1] - cum[seen]
    # shorter than any car as seen, it can only be a motorbike: its body raised or
    # hanging where the beams could see under it
    where_seen = bool(where_seen and length < min_car_length)
    body = length_share((flags & BODY_FLAGS) > 0, lengths)
    if where_seen:
        body = max(body, seen_share(flags, BODY_FLAGS | SUSPENDED_FLAG, lengths))
    if vehicle and length + hidden_length < min_car_length:
        # a body raised between the wheels, or seen hanging in the air
        hanging = seen_share(flags, RAISED_FLAG | SUSPENDED_FLAG, lengths, where_seen)
        vehicle = hanging >= min_raised_fraction
        body = max(body, hanging)
    elif (not vehicle and min_across_length is not None and hidden_length == 0
          and min_across_length <= length + end_length < min_length
          and top >= min_across_top
          and (cum[seen + 1] - cum[seen]).sum() >= length - MIN_VISIBLE / 2):
        evidence = RAISED_FLAG | (PASSED_FLAG if inside else 0)
        under = seen_share(flags, evidence, lengths, where_seen)
        vehicle = under >= min_across_raised  # a motorbike across the kerb
        body = max(body, under)  # its body: raised, or a beam passing under it
    return bool(vehicle and body >= min_body_fraction)


def end_match(upper, points, tolerance):
    """The points of a scan that reach the same highest part of an object as
    ``upper`` (its points near its top in the neighbouring scan).

    Past the end of a narrow object (a motorbike across the kerb) a scan sees its
    widest part alone: the screen and handlebars, at the height and depth where the
    scan before saw them.  When that part touches something behind (a hedge, a
    wall, the footway), single linkage joins it to that; its points still say that
    the object reaches into the scan.

    Parameters
    ----------
    upper : ndarray of shape (n, 2)
        ``(depth, height)`` of the object's points near its top in one scan.
    points : ndarray of shape (m, 2)
        ``(depth, height)`` of every point of the neighbouring scan.
    tolerance : float
        Largest depth and height difference (m): the resolution of the beams there.

    Returns
    -------
    matched : ndarray of shape (k, 2)
        The points of ``points`` within ``tolerance`` (both ways) of a point of
        ``upper`` and no lower than ``upper``'s lowest by more than ``tolerance``.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._vehicles import end_match
    >>> upper = np.array([[6.6, 1.25], [6.65, 1.3]])
    >>> scan = np.array([[6.5, 0.12], [6.62, 1.28], [7.2, 1.3], [7.2, 1.0]])
    >>> end_match(upper, scan, 0.1).tolist()
    [[6.62, 1.28]]
    """
    if not len(upper) or not len(points):
        return points[:0]
    cand = points[points[:, 1] >= upper[:, 1].min() - tolerance]
    if not len(cand):
        return cand
    near = ((np.abs(cand[:, None, 0] - upper[None, :, 0]) <= tolerance)
            & (np.abs(cand[:, None, 1] - upper[None, :, 1]) <= tolerance)).any(axis=1)
    return cand[near]


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
    >>> from tunnelsense.street._vehicles import extend_occluded
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
