"""The recent scans of a run: scan period, lost scans and ego speed, tilt and kerb.

The distance along the track between two scans is the ego speed times the scan
period (paper section III-C), both taken from the scans seen so far (a run's first
scans take the period of its first stamp differences, which a stream waits for:
``_clock``), never from later ones, so that a stream and a batch run agree: the
period from the stamps (a mean that a clock coarser than the period leaves right,
and a stretch of lost scans is left out of), the speed a running median of the
scans' own reports.  Scans whose tilt or kerb is unknown take the recent known ones.
"""

from __future__ import annotations

import numpy as np

from tunnelsense.street._clock import (
    DEFAULT_SCAN_PERIOD,
    HISTORY,
    STAMP_GAP,
    period_and_gap,
    run_start,
    running_median,
)

__all__ = [
    "DEFAULT_SPEED",
    "History",
    "KERB_MIN_SEEN",
    "SPEED_WINDOW",
    "across_lost",
    "forward_fill",
    "metres_from",
]

#: The paper's ego speed (m/s): its measurement vehicle drove at about 40 km/h
#: (``ScanClusterer(speed="paper")``; never assumed for scans without a speed).
DEFAULT_SPEED = 40 / 3.6
#: Scans over which the ego speed of the scans' payload is a median (a scan and the
#: ones just before it: against odometry's noise, without lagging across a stop).
SPEED_WINDOW = 5


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
        self.spans = np.empty(0)  # the periods every one of ``periods`` spans
        self.n = 0  # stamp differences seen in the run (position of the next scan)
        self.start = None  # the period of the run's first scans (``begin``)
        self.speeds = np.empty(0)
        self.tilts = np.empty(0)  # known tilts only
        self.kerbs = np.empty(0)  # known kerb depths only
        self.last_speed = np.nan  # the last scan's speed that was known
        self.last_reported = np.nan  # the last speed a scan reported (not a median)
        self.period = np.empty(0)  # scan period (s) of the last new scans
        self.gap = np.empty(0)  # their stamp differences (s) from which scans are lost
        self.span = np.empty(0)  # the scan periods their stamp differences span
        self.across = np.empty(0)  # speed (m/s) over lost scans before the new ones

    def begin(self, periods):
        """Read the period of the run's first scans from its first stamp differences
        ``periods`` (s, NaN for the first scan; :func:`~tunnelsense.street._clock.run_start`);
        return whether they give one (they do not if the stamps do not advance
        after the clock's first step, or a run has one scan)."""
        self.start = run_start(periods)
        return bool(np.isfinite(self.start[1]))

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
        (:func:`~tunnelsense.street._clock.period_and_gap`; the run's first scans
        take the one :meth:`begin` read) of every new scan is kept in ``period``,
        the difference from which scans are lost in ``gap``, the periods its stamp
        difference spans in ``span``, and in ``across`` the speed over scans lost
        right before it (:func:`across_lost`).

        Examples
        --------
        >>> import numpy as np
        >>> from tunnelsense.street._history import History
        >>> h = History()
        >>> np.round(h.steps(np.full(4, 0.1), np.array([10.0, 0.0, 0.0, 0.0])), 9).tolist()
        [1.0, 0.5, 0.0, 0.0]
        """
        if counts is not None:  # a stamp difference over several scan numbers
            periods = periods / counts
        periods = np.where(np.isfinite(periods) & (periods >= 0), periods, np.nan)
        period, gap, span = period_and_gap(self.periods, periods,
                                           history_spans=self.spans, start=self.start,
                                           offset=self.n)
        self.period = np.where(np.isfinite(period), period, DEFAULT_SCAN_PERIOD)
        self.gap = np.where(np.isnan(gap), STAMP_GAP * self.period, gap)
        self.span = span
        self.periods = np.concatenate([self.periods, periods])[-HISTORY:]
        self.spans = np.concatenate([self.spans, span])[-HISTORY:]
        self.n += len(periods)
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
