"""Three-dimensional restoration and tilt compensation (paper section III-A, III-B).

A vertically scanning laser range finder measures, in every scan, one range per beam in
the plane perpendicular to the street.  With the beam angle ``theta`` measured from the
horizontal (positive up, ROS ``LaserScan`` convention) and the sensor ``mount_height``
above the road, a return at range ``r`` lies at::

    depth  = r * cos(theta + tilt)        (across the street, away from the sensor)
    height = mount_height + r * sin(theta + tilt)

where ``tilt`` is the roll of the sensor in the scan plane, unknown in practice.  The
functions below work on one scan (1-D arrays) or on a stack of scans (2-D arrays, one
row per scan), so that a whole run is restored with a handful of array operations.
"""

from __future__ import annotations

import numpy as np

__all__ = ["compensate_tilt", "estimate_tilt", "no_return", "restore_points"]


def no_return(ranges, range_min=0.0, range_max=np.inf):
    """Mask of beams without a usable return.

    NaN, +inf, a range ``>= range_max`` (drivers report "nothing within range" in all
    three ways) and a range ``< range_min`` are no return.

    Parameters
    ----------
    ranges : array-like of float
        Ranges in metres, any shape.
    range_min, range_max : float, default=0.0, inf
        The valid range interval of the sensor.

    Returns
    -------
    mask : ndarray of bool, same shape as ``ranges``
        True where the beam has no return.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street import no_return
    >>> no_return([1.0, np.nan, np.inf, 8.191, 0.01], range_min=0.02, range_max=8.191)
    array([False,  True,  True,  True,  True])
    """
    r = np.asarray(ranges, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        return ~((r >= range_min) & (r < range_max))


def restore_points(ranges, angles, mount_height, tilt=0.0, road_offset=None):
    """Polar ranges to ``(depth, height)`` points, tilt compensated.

    Parameters
    ----------
    ranges : ndarray of shape (n_beams,) or (n_scans, n_beams)
        Ranges in metres; beams without return must already be NaN (see
        :func:`no_return`).
    angles : ndarray of shape (n_beams,)
        Beam angles (rad) from the horizontal, positive up.
    mount_height : float
        Height of the sensor above the road (m).
    tilt : float or ndarray of shape (n_scans,), default=0.0
        Roll of the sensor in the scan plane (rad), added to every beam angle.
    road_offset : float, ndarray of shape (n_scans,) or None, default=None
        Height of the sensor above the road as estimated from the road itself (see
        :func:`estimate_tilt`); None uses ``mount_height``.  NaN entries fall back to
        ``mount_height``.

    Returns
    -------
    depth, height : ndarray, same shape as ``ranges``
        NaN where the range is NaN.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street import restore_points
    >>> d, h = restore_points(np.array([2.0, 2.0]), np.array([-np.pi / 6, 0.0]), 1.0)
    >>> np.round(d, 3).tolist(), np.round(h, 3).tolist()
    ([1.732, 2.0], [0.0, 1.0])
    """
    r = np.asarray(ranges, dtype=np.float64)
    theta = np.asarray(angles, dtype=np.float64)
    tilt = np.asarray(tilt, dtype=np.float64)
    if r.ndim == 2 and tilt.ndim == 1:
        tilt = tilt[:, None]
    offset = mount_height
    if road_offset is not None:
        offset = np.where(np.isnan(road_offset), mount_height, road_offset)
        offset = np.asarray(offset, dtype=np.float64)
        if r.ndim == 2 and offset.ndim == 1:
            offset = offset[:, None]
    phi = theta + tilt
    return r * np.cos(phi), offset + r * np.sin(phi)


def estimate_tilt(
    ranges,
    angles,
    mount_height,
    *,
    max_tilt=10.0,
    tolerance=0.1,
    min_road_points=5,
    resolution=0.25,
):
    """Estimate the sensor's tilt from the beams that hit the road, scan by scan.

    The paper takes "a few first laser beams" as road points.  That fails when the
    first beams hit something else (a car parked right beside the sensor), so the
    estimate here is robust, in two steps:

    1. *Vote* (a one-parameter Hough transform, RANSAC-like): every downward return at
       range ``r >= mount_height`` is on the road for exactly one tilt,
       ``tilt = -arcsin(mount_height / r) - theta``.  Road returns agree on it, returns
       from vertical surfaces (a car side, a wall) spread over many tilts.  The tilt
       bin (``resolution`` wide, counted with its two neighbours) holding most votes
       within ``[-max_tilt, max_tilt]`` wins.
    2. *Refine*: the returns within ``tolerance`` of the road plane of the winning
       tilt are fitted with a least-squares line in the sensor frame, twice (re-select
       inliers with the fitted line).  The line's slope gives the tilt, its distance
       from the sensor the road offset (the sensor's height above this very road, which
       absorbs errors of ``mount_height`` and the vehicle's bounce).

    Parameters
    ----------
    ranges : ndarray of shape (n_beams,) or (n_scans, n_beams)
        Ranges (m); no-return beams NaN (or +inf).
    angles : ndarray of shape (n_beams,)
        Nominal beam angles (rad) from the horizontal, positive up.
    mount_height : float
        Nominal height of the sensor above the road (m).
    max_tilt : float, default=10.0
        Largest tilt considered (degrees).
    tolerance : float, default=0.1
        Largest distance (m) of a road return from the road plane; the paper's road
        band (``|height| < 0.1`` m).
    min_road_points : int, default=5
        Fewer road inliers than this: no estimate (NaN).
    resolution : float, default=0.25
        Width of a vote bin (degrees).

    Returns
    -------
    tilt : float or ndarray of shape (n_scans,)
        Estimated tilt (rad), NaN where the road is not seen.
    road_offset : float or ndarray of shape (n_scans,)
        Estimated height (m) of the sensor above the road, NaN where not seen.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street import estimate_tilt
    >>> angles = np.deg2rad(np.linspace(-80, -20, 61))
    >>> true_tilt = np.deg2rad(3.0)
    >>> ranges = 1.5 / np.sin(-(angles + true_tilt))    # flat road 1.5 m below
    >>> ranges[:10] = 0.9                              # a car right beside the sensor
    >>> tilt, offset = estimate_tilt(ranges, angles, 1.5)
    >>> round(float(np.rad2deg(tilt)), 3), round(float(offset), 3)
    (3.0, 1.5)
    """
    r = np.asarray(ranges, dtype=np.float64)
    one = r.ndim == 1
    r = np.atleast_2d(r)
    r = np.where(np.isfinite(r), r, np.nan)
    theta = np.asarray(angles, dtype=np.float64)[None, :]
    n_scans = r.shape[0]
    h = float(mount_height)
    max_tilt = np.deg2rad(max_tilt)
    resolution = np.deg2rad(resolution)
    # 1. votes
    with np.errstate(invalid="ignore", divide="ignore"):
        ok = (r >= h) & (theta < max_tilt) & (theta > -np.pi / 2 - max_tilt)
        vote = -np.arcsin(np.where(ok, h / np.where(ok, r, 1.0), 0.0)) - theta
    ok &= np.abs(vote) <= max_tilt
    n_bins = int(np.ceil(2 * max_tilt / resolution)) + 1
    bins = np.clip(((vote + max_tilt) / resolution).astype(np.int64), 0, n_bins - 1)
    rows = np.broadcast_to(np.arange(n_scans)[:, None], r.shape)
    counts = np.zeros((n_scans, n_bins + 2), dtype=np.int64)
    np.add.at(counts, (rows[ok], bins[ok] + 1), 1)
    smooth = counts[:, :-2] + counts[:, 1:-1] + counts[:, 2:]
    best = np.argmax(smooth, axis=1)
    tilt0 = -max_tilt + (best + 0.5) * resolution
    # 2. refine: inliers of the voted road plane, then a line fit, twice
    x = r * np.cos(theta)
    z = r * np.sin(theta)
    valid = np.isfinite(r)
    # road of the voted tilt, in sensor coordinates: x sin(t) + z cos(t) = -h
    resid = x * np.sin(tilt0)[:, None] + z * np.cos(tilt0)[:, None] + h
    slope = np.full(n_scans, np.nan)
    icept = np.full(n_scans, np.nan)
    for _ in range(2):
        with np.errstate(invalid="ignore"):
            inl = valid & (np.abs(resid) < tolerance) & (x > 0)
        n = inl.sum(axis=1)
        xs = np.where(inl, x, 0.0)
        zs = np.where(inl, z, 0.0)
        sx, sz = xs.sum(1), zs.sum(1)
        sxx, sxz = (xs * xs).sum(1), (xs * zs).sum(1)
        with np.errstate(invalid="ignore", divide="ignore"):
            den = n * sxx - sx * sx
            slope = (n * sxz - sx * sz) / den
            icept = (sz - slope * sx) / n
        good = (n >= min_road_points) & np.isfinite(slope) & (np.abs(den) > 1e-12)
        slope = np.where(good, slope, np.nan)
        icept = np.where(good, icept, np.nan)
        # distance of every return from the fitted line z = icept + slope x
        with np.errstate(invalid="ignore"):
            resid = (z - icept[:, None] - slope[:, None] * x) / np.sqrt(
                1 + slope[:, None] ** 2
            )
    tilt = -np.arctan(slope)
    offset = -icept * np.cos(tilt)
    with np.errstate(invalid="ignore"):
        bad = ~(np.abs(tilt) <= max_tilt) | ~(offset > 0)
    tilt = np.where(bad, np.nan, tilt)
    offset = np.where(bad, np.nan, offset)
    if one:
        return float(tilt[0]), float(offset[0])
    return tilt, offset


def compensate_tilt(ranges, angles, mount_height, tilt, road_offset=None):
    """Restore ``(depth, height)`` with the road at height 0, filling unknown tilts.

    Scans whose tilt is NaN (road not seen) take the median of the other scans'
    estimates (0 when no scan saw the road); their road offset falls back to
    ``mount_height``.

    Parameters
    ----------
    ranges : ndarray of shape (n_scans, n_beams)
        Ranges (m); no-return beams NaN.
    angles : ndarray of shape (n_beams,)
        Nominal beam angles (rad).
    mount_height : float
        Nominal height of the sensor above the road (m).
    tilt, road_offset : ndarray of shape (n_scans,)
        As returned by :func:`estimate_tilt`; ``road_offset`` None uses
        ``mount_height`` everywhere.

    Returns
    -------
    depth, height : ndarray of shape (n_scans, n_beams)
    tilt : ndarray of shape (n_scans,)
        The tilt used for every scan.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street import compensate_tilt
    >>> d, h, used = compensate_tilt(np.ones((2, 1)), np.zeros(1), 1.0,
    ...                              np.array([np.nan, 0.0]))
    >>> used.tolist(), h.ravel().tolist()
    ([0.0, 0.0], [1.0, 1.0])
    """
    tilt = np.asarray(tilt, dtype=np.float64)
    known = np.isfinite(tilt)
    fill = float(np.median(tilt[known])) if known.any() else 0.0
    tilt = np.where(known, tilt, fill)
    depth, height = restore_points(ranges, angles, mount_height, tilt, road_offset)
    return depth, height, tilt
