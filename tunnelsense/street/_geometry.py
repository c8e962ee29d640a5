"""From ranges to region-of-interest points, and the distance travelled per scan.

The per-scan geometry of the detector (paper sections III-A to III-C): restoration,
tilt compensation with a fallback for scans that show no road, the region of interest
with the returns of the beams just above and below every point, and the distance
along the track between two scans (ego speed times scan period).  Every value comes
from the scans seen so far, never from later ones, so that a stream and a batch run
agree.
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
    "DEFAULT_SCAN_PERIOD",
    "DEFAULT_SPEED",
    "across_lost",
    "forward_fill",
    "metres_from",
    "HORIZON_STEP",
    "History",
    "horizon",
    "road_crossing",
    "kerb_steps",
    "RoiPoints",
    "SPEED_WINDOW",
    "roi_points",
    "running_median",
]

#: The paper's ego speed (m/s): its measurement vehicle drove at about 40 km/h
#: (``ScanClusterer(speed="paper")``; never assumed for scans without a speed).
DEFAULT_SPEED = 40 / 3.6
#: Scan period (s) assumed when the stamps do not give one yet (75 scans/s).
DEFAULT_SCAN_PERIOD = 1 / 75
#: Depth step (m) of the grid on which :func:`horizon` is kept.
HORIZON_STEP = 0.25
#: Scans over which the scan period and the fallback tilt are medians.
HISTORY = 151
#: Scans over which the ego speed of the scans' payload is a median (a scan and the
#: ones just before it: against odometry's noise, without lagging across a stop).
SPEED_WINDOW = 5


def _windows(history, values, window):
    """The last ``window`` values (history then values, NaN before) ending at every
    new value: an array of shape ``(len(values), window)``."""
    full = np.concatenate([np.full(window - 1, np.nan), history[-(window - 1):], values])
    full = full[-(len(values) + window - 1):]
    return np.lib.stride_tricks.sliding_window_view(full, window)


def running_median(history, values, window=HISTORY):
    """Median of the finite values among the last ``window`` (history then values),
    for every new value; NaN where there is none.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._geometry import running_median
    >>> running_median(np.array([1.0, 5.0]), np.array([3.0, np.nan, 9.0]), window=3)
    array([3., 4., 6.])
    """
    win = _windows(history, values, window)
    srt = np.sort(win, axis=1)  # NaN last
    k = np.isfinite(win).sum(axis=1)
    rows = np.arange(len(values))
    lo = srt[rows, np.maximum((k - 1) // 2, 0)]
    hi = srt[rows, np.maximum(k // 2, 0)]
    return np.where(k > 0, (lo + hi) / 2, np.nan)


#: Stamp difference (in scan periods) from which consecutive scan numbers are taken
#: to hide lost scans: host-time stamps jitter and are quantised (a 10 ms clock at
#: 75 scans/s gives differences of 0.75 and 1.5 periods), so a difference of up to
#: two periods is read as jitter, not as a lost scan.
STAMP_GAP = 2.5


def running_tick(history, values, window=HISTORY):
    """The typical step of the stamps for every new stamp difference: the median of
    the positive ones among the last ``window`` (history then values); NaN where
    there is none.

    It is the scan period for stamps that follow the scans, and the clock's step for
    a clock coarser than the period (at 75 scans/s a 40 ms clock gives differences of
    0, 0 and 40 ms): a difference of a few such steps is then no lost scan.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._geometry import running_tick
    >>> running_tick(np.empty(0), np.array([0.0, 0.0, 0.04, 0.0, 0.0, 0.04])).tolist()
    [nan, nan, 0.04, 0.04, 0.04, 0.04]
    """
    with np.errstate(invalid="ignore"):
        return running_median(np.where(history > 0, history, np.nan),
                              np.where(values > 0, values, np.nan), window)


def running_period(history, values, window=HISTORY, tick=None):
    """The scan period for every new stamp difference: the mean of the finite ones
    among the last ``window`` (history then values), leaving out those of
    ``STAMP_GAP`` times the mean of all, or of the stamps' step (``tick``, by default
    :func:`running_tick`), whichever is larger, or more (a gap over lost scans); NaN
    where there is none.

    A median reads a clock coarser than the period wrong: at 75 scans/s stamps on
    a 10 ms clock differ by 10 ms twice and 20 ms once (and by 0 or 30 ms when they
    also jitter), whose median is 10 ms where the period is 13.3 ms, and every
    length would be a quarter short.  The mean is right for such a clock and for
    stamps that jitter: the time between two stamps is spread over the scans.  On a
    clock of several periods (differences of 0 and 40 ms) the stamps' step keeps
    its own differences in the mean, which would otherwise be 0.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._geometry import running_period
    >>> d = np.array([0.01, 0.02, 0.01, 0.01, 0.02, 0.01])
    >>> np.round(running_period(np.empty(0), d), 4)
    array([0.01  , 0.015 , 0.0133, 0.0125, 0.014 , 0.0133])
    >>> running_period(np.full(5, 0.01), np.array([0.2]), window=6)  # a gap
    array([0.01])
    >>> round(float(running_period(np.empty(0), np.tile([0.0, 0.0, 0.04], 3))[-1]), 4)
    0.0133
    """
    if tick is None:
        tick = running_tick(history, values, window)
    win = _windows(history, values, window)
    finite = np.isfinite(win)
    n = finite.sum(axis=1)
    mean = np.where(finite, win, 0.0).sum(axis=1) / np.maximum(n, 1)
    with np.errstate(invalid="ignore"):
        near = finite & (win < STAMP_GAP * np.fmax(mean, tick)[:, None])
    k = near.sum(axis=1)
    total = np.where(near, win, 0.0).sum(axis=1)
    return np.where(k > 0, total / np.maximum(k, 1), np.nan)


def metres_from(cum, gap, first):
    """``cum`` (metres up to every scan position) as an object whose first scan is
    position ``first`` sees it: the metres of lost scans right before that scan
    (``gap[first]``), which count to that scan's stretch in ``cum``, are not the
    object's.  Nothing of it was seen there: only an object seen on both sides of
    a stretch (linked across it) spans its metres.  ``gap`` None: ``cum``.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._geometry import metres_from
    >>> cum, gap = np.array([0.0, 1.0, 4.0, 5.0]), np.array([0.0, 2.0, 0.0])
    >>> metres_from(cum, gap, 1).tolist(), metres_from(cum, gap, 0).tolist()
    ([0.0, 3.0, 4.0, 5.0], [0.0, 1.0, 4.0, 5.0])
    """
    if gap is None or not gap[first] > 0:
        return cum
    cum = cum.copy()
    cum[first] += gap[first]
    return cum


def period_and_gap(history, values, window=HISTORY):
    """For every new stamp difference, the scan period (:func:`running_period`) and
    the difference from which scans are lost: ``STAMP_GAP`` periods, or steps of a
    clock coarser than the period (:func:`running_tick`), whichever is larger;
    NaN where unknown.  The detector and the census read lost scans by this rule.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._geometry import period_and_gap
    >>> period, gap = period_and_gap(np.empty(0), np.tile([0.0, 0.0, 0.04], 3))
    >>> round(float(period[-1]), 4), round(float(gap[-1]), 4)
    (0.0133, 0.1)
    """
    tick = running_tick(history, values, window)
    period = running_period(history, values, window, tick=tick)
    return period, STAMP_GAP * np.fmax(period, tick)


def forward_fill(values):
    """Every NaN replaced by the last finite value before it (NaN before any).

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._geometry import forward_fill
    >>> forward_fill(np.array([np.nan, 2.0, np.nan, 3.0])).tolist()
    [nan, 2.0, 2.0, 3.0]
    """
    values = np.asarray(values, dtype=np.float64)
    known = np.where(np.isfinite(values), np.arange(len(values)), 0)
    return values[np.maximum.accumulate(known)] if len(values) else values


def across_lost(before, after):
    """Ego speed (m/s) over a stretch of lost scans: the mean of the speed reported
    by the scan before it and by the scan after it.

    The scans' own reports, not their running medians: a median over the scans
    before lags a start (or a stop) during the lost scans, and gives a car that
    stood before the stretch and drives after it no metres over it.  Under a
    steady acceleration the mean is exact; a single noisy report moves a stretch
    of at most ``max_missing_length`` by half its noise.  NaN where either is
    unknown (the detector then takes the scan's running speed).

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._geometry import across_lost
    >>> across_lost(np.array([0.0, 11.0]), np.array([8.0, 11.0])).tolist()
    [4.0, 11.0]
    """
    return (np.asarray(before, float) + np.asarray(after, float)) / 2


class History:
    """The recent scan periods, ego speeds and tilts of one run (causal medians)."""

    def __init__(self):
        self.periods = np.empty(0)
        self.speeds = np.empty(0)
        self.tilts = np.empty(0)  # known tilts only
        self.kerbs = np.empty(0)  # known kerb depths only
        self.last_speed = np.nan  # the last scan's speed that was known
        self.last_reported = np.nan  # the last speed a scan reported (not a median)
        self.period = np.empty(0)  # scan period (s) of the last new scans
        self.gap = np.empty(0)  # their stamp differences (s) from which scans are lost
        self.across = np.empty(0)  # speed (m/s) over lost scans before the new ones

    def steps(self, periods, speeds, counts=None):
        """Metres travelled per scan: the scan's own speed x the recent period.

        ``periods`` (s) and ``speeds`` (m/s) are per new scan, NaN where unknown;
        a scalar ``speeds`` keeps no speed history (a fixed speed is given instead).
        A scan's speed is the median of its own and the ``SPEED_WINDOW - 1`` before
        it that are known (odometry's noise, no lag: a car that stops advances 0 m
        while it stands, and its full speed again as soon as it drives); a scan
        whose speed and recent ones are unknown (NaN, or negative) keeps the last
        known one.  NaN where no speed is known yet (none given, none before).
        ``counts`` (optional, per new scan) is how many scan numbers its stamp
        difference spans (more than one after missing scans); the period
        (:func:`running_period`) of every new scan is kept in ``period``, and in
        ``across`` the speed over scans lost right before it (:func:`across_lost`).

        Examples
        --------
        >>> import numpy as np
        >>> from tunnelsense.street._geometry import History
        >>> h = History()
        >>> h.steps(np.full(4, 0.1), np.array([10.0, 0.0, 0.0, 0.0])).tolist()
        [1.0, 0.5, 0.0, 0.0]
        """
        if counts is not None:  # a stamp difference over several scan numbers
            periods = periods / counts
        periods = np.where(np.isfinite(periods) & (periods >= 0), periods, np.nan)
        period, gap = period_and_gap(self.periods, periods)
        self.period = np.where(np.isfinite(period), period, DEFAULT_SCAN_PERIOD)
        self.gap = np.where(np.isfinite(gap), gap, STAMP_GAP * self.period)
        self.periods = np.concatenate([self.periods, periods])[-HISTORY:]
        speed = speeds
        if np.isscalar(speeds):
            self.across = np.full(len(periods), float(speeds))
        else:
            speeds = np.where(np.isfinite(speeds) & (speeds >= 0), speeds, np.nan)
            reported = forward_fill(np.concatenate([[self.last_reported], speeds]))
            self.last_reported = reported[-1]
            across = across_lost(reported[:-1], reported[1:])
            speed = running_median(self.speeds, speeds, window=SPEED_WINDOW)
            self.speeds = np.concatenate([self.speeds, speeds])[-SPEED_WINDOW:]
            for i in range(len(speed)):  # unknown: the last known speed
                if np.isfinite(speed[i]):
                    self.last_speed = speed[i]
                else:
                    speed[i] = self.last_speed
            self.across = np.where(np.isfinite(across), across, speed)
        return speed * self.period

    def fill_tilts(self, tilts):
        """Unknown (NaN) tilts become the median of the recent known ones (0 first)."""
        tilts = np.asarray(tilts, dtype=np.float64)
        for i in range(len(tilts)):
            if np.isfinite(tilts[i]):
                self.tilts = np.append(self.tilts[-(HISTORY - 1):], tilts[i])
            else:
                tilts[i] = float(np.median(self.tilts)) if len(self.tilts) else 0.0
        return tilts


    def fill_kerbs(self, kerbs):
        """Every scan's kerb depth: the median of the recent known ones (NaN until
        ``KERB_MIN_SEEN`` are known; ``kerbs`` NaN where a scan shows no kerb step)."""
        out = np.full(len(kerbs), np.nan)
        for i, k in enumerate(np.asarray(kerbs, dtype=np.float64)):
            if np.isfinite(k):
                self.kerbs = np.append(self.kerbs[-(HISTORY - 1):], k)
            if len(self.kerbs) >= KERB_MIN_SEEN:
                out[i] = float(np.median(self.kerbs))
        return out


#: Scans showing a kerb step before the kerb depth is trusted.
KERB_MIN_SEEN = 5
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
