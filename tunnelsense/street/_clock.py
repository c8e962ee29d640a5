"""A run's clock: the scan period and the lost scans, read from the scans' stamps.

The scan period is a property of the sensor, read from the data: the mean stamp
difference of the recent scans, leaving out stretches of lost scans (a mean that a
clock coarser than the period leaves right).  Three things a real clock does are
read for what they are:

* **a stamp that repeats** (a clock that did not advance, at a run's start or on a
  clock coarser than the period): the next step holds the time of every scan since
  the stamp last changed (:func:`stamp_spans`), and is no lost scan for it;
* **a run's start**: no period is trusted from fewer than ``START_DIFFERENCES``
  stamp differences, ``MIN_POSITIVE`` of them positive; the first scans take the
  period read where that many are known (:func:`run_start`, a look forward that a
  stream waits for), so a stale first stamp or stamps that repeat at the start
  count as what they are, not as the period;
* **a jump** of ``STAMP_GAP`` periods or more (plus the periods a step after a
  repeated stamp spans beyond its own; or ``STAMP_GAP`` steps of a coarser clock) is a
  stretch of lost scans; within a run's first ``STALE_SCANS + 1`` scans, with
  the scan numbers running on, it is a stale stamp (a driver's buffered scan): the scans
  before it are not linked to the rest and the jump holds no metres.

The detector (``History``) and the census (``scan_distances``) read the stamps by
these rules.  Every value depends on the differences before it (and, at a run's
start, on its first ones) only, so that a stream and a batch run agree.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "DEFAULT_SCAN_PERIOD",
    "HISTORY",
    "MIN_POSITIVE",
    "STALE_SCANS",
    "STAMP_GAP",
    "START_DIFFERENCES",
    "period_and_gap",
    "run_start",
    "running_median",
    "running_period",
    "running_tick",
    "stamp_differences",
    "stamp_spans",
]

#: Scan period (s) assumed when the stamps do not give one (a run of one scan).
DEFAULT_SCAN_PERIOD = 1 / 75
#: Scans over which the scan period and the fallback tilt are medians.
HISTORY = 151
#: Stamp difference (in scan periods) from which consecutive scan numbers are taken
#: to hide lost scans: host-time stamps jitter and are quantised (a 10 ms clock at
#: 75 scans/s gives differences of 0.75 and 1.5 periods), so a difference of up to
#: two periods is read as jitter, not as a lost scan.
STAMP_GAP = 2.5
#: Stamp differences of a run over which its first period is read (the run's first
#: scans take it): a stale first stamp is one of them, not the period.
START_DIFFERENCES = 32
#: Positive stamp differences (the clock advanced) needed to trust a period.
MIN_POSITIVE = 3
#: A stamp jump with fewer stamp differences before it than this (within a run's
#: first four scans), the scan numbers running on, is a stale stamp.
STALE_SCANS = 3


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
    >>> from tunnelsense.street._clock import running_median
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
    >>> from tunnelsense.street._clock import running_tick
    >>> running_tick(np.empty(0), np.array([0.0, 0.0, 0.04, 0.0, 0.0, 0.04])).tolist()
    [nan, nan, 0.04, 0.04, 0.04, 0.04]
    """
    with np.errstate(invalid="ignore"):
        return running_median(np.where(history > 0, history, np.nan),
                              np.where(values > 0, values, np.nan), window)


def stamp_spans(history, values, window=HISTORY):
    """How many scan periods every new stamp difference spans: one, plus the
    differences of 0 right before it (the clock did not advance over them, so its
    next step holds their time too), at most ``window``.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._clock import stamp_spans
    >>> stamp_spans(np.array([0.0]), np.array([0.0, 0.04, 0.01, 0.0, 0.03])).tolist()
    [2, 3, 1, 1, 2]
    """
    full = np.concatenate([history[-(window - 1):], values])
    index = np.arange(len(full))
    last = np.maximum.accumulate(np.where(full == 0, -1, index))
    zeros = index - last  # differences of 0 ending at each
    before = np.concatenate([[0], zeros[:-1]])
    return np.minimum(before, window - 1)[len(full) - len(values):] + 1


def running_period(history, values, window=HISTORY, tick=None, history_spans=None,
                   spans=None):
    """The scan period for every new stamp difference: the mean of the finite ones
    among the last ``window`` (history then values), leaving out those of
    ``STAMP_GAP`` times the mean of all (plus the periods a step after a repeated
    stamp spans beyond its own, :func:`stamp_spans`: the jitter allowance counts
    once), or of ``STAMP_GAP`` stamps' steps (``tick``, by default
    :func:`running_tick`), whichever is larger, or more (a gap over lost scans);
    NaN where there is none.

    A median reads a clock coarser than the period wrong: at 75 scans/s stamps on
    a 10 ms clock differ by 10 ms twice and 20 ms once (and by 0 or 30 ms when they
    also jitter), whose median is 10 ms where the period is 13.3 ms, and every
    length would be a quarter short.  The mean is right for such a clock and for
    stamps that jitter: the time between two stamps is spread over the scans.  On a
    clock of several periods (differences of 0 and 40 ms) the stamps' step keeps
    its own differences in the mean, which would otherwise be 0; after stamps that
    repeat (a clock that stalled), the step that catches up is kept by its span,
    and counts in the window for its scans inside it only.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._clock import running_period
    >>> d = np.array([0.01, 0.02, 0.01, 0.01, 0.02, 0.01])
    >>> np.round(running_period(np.empty(0), d), 4)
    array([0.01  , 0.015 , 0.0133, 0.0125, 0.014 , 0.0133])
    >>> running_period(np.full(5, 0.01), np.array([0.2]), window=6)  # a gap
    array([0.01])
    >>> round(float(running_period(np.empty(0), np.tile([0.0, 0.0, 0.04], 3))[-1]), 4)
    0.0133
    >>> stalled = np.r_[0.0, 0.0, 0.0, 0.04, np.full(5, 0.01)]  # 4 scans, one stamp
    >>> round(float(running_period(np.empty(0), stalled)[-1]), 4)
    0.01
    """
    if tick is None:
        tick = running_tick(history, values, window)
    if history_spans is None:
        history_spans = stamp_spans(np.empty(0), history, window)
    if spans is None:
        spans = stamp_spans(history, values, window)
    win = _windows(history, values, window)
    span = _windows(np.asarray(history_spans, float), np.asarray(spans, float), window)
    finite = np.isfinite(win)
    n = finite.sum(axis=1)
    mean = np.where(finite, win, 0.0).sum(axis=1) / np.maximum(n, 1)
    with np.errstate(invalid="ignore"):
        near = finite & (win < np.fmax(mean[:, None] * (span + STAMP_GAP - 1),
                                       STAMP_GAP * tick[:, None]))
    k = near.sum(axis=1)
    # a step whose repeated stamps began before the window: only its scans inside
    inside = np.minimum(span, np.arange(1, window + 1)) / span
    total = np.where(near, win * inside, 0.0).sum(axis=1)
    return np.where(k > 0, total / np.maximum(k, 1), np.nan)


def stamp_differences(stamps, numbers):
    """A run's stamp differences (s) per scan number they span, NaN for the first
    scan and where the stamps decrease (the detector refuses those).

    Examples
    --------
    >>> from tunnelsense.street._clock import stamp_differences
    >>> stamp_differences([0.0, 0.5, 2.0, 1.5], [0, 1, 4, 5]).tolist()
    [nan, 0.5, 0.5, nan]
    """
    stamps = np.asarray(stamps, dtype=np.float64)
    numbers = np.asarray(numbers, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        periods = np.diff(stamps) / np.maximum(np.diff(numbers), 1)
        periods = np.where(periods >= 0, periods, np.nan)
    return np.concatenate([[np.nan], periods])


def run_start(values, window=HISTORY):
    """Where a run's scan period becomes known, and what it is: ``(position,
    period, tick, ready, trusted, first_step)`` of the run's first stamp
    differences ``values`` (NaN for its first scan).

    The period is read from the clock's first step on (the stamps before it: a
    stale first stamp, or stamps that repeat until the clock first advances, hold
    time of unknown scans), up to the first ``position`` where
    ``START_DIFFERENCES`` differences are known, ``MIN_POSITIVE`` of them positive,
    the last one positive too (whole steps of a clock coarser than the period);
    ``ready`` says whether there is such a position (else it is the last of
    ``values``), ``trusted`` whether ``MIN_POSITIVE`` are known at it.  The period
    and the stamps' step (:func:`running_period`, :func:`running_tick`) read there
    are those of the scans before it.  Only the first ``window`` differences are
    read (a stream waits for no more).  ``first_step`` is the position of the
    clock's first step: no period is ever read from it or the differences before it.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._clock import run_start
    >>> stale = np.r_[np.nan, 1.0, np.full(40, 0.01)]  # first stamp 1 s early
    >>> position, period, tick, ready, trusted, first_step = run_start(stale)
    >>> position, round(float(period), 4), ready
    (33, 0.01, True)
    """
    values = np.asarray(values, dtype=np.float64)[:window]
    if not len(values):
        return -1, np.nan, np.nan, False, False, -1
    with np.errstate(invalid="ignore"):
        steps = np.flatnonzero(values > 0)
    first_step = int(steps[0]) if steps.size else len(values) - 1
    read = values.copy()
    read[:first_step + 1] = np.nan  # from the clock's first step on
    empty = np.empty(0)
    tick = running_tick(empty, read, window)
    period = running_period(empty, read, window, tick=tick)
    known = np.cumsum(np.isfinite(read))
    with np.errstate(invalid="ignore"):
        positive = np.cumsum(read > 0)
        ready = np.flatnonzero((known >= START_DIFFERENCES)
                               & (positive >= MIN_POSITIVE) & (read > 0))
    position = int(ready[0]) if ready.size else len(values) - 1
    return (position, float(period[position]), float(tick[position]), bool(ready.size),
            bool(positive[position] >= MIN_POSITIVE), first_step)


def period_and_gap(history, values, window=HISTORY, *, history_spans=None, start=None,
                   offset=0):
    """For every new stamp difference, the scan period (:func:`running_period`),
    the difference from which scans are lost (the periods it spans,
    :func:`stamp_spans`, plus ``STAMP_GAP - 1`` periods of jitter, or ``STAMP_GAP``
    steps of a clock coarser than the period, :func:`running_tick`, whichever is
    larger; infinite where the period is not trusted) and the periods it spans.  The detector and the census read lost
    scans by this rule.

    ``start`` (:func:`run_start`) gives the period of the run's first scans, those
    before its position, and its first step, from which on the stamps are read
    (``offset`` is the position of the first new value in the run, ``history``
    the differences right before it); without it, ``values`` with no ``history``
    are a run's from its start.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._clock import period_and_gap
    >>> period, gap, _ = period_and_gap(np.empty(0), np.tile([0.0, 0.0, 0.04], 12))
    >>> round(float(period[0]), 4), round(float(gap[-1]), 4)
    (0.0133, 0.1)
    """
    values = np.asarray(values, dtype=np.float64)
    if history_spans is None:
        history_spans = stamp_spans(np.empty(0), history, window)
    if start is None and not len(history) and offset == 0:
        start = run_start(values, window)
    spans = stamp_spans(history, values, window)
    read_history, read = history, values
    if start is not None:  # nothing before the clock's first step is read
        first = np.arange(offset - len(history), offset + len(values)) <= start[5]
        read_history = np.where(first[:len(history)], np.nan, history)
        read = np.where(first[len(history):], np.nan, values)
    tick = running_tick(read_history, read, window)
    period = running_period(read_history, read, window, tick=tick,
                            history_spans=history_spans, spans=spans)
    untrusted = np.zeros(len(values), dtype=bool)
    if start is not None:
        position, first_period, first_tick, _, trusted, _ = start
        early = offset + np.arange(len(values)) <= position
        period[early], tick[early] = first_period, first_tick
        untrusted = early & (not trusted)
    with np.errstate(invalid="ignore"):
        gap = np.where(np.isfinite(period),
                       np.fmax(period * (spans + STAMP_GAP - 1), STAMP_GAP * tick), np.nan)
    return period, np.where(untrusted, np.inf, gap), spans
