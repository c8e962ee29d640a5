"""The recent scans of a run: scan period, lost scans and ego speed, tilt and kerb.

The distance along the track between two scans is the ego speed times the scan
period (paper section III-C), both taken from the scans seen so far, never from later
ones, so that a stream and a batch run agree: the period from the stamps (a mean that
a clock coarser than the period leaves right, and a stretch of lost scans is left out
of), the speed a running median of the scans' own reports.  Scans whose tilt or kerb
is unknown take the recent known ones.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "DEFAULT_SCAN_PERIOD",
    "DEFAULT_SPEED",
    "History",
    "KERB_MIN_SEEN",
    "SPEED_WINDOW",
    "STAMP_GAP",
    "across_lost",
    "forward_fill",
    "metres_from",
    "period_and_gap",
    "running_median",
    "running_period",
    "running_tick",
]

#: The paper's ego speed (m/s): its measurement vehicle drove at about 40 km/h
#: (``ScanClusterer(speed="paper")``; never assumed for scans without a speed).
DEFAULT_SPEED = 40 / 3.6
#: Scan period (s) assumed when the stamps do not give one yet (75 scans/s).
DEFAULT_SCAN_PERIOD = 1 / 75
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
    >>> from tunnelsense.street._history import running_median
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
    >>> from tunnelsense.street._history import running_tick
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
    >>> from tunnelsense.street._history import running_period
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
    >>> from tunnelsense.street._history import metres_from
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
    >>> from tunnelsense.street._history import period_and_gap
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
    >>> from tunnelsense.street._history import forward_fill
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
    >>> from tunnelsense.street._history import across_lost
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
        >>> from tunnelsense.street._history import History
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
