"""TunnelPositioner: odometry and detected indicators fused into a chainage per frame."""

from __future__ import annotations

import numbers

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.utils.validation import check_is_fitted

from tunnelsense.exceptions import InputFormatError
from tunnelsense.positioning._defaults import SIDE_ERROR
from tunnelsense.positioning._fixes import detection_table
from tunnelsense.positioning._offline import smooth_tour
from tunnelsense.positioning._side import side_code
from tunnelsense.positioning._stream import PositionStream
from tunnelsense.positioning._tables import (
    check_indicator_map,
    check_odometry,
)
from tunnelsense.utils._sklearn_compat import Interval, _fit_context

__all__ = ["TunnelPositioner"]


class TunnelPositioner(BaseEstimator):
    """Chainage of the camera per frame from odometry and detected indicators.

    Dead reckoning integrates the odometry's speed; its error grows with the
    distance driven.  Each emergency-telephone indicator the detector finds stands at
    a surveyed chainage and resets that error.  A 1-D Kalman filter over distance
    holds the chainage and, with ``estimate_scale``, the odometry's scale factor
    (two fixes 200 m apart make a wheel-radius error of a few per cent observable).

    A trajectory's fix is the odometry distance at which its sign passes the camera,
    extrapolated from the growth of its box height (``1 / h`` falls linearly with the
    distance; :func:`estimate_pass`), so it does not matter that the sign leaves the
    image some metres before the pass.  The fix is associated to the nearest
    indicator of the map, and used only when that indicator lies within ``gate``
    standard deviations of the predicted chainage (Mahalanobis gate): a false alarm
    or a trajectory of a missed sign's neighbour is rejected, and the position then
    drifts with the odometry until the next sign.

    Where the tour starts is ``initial_chainage`` (the chainage of the first frame,
    e.g. from GPS at the portal) with its uncertainty ``initial_sigma``.  With
    ``initial_chainage=None`` the start is unknown: the positioner keeps hypotheses
    over which indicator each pass was (the odometry distances between passes must
    match the map's gaps; each pass may also be false) and locks on when one
    explains the passes clearly better than every other (their likelihood, the
    detector assumed to miss signs often); until then its rows have
    ``locked=False`` and no chainage.  A map whose indicators are evenly spaced gives no such cue: there it does not
    lock.  When the gate rejects ``relock_after`` passes in a row (a wrong start),
    it drops its position and locks on again the same way.

    The odometry's scale factor is estimated along the way and written with each
    position (``scale``, ``scale_sigma``); ``initial_scale`` and ``scale_sigma``
    take it from a previous tunnel, so a vehicle starts the next one calibrated.
    Given the camera's focal length and the signs' height, each sign's box growth
    measures the scale too, from the first sign on.

    ``fit`` takes the indicator map; ``predict`` the detections and the odometry
    of one tour.  ``predict`` runs the same stream state as :meth:`start_stream`,
    with each frame's detections pushed with its odometry sample, so both give
    identical positions; with ``smooth`` it then runs the Rauch-Tung-Striebel
    smoother over the whole tour (offline), where the stream is a fixed-lag
    smoother that holds ``window`` frames (online, memory independent of the tour).

    Parameters
    ----------
    estimate_scale : bool, default=True
        Estimate the odometry's scale factor along with the chainage.
    smooth : bool, default=False
        ``predict`` returns the Rauch-Tung-Striebel smoother's estimate given every
        fix (offline) instead of the filter's estimate at each frame (online); the
        stream releases a fixed-lag smoother's estimate.
    initial_chainage : float or None, default=0.0
        Chainage of the first frame (m), e.g. the tunnel entrance from GPS.  The
        default assumes the tour starts at the map's chainage 0 (the portal the map
        is measured from).  None: unknown, lock on from the passes.
    initial_sigma : float, default=1.0
        Its standard deviation (m).
    initial_scale : float, default=1.0
        Prior of the odometry's scale factor (true distance / odometry distance),
        e.g. the ``scale`` a previous tunnel ended with.
    scale_sigma : float, default=0.05
        Prior standard deviation of the odometry's scale factor around
        ``initial_scale``.
    speed_noise : float, default=0.2
        Standard deviation of the odometry's speed noise (m/s).
    scale_drift : float, default=1e-4
        Random walk of the scale factor (1/sqrt(s)).
    fix_sigma : float, default=0.3
        Standard deviation of a fix (m), added to the pass fit's own.
    gate : float, default=4.0
        Largest Mahalanobis distance of an accepted fix (standard deviations).
    min_height : float, default=8.0
        Boxes shorter than this (px) are left out of the pass fit.
    min_detections : int, default=5
        Fewest boxes of a trajectory that gives a fix.
    max_gap : int, default=6
        A trajectory is complete when no box of it came for more than this many
        frames (at least the detector's ``tracks__max_gap``).
    max_extrapolation : float, default=60.0
        Largest odometry distance (m) from a trajectory's last box to its pass.
    focal_length_px : float or None, default=None
        Focal length of the camera (px).  With ``sign_height_m``, a sign's size in
        the image is known: the growth of its box (``1 / h`` falls by ``c / (f H)``
        per metre of odometry) then measures the odometry's scale ``c`` from one
        trajectory (:func:`scale_from_slope`), before a second sign is passed
        (not while locking on without a start: a scale known that well, with a
        missed sign and a false pass among the first passes, can favour a wrong
        place).  None: not known (the scale is then observed from the distances
        between passes alone).
    sign_height_m : float or None, default=None
        Height of the indicators (m), as the detector's boxes measure it.
    size_sigma : float, default=0.03
        Relative standard deviation of ``focal_length_px * sign_height_m`` as the
        detector's boxes see it (the calibration, and how tightly the boxes fit
        the signs: a detector's boxes of far, small signs tend to be a little too
        large, which makes the scale read low), added to each trajectory's own: a
        size believed 2 % off biases the scale by 2 %.
    window : int, default=3000
        Frames the stream holds (100 s at 30 fps): a pass older than this is not
        used, and the fixed-lag smoother releases a frame ``window // 2`` to
        ``window`` frames late.
    lock_margin : float, default=9.0
        Log-likelihood ratio by which the lock's hypothesis must beat every
        hypothesis that puts the vehicle at another place (9: 8000 to 1).
    lock_passes : int, default=3
        Fewest passes the lock's hypothesis explains (two gaps between them).
    miss_rate : float, default=0.4
        Probability that the detector misses an indicator (lock-on scoring),
        deliberately pessimistic: with a missed sign and a false pass near it a
        wrong stretch of the map (its scale a few per cent off) can explain every
        pass, while the right place counts a miss and a false pass; a lock must
        not hinge on the detector never missing.
    false_pass_rate : float, default=0.05
        False passes per km (lock-on scoring): trajectories of something else
        that pass the positioner's own checks (boxes, approach, extrapolation).
    relock_after : int, default=3
        Passes rejected by the gate in a row after which the position is dropped
        and found again by locking on (0: never).
    side_error : float or None, default=0.05
        Probability that the wall a trajectory is seen on
        (:func:`observed_side`, from the boxes' drift as they grow) is the other
        one (lock-on scoring, without a start or at a relock).  Where the map's
        ``side`` column names both walls, a hypothesis that explains a pass by an
        indicator on the other wall pays ``log(e / (1 - e))`` (-2.9 at 0.05:
        never a veto), ``e`` the pass's own error: the normal tail at a third of
        the drift's t statistic (0.16 at 3, as if its standard error were three
        times what the boxes' scatter says), and ``side_error`` once that tail
        falls below it (at 0.05: a drift of 5 standard errors or more).  An
        unknown side, and a pass taken as false, cost nothing.  On a map with one
        wall (or none named) it is not used.
        None (or 0.5): the side is not used.  The rate at which a real
        detector's trajectories misread the wall is not measured: should it be
        higher, give it (the side then counts less), or None.  The side only
        settles what the spacing leaves open (``side_margin``, ``side_passes``).
    side_margin : float, default=0.0
        A lock that the side is needed for (without it the lead is below
        ``lock_margin``) also needs this lead without it: at 0 the side settles
        the place the spacing of the passes already ranks first (or level with
        others), and never lifts a place the spacing puts behind another.  A
        negative value lets the side lift a place the spacing puts behind by up
        to ``-side_margin`` (``-inf``: the side decides alone); a positive one
        asks the spacing for a lead of its own.
    side_passes : int, default=4
        Fewest passes seen (false ones included) before a lock that the side is
        needed for: a wrong stretch matches the walls of three passes by chance
        one time in eight, and a pass more can contradict it.  Locks that the
        spacing alone gives keep ``lock_passes``.

    Attributes
    ----------
    indicator_chainage_ : ndarray of shape (n_indicators,)
        The map's chainages, increasing.
    indicator_ids_ : ndarray of shape (n_indicators,)
        Their ids.
    indicator_side_ : ndarray of shape (n_indicators,)
        Their walls from the map's ``side`` column: -1 left, +1 right, 0 unknown
        (any other entry, or no such column).
    n_indicators_ : int

    Examples
    --------
    >>> from tunnelsense.datasets import (make_tunnel_kinematics, make_tunnel_odometry,
    ...                                   simulate_indicator_detections)
    >>> from tunnelsense.positioning import TunnelPositioner
    >>> truth = make_tunnel_kinematics(1000.0, random_state=0)
    >>> positions, odometry, indicators = make_tunnel_odometry(truth, random_state=0)
    >>> detections = simulate_indicator_detections(truth, random_state=0)
    >>> est = TunnelPositioner().fit(indicators).predict(detections, odometry)
    >>> list(est.columns)
    ['frame', 'stamp', 'chainage', 'sigma', 'locked', 'scale', 'scale_sigma']
    >>> bool(abs(est["chainage"] - positions["chainage"]).iloc[-1] < 1.0)
    True
    """

    _parameter_constraints: dict = {
        "estimate_scale": ["boolean"],
        "smooth": ["boolean"],
        "initial_chainage": [Interval(numbers.Real, None, None, closed="neither"),
                             None],
        "initial_sigma": [Interval(numbers.Real, 0, None, closed="left")],
        "initial_scale": [Interval(numbers.Real, 0.5, 2.0, closed="both")],
        "scale_sigma": [Interval(numbers.Real, 0, 1, closed="both")],
        "speed_noise": [Interval(numbers.Real, 0, None, closed="left")],
        "scale_drift": [Interval(numbers.Real, 0, None, closed="left")],
        "fix_sigma": [Interval(numbers.Real, 0, None, closed="neither")],
        "gate": [Interval(numbers.Real, 0, None, closed="neither")],
        "min_height": [Interval(numbers.Real, 0, None, closed="left")],
        "min_detections": [Interval(numbers.Integral, 2, None, closed="left")],
        "max_gap": [Interval(numbers.Integral, 0, None, closed="left")],
        "max_extrapolation": [Interval(numbers.Real, 0, None, closed="neither")],
        "focal_length_px": [Interval(numbers.Real, 0, None, closed="neither"), None],
        "sign_height_m": [Interval(numbers.Real, 0, None, closed="neither"), None],
        "size_sigma": [Interval(numbers.Real, 0, None, closed="left")],
        "window": [Interval(numbers.Integral, 2, None, closed="left")],
        "lock_margin": [Interval(numbers.Real, 0, None, closed="neither")],
        "lock_passes": [Interval(numbers.Integral, 2, None, closed="left")],
        "miss_rate": [Interval(numbers.Real, 0, 1, closed="neither")],
        "false_pass_rate": [Interval(numbers.Real, 0, None, closed="neither")],
        "relock_after": [Interval(numbers.Integral, 0, None, closed="left")],
        "side_error": [Interval(numbers.Real, 0, 0.5, closed="right"), None],
        "side_margin": [Interval(numbers.Real, None, None, closed="neither")],
        "side_passes": [Interval(numbers.Integral, 2, None, closed="left")],
    }

    def __init__(
        self,
        *,
        estimate_scale=True,
        smooth=False,
        initial_chainage=0.0,
        initial_sigma=1.0,
        initial_scale=1.0,
        scale_sigma=0.05,
        speed_noise=0.2,
        scale_drift=1e-4,
        fix_sigma=0.3,
        gate=4.0,
        min_height=8.0,
        min_detections=5,
        max_gap=6,
        max_extrapolation=60.0,
        focal_length_px=None,
        sign_height_m=None,
        size_sigma=0.03,
        window=3000,
        lock_margin=9.0,
        lock_passes=3,
        miss_rate=0.4,
        false_pass_rate=0.05,
        relock_after=3,
        side_error=SIDE_ERROR,
        side_margin=0.0,
        side_passes=4,
    ):
        self.estimate_scale = estimate_scale
        self.smooth = smooth
        self.initial_chainage = initial_chainage
        self.initial_sigma = initial_sigma
        self.initial_scale = initial_scale
        self.scale_sigma = scale_sigma
        self.speed_noise = speed_noise
        self.scale_drift = scale_drift
        self.fix_sigma = fix_sigma
        self.gate = gate
        self.min_height = min_height
        self.min_detections = min_detections
        self.max_gap = max_gap
        self.max_extrapolation = max_extrapolation
        self.focal_length_px = focal_length_px
        self.sign_height_m = sign_height_m
        self.size_sigma = size_sigma
        self.window = window
        self.lock_margin = lock_margin
        self.lock_passes = lock_passes
        self.miss_rate = miss_rate
        self.false_pass_rate = false_pass_rate
        self.relock_after = relock_after
        self.side_error = side_error
        self.side_margin = side_margin
        self.side_passes = side_passes

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y=None):
        """Take the surveyed indicator map.

        Parameters
        ----------
        X : DataFrame
            The map: ``id, chainage`` (and ``side``), e.g.
            :func:`~tunnelsense.positioning.read_indicator_map`.
        y : None
            Ignored.

        Returns
        -------
        self : TunnelPositioner
        """
        table = check_indicator_map(X, "X (indicator map)")
        self.indicator_chainage_ = table["chainage"].to_numpy(np.float64)
        self.indicator_ids_ = table["id"].to_numpy(np.int64)
        self.indicator_side_ = (side_code(table["side"]) if "side" in table.columns
                                else np.zeros(len(table), np.int64))
        self.n_indicators_ = len(table)
        return self

    def start_stream(self) -> PositionStream:
        """A fresh online state: ``push`` one odometry sample, get its position.

        Examples
        --------
        >>> import pandas as pd
        >>> from tunnelsense.positioning import TunnelPositioner
        >>> pos = TunnelPositioner().fit(pd.DataFrame({"id": [1], "chainage": [50.0]}))
        >>> stream = pos.start_stream()
        >>> stream.push(1, 0.0, 20.0)
        Position(frame=1, stamp=0.0, chainage=0.0, sigma=1.0, locked=True, scale=1.0, scale_sigma=0.05)
        >>> stream.push(2, 0.5, 20.0).chainage
        10.0
        """
        check_is_fitted(self)
        return PositionStream(self)

    def predict(self, detections, odometry, *, return_fixes=False):
        """The chainage of every odometry frame.

        Parameters
        ----------
        detections : DataFrame or sequence of FrameRecord
            The detector's output for the tour: a MOTChallenge results table
            (``frame, id, ..., bb_height, ...``) or the frame records
            ``make_indicator_pipeline().predict`` returns.
        odometry : DataFrame
            ``frame, stamp, speed, yaw_rate`` of the tour.
        return_fixes : bool, default=False
            Also return the fix of every trajectory (where it passed, its indicator,
            whether the gate kept it).

        Returns
        -------
        positions : DataFrame
            ``frame, stamp, chainage, sigma, locked, scale, scale_sigma``: the
            chainage (m) and its standard deviation, whether the position is known
            (without a start: once locked on; chainage and sigma empty before), and
            the odometry's estimated scale factor and its standard deviation.
        fixes : DataFrame
            Only with ``return_fixes``: one row per trajectory; its
            ``attrs["lock_status"]`` says whether and where the stream locked on.
        """
        check_is_fitted(self)
        odometry = check_odometry(odometry)
        table = detection_table(detections)
        frames = table["frame"].to_numpy()
        missing = np.setdiff1d(frames, odometry["frame"].to_numpy())
        if missing.size:
            raise InputFormatError(
                f"detections: frame {missing[0]} has no odometry sample (the odometry "
                "must have a row for every frame with detections)")
        # each frame's detections pushed with its odometry sample (sorted by frame)
        starts = np.searchsorted(frames, odometry["frame"].to_numpy(), side="left")
        ends = np.searchsorted(frames, odometry["frame"].to_numpy(), side="right")
        tracks, heights = table["track_id"].tolist(), table["bb_height"].tolist()
        centres = (table["bb_centre_x"].tolist() if "bb_centre_x" in table.columns
                   else [np.nan] * len(table))
        frames = frames.tolist()
        stream = PositionStream(self, lagged=False, keep_fixes=True)
        f_all = odometry["frame"].tolist()
        t_all, v_all = odometry["stamp"].tolist(), odometry["speed"].tolist()
        for f, t, v, a, b in zip(f_all, t_all, v_all, starts.tolist(), ends.tolist(),
                                 strict=True):
            stream._advance(f, t, v)  # noqa: SLF001 - push without a table per frame
            if b > a:
                stream._add_rows(frames[a:b], tracks[a:b], heights[a:b],  # noqa: SLF001
                                 centres[a:b])
            stream._finish(f)  # noqa: SLF001
        positions = stream.close()
        if self.smooth:
            positions = smooth_tour(self, odometry, stream.fix_list, stream.relocked)
        if not return_fixes:
            return positions
        fixes = stream.fixes
        fixes.attrs["lock_status"] = stream.lock_status()
        return positions, fixes

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.two_d_array = False
        tags.requires_fit = True
        return tags

