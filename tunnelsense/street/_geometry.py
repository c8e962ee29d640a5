"""From ranges to region-of-interest points.

The per-scan geometry of the detector (paper sections III-A and III-B): restoration,
tilt compensation with a fallback for scans that show no road (the recent tilts:
:class:`~tunnelsense.street._history.History`), the region of interest with the
returns of the beams just above and below every point, the kerb and the horizon.
Every value comes from the scans seen so far, never from later ones, so that a
stream and a batch run agree.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from tunnelsense.street._restoration import (
    compensate_tilt,
    estimate_tilt,
    no_return,
    restore_points,
)
from tunnelsense.street._roi import roi_mask

__all__ = [
    "HORIZON_STEP",
    "RoiPoints",
    "horizon",
    "kerb_steps",
    "road_crossing",
    "roi_points",
]

#: Depth step (m) of the grid on which :func:`horizon` is kept.
HORIZON_STEP = 0.25


#: Heights (m) of a kerb step: lowest and highest footway above the road.
KERB_STEP = (0.05, 0.35)
#: Footway beams after the step that must lie flat (within ``KERB_FLAT`` m).
KERB_RUN = 3
KERB_FLAT = 0.03
#: Steepest footway run (height change over depth advance): a footway's cross-fall is a
#: few per cent; the near face of a vehicle close to the sensor, whose beams lie
#: within ``KERB_FLAT`` of each other in height, rises without going outwards.
KERB_SLOPE = 0.2
#: Returns of the kerb's face between road and footway: at most this many, within
#: ``KERB_FACE_DEPTH`` (m) of the road's last return.
KERB_FACE = 3
KERB_FACE_DEPTH = 0.3


def kerb_steps(depth, height, road=0.04):
    """Per scan, the depth (m) of a kerb step, or NaN where none shows.

    Going out along the beams of one scan: a return of the road (within ``road``
    of height 0 after tilt compensation), then at most ``KERB_FACE`` returns of
    the kerb's face (within ``KERB_FACE_DEPTH`` of the road's last depth), then
    ``KERB_RUN`` returns going outwards and lying flat (within ``KERB_FLAT``, and
    rising at most ``KERB_SLOPE`` of their depth advance) at a height in
    ``KERB_STEP``: the footway behind the kerb.  The step lies halfway
    between the road's last return and the next one.  Scans where a parked vehicle hides the kerb show none.

    Parameters
    ----------
    depth, height : ndarray of shape (n_scans, n_beams)
        Restored, tilt-compensated returns, in beam order (NaN: none).
    road : float, default=0.04

    Returns
    -------
    kerb : ndarray of shape (n_scans,)

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._geometry import kerb_steps
    >>> d = np.array([[5.9, 6.3, 6.49, 6.43, 6.45, 6.52, 6.73, 7.0, 7.18]])
    >>> h = np.array([[0.0, 0.01, -0.02, 0.06, 0.12, 0.16, 0.16, 0.15, 0.17]])
    >>> kerb_steps(d, h).tolist(), kerb_steps(d, h + 0.5).tolist()
    ([6.46], [nan])
    """
    n_scans, n_beams = depth.shape
    out = np.full(n_scans, np.nan)
    lo, hi = KERB_STEP
    n = n_beams - KERB_RUN + 1  # beams that can start a footway run
    if n < 2:
        return out
    with np.errstate(invalid="ignore"):
        is_road = np.abs(height) < road
        step = (height >= lo) & (height <= hi)
        run = step[:, :n].copy()  # a flat footway run starts at the beam
        for k in range(1, KERB_RUN):
            run &= (step[:, k:n + k] & (np.abs(height[:, k:n + k] - height[:, :n])
                                        <= KERB_FLAT)
                    & (depth[:, k:n + k] > depth[:, k - 1:n + k - 1]))
        end = KERB_RUN - 1  # the run lies flat: it goes outwards, not up
        run &= (np.abs(height[:, end:n + end] - height[:, :n])
                <= KERB_SLOPE * (depth[:, end:n + end] - depth[:, :n]))
        found = np.zeros((n_scans, n), dtype=bool)
        kerb = np.full((n_scans, n), np.nan)
        for gap in range(KERB_FACE + 1, 0, -1):  # the road's last return gap beams back
            j = np.arange(gap, n)
            i = j - gap
            ok = run[:, j] & is_road[:, i]
            for f in range(1, gap):  # the beams between: the kerb's face
                ok &= np.abs(depth[:, i + f] - depth[:, i]) <= KERB_FACE_DEPTH
            kerb[:, j] = np.where(ok, (depth[:, i] + depth[:, i + 1]) / 2, kerb[:, j])
            found[:, j] |= ok
    rows = np.flatnonzero(found.any(axis=1))
    out[rows] = kerb[rows, found[rows].argmax(axis=1)]
    return out


class RoiPoints(NamedTuple):
    """Region-of-interest points of a block of scans, in scan then beam order."""

    scan: np.ndarray  #: (n,) index of the point's scan in the block
    beam: np.ndarray  #: (n,) beam number
    points: np.ndarray  #: (n, 2) ``(depth, height)``
    above: np.ndarray  #: (n, 2) the return of the next beam up (NaN: none)
    below: np.ndarray  #: (n, 2) the return of the next beam down (NaN: none)
    tilt: np.ndarray  #: (n_scans,) the tilt used for every scan (rad)
    horizon: np.ndarray  #: (n_scans, n_depths) see :func:`horizon`
    sensor: np.ndarray  #: (n_scans,) height of the sensor in the restored frame
    #: (n, 2) whether the beam just above / below returned nothing within range
    #: (it passes everything; a dropout, NaN, says nothing)
    passes: np.ndarray
    #: (n_scans,) depth of the kerb step every scan shows (NaN: none)
    kerb: np.ndarray


def roi_points(ranges, geometry, history, *, tilt_compensation=True, max_tilt=10.0,
               min_height=0.1, max_height=2.0):
    """Restore a block of scans and keep the returns in the region of interest.

    Parameters
    ----------
    ranges : ndarray of shape (n_scans, n_beams)
        Ranges (m) of consecutive scans of one run.
    geometry : LaserGeometry
        The run's sensor geometry.
    history : History
        The run's recent tilts (updated): a scan whose tilt cannot be estimated takes
        their median.
    tilt_compensation : bool, default=True
        Estimate the tilt of every scan from the road; False: the nominal geometry.
    max_tilt : float, default=10.0
        Largest tilt (degrees) the estimate considers.
    min_height, max_height : float, default=0.1, 2.0
        The region of interest (m above the road), exclusive.

    Returns
    -------
    points : RoiPoints
    """
    n_beams = ranges.shape[1]
    r = np.where(no_return(ranges, geometry.range_min, geometry.range_max), np.nan,
                 ranges)
    angles = geometry.angles(n_beams)
    if tilt_compensation:
        tilt, offset = estimate_tilt(r, angles, geometry.mount_height,
                                     max_tilt=max_tilt, tolerance=min_height)
        tilt = history.fill_tilts(tilt)
        depth, height, tilt = compensate_tilt(r, angles, geometry.mount_height, tilt,
                                              offset)
    else:
        tilt = np.zeros(len(r))
        depth, height = restore_points(r, angles, geometry.mount_height)
    scan, beam = np.nonzero(roi_mask(depth, height, min_height=min_height,
                                     max_height=max_height))
    up, down = np.minimum(beam + 1, n_beams - 1), np.maximum(beam - 1, 0)
    above = np.column_stack([depth[scan, up], height[scan, up]])
    above[beam + 1 >= n_beams] = np.nan
    below = np.column_stack([depth[scan, down], height[scan, down]])
    below[beam == 0] = np.nan
    points = np.column_stack([depth[scan, beam], height[scan, beam]])
    # beams with nothing within range (not dropouts) pass everything up to range_max
    offset = offset if tilt_compensation else None
    with np.errstate(invalid="ignore"):
        far = np.where(ranges >= geometry.range_max, geometry.range_max, np.nan)
    far_depth, far_height = restore_points(far, angles, geometry.mount_height, tilt,
                                           offset)
    sensor = restore_points(np.zeros((len(r), 1)), angles[:1], geometry.mount_height,
                            tilt, offset)[1][:, 0]
    passes = np.isfinite(far_depth)
    far_depth, far_height = road_crossing(far_depth, far_height, sensor, min_height)
    beyond = np.column_stack([passes[scan, up] & (beam + 1 < n_beams),
                              passes[scan, down] & (beam > 0)])
    return RoiPoints(scan, beam, points, above, below, tilt, horizon(
        np.where(passes, far_depth, depth), np.where(passes, far_height, height),
        sensor), sensor, beyond, kerb_steps(depth, height))


def road_crossing(depth, height, sensor, tolerance):
    """Move the far end of beams that return nothing back to where they meet the road.

    A beam with nothing within range counts as passing everything up to its far end
    (:func:`horizon`); but one whose line dips more than ``tolerance`` below the
    road before that end met the road surface on its way (a wet or dark road that
    returned nothing): it proves nothing past the point where its line crosses
    ``-tolerance``, and ends there.

    Parameters
    ----------
    depth, height : ndarray of shape (n_scans, n_beams)
        Far ends of the beams (NaN: a beam that returned).
    sensor : ndarray of shape (n_scans,)
        Height of the sensor (m) in the same frame.
    tolerance : float
        How far below the road plane (m) the road surface may lie.

    Returns
    -------
    depth, height : ndarray of shape (n_scans, n_beams)

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._geometry import road_crossing
    >>> d, h = road_crossing(np.array([[8.0, 8.0]]), np.array([[-2.0, 1.0]]),
    ...                      np.array([2.0]), 0.1)
    >>> d.round(2).tolist(), h.round(2).tolist()
    ([[4.2, 8.0]], [[-0.1, 1.0]])
    """
    with np.errstate(invalid="ignore", divide="ignore"):
        below = height < -tolerance
        s = sensor[:, None]
        scale = np.where(below, (s + tolerance) / (s - height), 1.0)
    return depth * scale, np.where(below, -tolerance, height)


def horizon(depth, height, sensor, step=HORIZON_STEP, n_depths=None):
    """Per scan, how low the beams that pass a depth cross it: what they rule out.

    A beam that ends on a nearer object says nothing about what lies behind it; a
    beam that returns from beyond depth ``d`` proves that nothing stands at ``d``
    higher than where its line crosses ``d``.  For every scan and every depth
    ``d = step, 2 step, ...`` this is the lowest crossing height of the beams
    returning from beyond ``d`` (+inf where none does: ``d`` is hidden).

    Parameters
    ----------
    depth, height : ndarray of shape (n_scans, n_beams)
        Restored returns (NaN: dropout; a beam with nothing within range counts as
        returning from its farthest range).
    sensor : ndarray of shape (n_scans,)
        Height of the sensor (m) in the same frame.
    step : float, default=HORIZON_STEP
        Depth step (m) of the grid.
    n_depths : int, default=None
        Grid size; ``ceil(8.2 / step)`` when None.

    Returns
    -------
    bound : ndarray of shape (n_scans, n_depths)

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._geometry import horizon
    >>> # a beam ending on a roof at 3 m (1.5 m high), another one over it onto the
    >>> # road at 12 m: at 5 m, nothing rises above 1.46 m
    >>> horizon(np.array([[12.0, 3.0]]), np.array([[0.0, 1.5]]), np.array([2.5]),
    ...         step=2.5, n_depths=3).round(2).tolist()
    [[1.67, 1.46, 0.94]]
    """
    n_depths = int(np.ceil(8.2 / step)) if n_depths is None else n_depths
    n_scans = depth.shape[0]
    grid = step * np.arange(1, n_depths + 1)
    # a beam crosses depth d at sensor - d * slope: the lowest crossing at d is that
    # of the steepest beam passing d.  Bucket every beam by how many grid depths it
    # passes, then take the running maximum of the slopes from the far end.
    ok = np.isfinite(depth) & np.isfinite(height) & (depth > 0)
    scan, beam = np.nonzero(ok)
    x, h = depth[scan, beam], height[scan, beam]
    slope = (sensor[scan] - h) / x
    passed = np.clip(np.ceil(x / step - 1.0), 0, n_depths).astype(np.int64)
    steepest = np.full((n_scans, n_depths + 1), -np.inf)
    np.maximum.at(steepest, (scan, passed), slope)
    steepest = np.maximum.accumulate(steepest[:, ::-1], axis=1)[:, ::-1]
    m = steepest[:, 1:]
    with np.errstate(invalid="ignore"):
        return np.where(np.isfinite(m), sensor[:, None] - grid[None, :] * m, np.inf)
