"""A parking census: parked vehicles per street segment, by class, with the kerb
occupancy, from an object table and the distance the vehicle drove.

The distance comes from the ego motion (:func:`scan_distances`: the speed of each scan
times its scan period, so a ROS bag's odometry or a run's own speed); the table is
that of :meth:`~tunnelsense.street.ScanClusterer.detect` or ``detect street``.
"""

from __future__ import annotations

import math
import numbers

import numpy as np
import pandas as pd

from tunnelsense.street._clock import STALE_SCANS, period_and_gap
from tunnelsense.street._history import across_lost

__all__ = [
    "CENSUS_CLASSES",
    "CENSUS_COLUMNS",
    "VEHICLE_CLASSES",
    "census",
    "parked_extents",
    "scan_distances",
]

#: The vehicle classes of the ``vehicle_class`` column of an object table.
VEHICLE_CLASSES = ("car", "van", "motorbike")

#: The classes a census counts: a parked object of no class is ``"unclassified"``.
CENSUS_CLASSES = (*VEHICLE_CLASSES, "unclassified")

#: Columns of the table :func:`census` returns.
CENSUS_COLUMNS = (
    "segment",
    "start_m",
    "end_m",
    "kerb_length_m",
    *CENSUS_CLASSES,
    "parked",
    "parked_length_m",
    "occupancy",
)


def scan_distances(stamps, speed):
    """Where along the street each scan's own stretch begins and ends (m).

    Scan ``i`` stands for the stretch the vehicle drives during its scan period:
    ``speed[i] * (stamps[i + 1] - stamps[i])`` metres (the last scan takes the
    period before it). Where the stamps jump by ``2.5`` scan periods, or by 2.5
    steps of a clock coarser than the period, or more (scans lost on the way, read
    as :class:`ScanClusterer` reads them), the scan before the jump keeps one period
    of its own, and the rest of the time is a stretch of no scan, driven at the mean
    of the speeds of the scans on both sides of it: nothing was seen there, so its
    metres belong to no scan, and only an object seen on both sides of it spans
    them. The street is assumed straight and driven forwards (a stop, speed 0, adds
    no distance); the distance starts at 0 where the first scan begins.

    Parameters
    ----------
    stamps : array-like of shape (n_scans,)
        Times of the scans (s), non-decreasing (equal stamps, from a clock coarser
        than the scan period, give a scan no stretch of its own), spanning some
        time; at least two scans.
    speed : float or array-like of shape (n_scans,)
        Ego speed (m/s) of every scan, or of each scan (e.g. interpolated from
        odometry); finite and not negative.

    Returns
    -------
    distances : ndarray of shape (n_scans, 2)
        ``distances[i]``: the start and end of scan ``i``'s stretch; the end of a
        scan is the start of the next, except across lost scans.

    Raises
    ------
    ValueError
        Fewer than two stamps, stamps decreasing, all equal (or all equal after
        the clock's first step: a stale first stamp, then a clock that never
        advances) or not finite, a speed
        negative or not finite, or a speed array of another length.

    Examples
    --------
    >>> from tunnelsense.street import scan_distances
    >>> scan_distances([0.0, 0.1, 0.2], 10.0).tolist()
    [[0.0, 1.0], [1.0, 2.0], [2.0, 3.0]]
    >>> scan_distances([0.0, 0.1, 0.2], [10.0, 20.0, 20.0]).tolist()
    [[0.0, 1.0], [1.0, 3.0], [3.0, 5.0]]
    >>> # scans lost between 0.5 s and 0.9 s: 3 m seen by no scan
    >>> scan_distances([0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.9, 1.0], 10.0)[4:].tolist()
    [[4.0, 5.0], [5.0, 6.0], [9.0, 10.0], [10.0, 11.0]]
    """
    stamps = np.asarray(stamps, dtype=np.float64)
    if stamps.ndim != 1 or len(stamps) < 2:
        raise ValueError(f"stamps must be a 1-D array of at least two scan times; got "
                         f"shape {stamps.shape}")
    periods = np.diff(stamps)
    bad = np.flatnonzero(~(np.isfinite(periods) & (periods >= 0)))
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"stamps must be finite and non-decreasing; scan {i + 1} "
                         f"({stamps[i + 1]}) follows scan {i} ({stamps[i]})")
    if not stamps[-1] > stamps[0]:
        raise ValueError(f"stamps must span some time; all {len(stamps)} are "
                         f"{stamps[0]}")
    after = np.flatnonzero(periods > 0)[0] + 1  # the clock's first step
    if len(stamps) > after + 1 and not stamps[-1] > stamps[after]:
        # a stale first stamp, then a clock that never advances: no period
        raise ValueError(f"stamps must advance after the clock's first step; scans "
                         f"{after} to {len(stamps) - 1} are all {stamps[after]}")
    speed = np.asarray(speed, dtype=np.float64)
    if speed.ndim == 0:
        speed = np.full(stamps.shape, float(speed))
    if speed.shape != stamps.shape:
        raise ValueError(f"speed must be a number or one per scan ({len(stamps)}); got "
                         f"shape {speed.shape}")
    bad = np.flatnonzero(~(np.isfinite(speed) & (speed >= 0)))
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"speed must be finite and not negative (m/s); scan {i} has "
                         f"{speed[i]}")
    own, lost = lost_time(periods)
    own = np.append(own, own[-1])  # the last scan: the period before it
    steps = speed * own
    gaps = across_lost(speed[:-1], speed[1:]) * lost
    starts = np.concatenate([[0.0], np.cumsum(steps[:-1] + gaps)])
    if not np.isfinite(starts[-1] + steps[-1]):
        raise ValueError(f"stamps give no scan period: the clock first advances at "
                         f"scan {after}, too late to read the period of the scans "
                         "before it (a clock stuck over the run's first scans); "
                         "expected the time of every scan (s)")
    return np.column_stack([starts, starts + steps])


def lost_time(periods):
    """Each stamp difference split into the scan's own time and the time of scans
    lost after it (s), by the detector's rule
    (:func:`~tunnelsense.street._clock.period_and_gap`): a difference of
    ``STAMP_GAP`` running scan periods (plus the periods a step after a repeated
    stamp spans beyond its own, or ``STAMP_GAP`` steps of a coarser clock) or more
    keeps a period for each scan it spans and holds lost scans beyond them; the
    others are the scan's own.  Scans that share a stamp (a clock that did not
    advance) share the step after it; at the run's start, before the clock's
    first step, they have at least the run's first period each, as in the
    detector, whether or not the clock catches up after them.

    Examples
    --------
    >>> import numpy as np
    >>> own, lost = lost_time(np.array([0.1, 0.1, 0.1, 0.1, 0.1, 0.5, 0.1]))
    >>> np.round(own, 9).tolist(), np.round(lost, 9).tolist()
    ([0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1], [0.0, 0.0, 0.0, 0.0, 0.0, 0.4, 0.0])
    """
    # as the detector reads them: the first scan's difference is none (NaN)
    period, gap, span = (a[1:] for a in period_and_gap(
        np.empty(0), np.concatenate([[np.nan], periods])))
    with np.errstate(invalid="ignore"):
        jump = periods >= gap
    own = np.where(jump, period * span, periods)
    lost = periods - own
    # a jump at the run's first scans is a stale stamp: no metres of anything
    lost[jump & (np.arange(len(periods)) < STALE_SCANS)] = 0.0
    # the scans that share a stamp share the step after it (a clock that did not
    # advance: each had its part of the time)
    n = len(periods)
    step = np.where(periods != 0, np.arange(n), n)
    step = np.minimum.accumulate(step[::-1])[::-1]  # the step each scan waits for
    has = step < n
    size = np.bincount(step[has], minlength=n)
    shared = np.zeros(n)
    shared[has] = own[step[has]] / size[step[has]]
    # before the clock's first step (and at it) at least a period each, as in the
    # detector: the run's start period, whether or not the clock catches up (it
    # may hold more: the phase of a clock coarser than the period)
    first = int(step[0]) + 1 if n and step[0] > 0 else 0  # 0: no repeated stamp
    shared[:first] = np.where(jump[:first], shared[:first],
                              np.maximum(shared[:first], period[:first]))
    return shared, lost


def _check_distances(distances):
    """``distances`` as the (n_scans, 2) start and end of each scan's stretch, from
    the run's start: (n_scans + 1,) boundaries are scans one after the other."""
    d = np.asarray(distances, dtype=np.float64)
    if d.ndim == 1 and len(d) >= 2:
        d = np.column_stack([d[:-1], d[1:]])
    if d.ndim != 2 or d.shape[1] != 2 or len(d) < 1:
        raise ValueError("distances must be the (n_scans, 2) start and end of each "
                         "scan's stretch (m), as scan_distances returns, or n_scans + 1 "
                         f"scan boundaries, at least two; got shape {d.shape}")
    if (not np.isfinite(d).all() or (d[:, 1] < d[:, 0]).any()
            or (d[1:, 0] < d[:-1, 1]).any()):
        raise ValueError("distances must be finite and non-decreasing (m)")
    if d[-1, 1] <= d[0, 0]:
        raise ValueError("distances cover no length: the vehicle did not move")
    return d - d[0, 0]


def _classes(parked, objects):
    """The census class of each parked row: its ``vehicle_class``, else unclassified."""
    if "vehicle_class" not in objects:
        return np.full(len(parked), "unclassified", dtype=object)
    values = parked["vehicle_class"].fillna("").astype(str).str.strip()
    unknown = ~values.isin(("", *VEHICLE_CLASSES))
    if unknown.any():
        row = parked.index[np.flatnonzero(unknown.to_numpy())[0]]
        raise ValueError(
            f"objects: row {row} has vehicle_class {values[row]!r}; expected one of "
            f"{', '.join(VEHICLE_CLASSES)} or empty (unclassified)")
    return values.where(values != "", "unclassified").to_numpy(dtype=object)


def parked_extents(objects, distances):
    """The parked objects of a table with their stretch of street (m) and class.

    An object seen in scans ``first_scan`` to ``last_scan`` covers the street from
    the start of the first scan's stretch to the end of the last one's: its extent
    comes from the ego motion, not from its ``length`` column, and the metres of
    scans lost right before or after it are not its own.

    Parameters
    ----------
    objects : DataFrame
        An object table with ``first_scan``, ``last_scan`` and ``label`` (only the
        ``"parked"`` rows are kept); its optional ``vehicle_class`` (``"car"``,
        ``"van"``, ``"motorbike"`` or empty) gives the class, and a parked object of
        no class, or every one of a table without the column, is ``"unclassified"``.
        A ``run`` column, if any, must hold one run.
    distances : array-like of shape (n_scans, 2) or (n_scans + 1,)
        The stretch of each scan along the street (m), as :func:`scan_distances`
        returns, or the boundaries of scans one after the other (scan ``i`` from
        ``distances[i]`` to ``distances[i + 1]``).

    Returns
    -------
    parked : DataFrame
        The parked rows with the columns ``start_m``, ``end_m``, ``length_m`` and
        ``vehicle_class`` (a class of :data:`CENSUS_CLASSES`) added.

    Raises
    ------
    ValueError
        A missing column, several runs, scans beyond the distances, a class not
        known, or distances that are not a non-decreasing array covering a length.

    Examples
    --------
    >>> import pandas as pd
    >>> from tunnelsense.street import parked_extents
    >>> objects = pd.DataFrame({"first_scan": [2, 5], "last_scan": [3, 6],
    ...                         "label": ["parked", "passing"]})
    >>> parked_extents(objects, range(9))[["start_m", "end_m", "vehicle_class"]]
       start_m  end_m vehicle_class
    0      2.0    4.0  unclassified
    """
    if not isinstance(objects, pd.DataFrame):
        raise ValueError(f"objects must be a DataFrame (an object table); got "
                         f"{type(objects).__name__}")
    missing = [c for c in ("first_scan", "last_scan", "label") if c not in objects]
    if missing:
        raise ValueError(f"objects lacks column(s) {', '.join(missing)}: expected an "
                         "object table (first_scan, last_scan, label, ...)")
    if "run" in objects and objects["run"].nunique() > 1:
        raise ValueError(f"objects holds {objects['run'].nunique()} runs; a census is "
                         "of one run: select its rows")
    d = _check_distances(distances)
    n_scans = len(d)
    parked = objects[objects["label"] == "parked"].copy()
    first = parked["first_scan"].to_numpy(dtype=np.int64)
    last = parked["last_scan"].to_numpy(dtype=np.int64)
    bad = np.flatnonzero((first < 0) | (last < first) | (last >= n_scans))
    if bad.size:
        row = parked.index[bad[0]]
        raise ValueError(
            f"objects: row {row} spans scans {first[bad[0]]}-{last[bad[0]]}; expected "
            f"0 <= first_scan <= last_scan < {n_scans} (the run's scans)")
    parked["vehicle_class"] = _classes(parked, objects)
    parked["start_m"] = d[first, 0]
    parked["end_m"] = d[last, 1]
    parked["length_m"] = parked["end_m"] - parked["start_m"]
    return parked


def _covered(starts, ends, x):
    """Total length of the intervals ``[starts, ends)`` left of each ``x``."""
    def ramp_sum(points):  # sum over p of max(x - p, 0)
        points = np.sort(points)
        k = np.searchsorted(points, x, side="right")
        below = np.concatenate([[0.0], np.cumsum(points)])[k]
        return k * x - below

    return ramp_sum(starts) - ramp_sum(ends)


def _union(starts, ends):
    """The intervals ``[starts, ends)`` merged where they overlap or touch."""
    if not len(starts):
        return starts, ends
    order = np.argsort(starts, kind="stable")
    starts, ends = starts[order], ends[order]
    reach = np.maximum.accumulate(ends)
    new = np.ones(len(starts), dtype=bool)
    new[1:] = starts[1:] > reach[:-1]
    first = np.flatnonzero(new)
    return starts[first], np.maximum.reduceat(ends, first)


def census(objects, distances, *, segment_length=50.0):
    """Count the parked vehicles per street segment, by class, with the kerb occupancy.

    The street driven (from the start of the first scan to the end of the last) is
    cut into segments of ``segment_length`` metres from its start, the last one
    shorter.  Each parked
    object covers its stretch of :func:`parked_extents` (from the ego motion).  Per
    segment:

    * the vehicles of each class of :data:`CENSUS_CLASSES`, each counted once, in the
      segment that holds the middle of its stretch (so the counts add up to the
      run's parked vehicles); ``unclassified`` holds the parked objects without a
      ``vehicle_class`` (every one of a table without the column);
    * ``parked_length_m``: the parked length inside the segment, an object across a
      boundary split between the segments by length (the sum over segments is the
      parked objects' total length);
    * ``occupancy``: the fraction of the segment's kerb covered by parked vehicles,
      in [0, 1]: overlapping objects (a motorbike on the footway beside a car) cover
      the kerb once.  The kerb is taken to run along the whole segment (driveways
      and junctions are not known), so ``kerb_length_m`` is the segment's length.

    Parameters
    ----------
    objects : DataFrame
        An object table (see :func:`parked_extents`): ``first_scan``,
        ``last_scan``, ``label`` and optionally ``vehicle_class``.
    distances : array-like of shape (n_scans, 2) or (n_scans + 1,)
        The stretch of each scan along the street (m), as :func:`scan_distances`
        returns, or the boundaries of scans one after the other (scan ``i`` from
        ``distances[i]`` to ``distances[i + 1]``).
    segment_length : float, default=50.0
        Length of a segment (m), positive.

    Returns
    -------
    table : DataFrame
        One row per segment, the columns :data:`CENSUS_COLUMNS`.

    Raises
    ------
    ValueError
        As :func:`parked_extents`, or a ``segment_length`` that is not a positive
        finite number.

    Examples
    --------
    >>> import pandas as pd
    >>> from tunnelsense.street import census
    >>> objects = pd.DataFrame({"first_scan": [0, 45], "last_scan": [44, 59],
    ...                         "label": ["parked", "parked"],
    ...                         "vehicle_class": ["van", "car"]})
    >>> distances = [0.1 * i for i in range(1001)]  # 1000 scans of 0.1 m: 100 m
    >>> table = census(objects, distances, segment_length=5.0)
    >>> # the car (4.5-6.0 m) is counted where its middle is, its length split
    >>> table.loc[:1, ["start_m", "van", "car", "parked_length_m", "occupancy"]]
       start_m  van  car  parked_length_m  occupancy
    0      0.0    1    0              5.0        1.0
    1      5.0    0    1              1.0        0.2
    """
    if (isinstance(segment_length, bool) or not isinstance(segment_length, numbers.Real)
            or not math.isfinite(segment_length) or segment_length <= 0):
        raise ValueError(f"segment_length must be a positive number of metres; got "
                         f"{segment_length!r}")
    parked = parked_extents(objects, distances)
    d = _check_distances(distances)
    total = float(d[-1, 1])
    n_segments = max(1, math.ceil(total / segment_length - 1e-9))
    bounds = np.minimum(np.arange(n_segments + 1) * float(segment_length), total)
    bounds[-1] = total
    starts = parked["start_m"].to_numpy()
    ends = parked["end_m"].to_numpy()
    middle = np.clip(((starts + ends) / 2 // segment_length).astype(np.int64), 0,
                     n_segments - 1)
    table = pd.DataFrame({"segment": np.arange(n_segments), "start_m": bounds[:-1],
                          "end_m": bounds[1:]})
    table["kerb_length_m"] = table["end_m"] - table["start_m"]
    classes = parked["vehicle_class"].to_numpy()
    for name in CENSUS_CLASSES:
        table[name] = np.bincount(middle[classes == name], minlength=n_segments)
    table["parked"] = table[list(CENSUS_CLASSES)].sum(axis=1)
    table["parked_length_m"] = np.diff(_covered(starts, ends, bounds))
    u_starts, u_ends = _union(starts, ends)
    covered = np.diff(_covered(u_starts, u_ends, bounds))
    table["occupancy"] = np.clip(covered / table["kerb_length_m"].to_numpy(), 0.0, 1.0)
    return table[list(CENSUS_COLUMNS)]
