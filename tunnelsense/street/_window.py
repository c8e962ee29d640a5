"""The window of a run's scans the online detector holds: scans in, clusters linked.

Every scan is restored, clustered and linked as it arrives (:meth:`ScanWindow.ingest`:
the geometry of ``_geometry``, the clustering of ``_clustering``, the cross-section
evidence of ``_sections``), with the tilt fallback, the scan period and the ego speed
taken from the recent past, never from the future.  The stream drops the scans no
decision needs any more (:meth:`ScanWindow.drop`).
"""

from __future__ import annotations

import numpy as np

from tunnelsense.street._clock import (
    HISTORY,
    STALE_SCANS,
    START_DIFFERENCES,
    run_start,
    stamp_differences,
)
from tunnelsense.street._clustering import concat, link_pairs, single_linkage
from tunnelsense.street._geometry import roi_points
from tunnelsense.street._history import DEFAULT_SPEED, History, metres_from
from tunnelsense.street._objects import HIDDEN_FLAG, SIDE_HEIGHT, SUSPENDED_FLAG
from tunnelsense.street._sections import passed_under, section_evidence

__all__ = ["MIN_RESOLUTION", "SIDE_HEIGHT", "ScanWindow"]

#: Finest depth and height resolution (m) assumed of the returns (range noise).
MIN_RESOLUTION = 0.05


def spray(scan, beam, points, above, below, max_beams, cut, sensor=None, passes=None):
    """Which region-of-interest points are echoes from raindrops or spray.

    A drop returns one beam, seldom two, and the beams around it pass on to the
    surface behind it: a run of at most ``max_beams`` consecutive beams (each
    within ``cut`` of the next) whose beams just below and just above both pass
    farther (nothing within range, ``passes`` (n, 2) for the beams above and
    below, or a return more than ``cut`` farther from the sensor, at height
    ``sensor[scan]`` above the origin, than the run; a dropout says nothing, so
    one of the two must pass and the other pass or drop out; without ``passes``
    every missing return passes) is an echo,
    not an object.  Anything real spans more beams, or has a neighbour beam ending
    on it or in front of it (a roof edge seen over a passing vehicle).

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street._window import spray
    >>> pts = np.array([[1.2, 1.0], [5.0, 0.5], [5.0, 0.6], [5.0, 0.7]])
    >>> beam = np.array([10, 20, 21, 22])
    >>> above = np.array([[6.0, 0.4], [5.0, 0.6], [5.0, 0.7], [np.nan, np.nan]])
    >>> below = np.array([[np.nan, np.nan], [5.0, 0.4], [5.0, 0.5], [5.0, 0.6]])
    >>> spray(np.zeros(4, int), beam, pts, above, below, 2, 0.6).tolist()
    [True, False, False, False]
    """
    n = len(scan)
    if n == 0:
        return np.zeros(0, dtype=bool)
    gap = np.hypot(*(points[1:] - points[:-1]).T)
    link = (scan[1:] == scan[:-1]) & (beam[1:] == beam[:-1] + 1) & (gap <= cut)
    start = concat(True, ~link)
    chain = np.cumsum(start) - 1
    first = np.flatnonzero(start)
    last = concat(first[1:], n) - 1
    h = np.zeros(n) if sensor is None else sensor[scan]

    def rng(p):
        return np.hypot(p[:, 0], p[:, 1] - h)

    far = np.maximum.reduceat(rng(points), first)
    with np.errstate(invalid="ignore"):
        if passes is None:
            past = ((~(rng(below)[first] <= far + cut))
                    & (~(rng(above)[last] <= far + cut)))
        else:  # one side passes; the other passes too or dropped out
            down = passes[first, 1] | (rng(below)[first] > far + cut)
            up = passes[last, 0] | (rng(above)[last] > far + cut)
            past = ((down | np.isnan(below[first, 0]))
                    & (up | np.isnan(above[last, 0])) & (down | up))
    return (past & (last - first + 1 <= max_beams))[chain]


def _start_periods(records):
    """The stamp differences of a run's first scans (:func:`stamp_differences`)."""
    return stamp_differences([r.stamp for r in records], [r.scan for r in records])


class ScanWindow:
    """The held scans of one run and their intra-clusters.

    Scans have absolute positions in the run (``base`` is the first held), clusters
    absolute numbers (``cluster_base`` the first held).

    Parameters
    ----------
    estimator : ScanClusterer
        The fitted detector whose parameters restore and cluster the scans.
    name : str
        The run.
    """

    def __init__(self, estimator, name):
        self.est = estimator
        self.name = name
        self.geometry = None
        self.n_beams = None
        self.last_scan = None
        self.last_stamp = None
        self.n_seen = 0  # scans seen in this run (absolute position of the next)
        self.history = History()
        self.no_period = False  # a short run whose stamps give no period (begin)
        # per held scan
        self.base = 0
        self.records = []
        self.payload = []  # (points, beams, clusters) of every scan
        self.under = []  # (depth, height) the next beam down from every point ends at
        self.scans = np.empty(0, np.int64)
        self.follows = np.empty(0, bool)
        self.near = np.empty(0)  # mean depth of the nearest cluster
        self.cum = np.zeros(1)  # cum[p]: metres from the run's start to scan p
        self.gap = np.empty(0)  # metres of lost scans linked across before scan p
        self.tilt = np.empty(0)
        self.kerb = np.empty(0)  # kerb depth at every scan (NaN: not yet known)
        self.horizon = np.empty((0, 0))  # per scan and depth: see ``horizon``
        self.n_clusters = np.empty(0, np.int64)
        self.first_cluster = np.empty(0, np.int64)  # absolute number of its first
        # per held cluster
        self.cluster_base = 0
        self.position = np.empty(0, np.int64)  # absolute scan position
        self.depth = np.empty(0)
        self.top = np.empty(0)
        self.n_points = np.empty(0)
        self.flags = np.empty(0, np.int8)
        self.side = np.empty(0)  # nearest depth (near side) of every cluster
        self.far = np.empty(0)  # farthest depth of every cluster's body (NaN: none)
        self.occluder = np.empty(0)  # depth the beam below every cluster ends at
        self.object_id = np.empty(0, np.int64)  # 0 not final, -1 final without id
        self.links = (np.empty(0, np.int64), np.empty(0, np.int64))

    @classmethod
    def can_begin(cls, records):
        """Whether a run's first scans ``records`` give its period (or are as many
        as it is read over, ``HISTORY``): the scans before that are held."""
        if len(records) > HISTORY:
            return True
        return run_start(_start_periods(records))[3]

    def begin(self, records):
        """Read the run's scan period from its first scans ``records`` (all it has,
        or those :meth:`can_begin` waited for), before any is ingested.

        Stamps that do not advance after the clock's first step (a stale first
        stamp may come before it) give no period: over more than
        ``START_DIFFERENCES`` scans that is an error; a shorter run (a clock
        coarser than its few scans, or a run of one scan) has no period, and no
        object is built from it (``no_period``): its scans have no metres.  A clock
        that first advances too late in the held scans to read a period there is an
        error too: the scans before its step have no known period (measured at a
        guessed one, a car at 25 scans a second would read a third of its length)."""
        self.no_period = not self.history.begin(_start_periods(records))
        if self.no_period and len(records) > START_DIFFERENCES:
            read = records[:HISTORY + 1]
            stamps = np.array([r.stamp for r in read])
            steps = np.flatnonzero(stamps[1:] != stamps[:-1])
            k = int(steps[-1]) + 1 if steps.size else 0  # first scan on the last stamp
            if len(read) - k > START_DIFFERENCES:  # the stamps do not advance
                raise ValueError(
                    f"stamps of run {self.name!r} do not advance: its scans "
                    f"{read[k].scan} to {read[-1].scan} ({len(read) - k} of its "
                    f"first {len(read)}) are all stamped {stamps[k]}; expected the "
                    "time of every scan (s), which gives the scan period that turns "
                    "scans into metres")
            first = int(steps[0]) + 1  # the clock's first step
            raise ValueError(
                f"stamps of run {self.name!r} give no scan period: its clock first "
                f"advances at scan {read[first].scan}, after {first} scans on one "
                f"stamp, which leaves fewer than {START_DIFFERENCES} stamp differences "
                f"among its first {len(read)} scans to read the period from; expected the "
                "time of every scan (s), which gives the scan period that turns "
                "scans into metres")

    def _check_block(self, block):
        """Validate a block of scans (in scan order, checked by the stream); return
        their scan numbers, periods (stamp differences) and how many scan numbers
        each advances from the previous scan (0 for a run's first)."""
        if self.geometry is None:
            self.geometry, self.n_beams = block[0].geometry, len(block[0].ranges)
            g = self.geometry
            if self.n_beams == 0:
                raise ValueError(f"run {self.name!r}: scans have no beams")
            if not (np.isfinite(g.mount_height) and np.isfinite(g.angle_increment)):
                raise ValueError(f"run {self.name!r}: geometry is not finite: {g}")
        for r in block:
            if len(r.ranges) != self.n_beams:
                raise ValueError(
                    f"scan {r.scan} of run {r.run!r} has {len(r.ranges)} ranges but "
                    f"its run's first scan has {self.n_beams}: expected the same "
                    "number of beams (angles) in every scan of a run")
            if r.geometry != self.geometry:
                raise ValueError(
                    f"scan {r.scan} of run {r.run!r} has another LaserGeometry than "
                    "its run's first scan: expected one geometry per run")
        scans = np.array([r.scan for r in block], dtype=np.int64)
        stamps = np.array([r.stamp for r in block], dtype=np.float64)
        prev = concat(scans[0] - 1 if self.last_scan is None else self.last_scan,
                     scans[:-1])
        prev_stamps = concat(np.nan if self.last_stamp is None else self.last_stamp,
                            stamps[:-1])
        periods = stamps - prev_stamps
        if np.any(periods < 0):
            i = int(np.flatnonzero(periods < 0)[0])
            raise ValueError(
                f"stamps of run {self.name!r} are not sorted: scan {scans[i]} "
                f"({stamps[i]}) comes after scan {prev[i]} ({prev_stamps[i]}); "
                "expected non-decreasing stamps")
        counts = scans - prev
        if self.last_scan is None:
            counts[0] = 0
        self.last_scan, self.last_stamp = int(scans[-1]), float(stamps[-1])
        return scans, periods, counts

    def _missing(self, periods, counts, unit):
        """Whether every new scan follows the previous one (directly, or across a
        stretch of missing scans at most ``max_missing_length`` metres long), and
        the metres of such a stretch before it (0 where none).  Scans are missing
        where the scan numbers jump (the numbers then win over the stamps), or
        where the stamps do by ``STAMP_GAP`` scan periods (plus the periods a
        repeated stamp before it spans, or steps of a clock coarser than the
        period: :func:`~tunnelsense.street._clock.period_and_gap`) or more while
        the numbers do not (a recorder that numbers what it received).  Such a
        jump within the run's first ``STALE_SCANS + 1`` scans is a stale stamp (a
        driver's buffered scan): the scans before it are not followed.  A stretch's metres are the speed over it (:func:`~tunnelsense.street._history.across_lost`:
        the mean of the speeds reported on both sides) times the scan period
        times the scans it spans; ``unit`` (one scan's metres) only where no
        speed is known."""
        period = self.history.period
        with np.errstate(invalid="ignore"):
            jump = (counts == 1) & (periods >= self.history.gap)
            # the scans sharing the stamp before it had a period each already
            by_stamp = np.where(jump, np.maximum(
                np.rint(periods / period) - (self.history.span - 1), 1.0), 1.0)
        # a jump at the run's first scans is a stale stamp: where they were is unknown
        stale = jump & (self.n_seen + np.arange(len(periods)) <= STALE_SCANS)
        elapsed = np.maximum(counts, by_stamp)
        lost = elapsed > 1
        metres = np.where(lost, self.history.across * period * (elapsed - 1), 0.0)
        metres = np.where(np.isfinite(metres), metres, unit * (elapsed - 1))
        bound = self.est.max_missing_length
        follows = elapsed == 1
        if bound is not None:
            follows |= lost & (metres <= bound + 1e-9)
        follows &= (counts > 0) & ~stale
        return follows, np.where(follows & lost, metres, 0.0)

    def ingest(self, block):
        """Restore, cluster and link a block of consecutive scans of the run."""
        est = self.est
        scans, periods, counts = self._check_block(block)
        if isinstance(est.speed, str):  # "paper"
            speeds = DEFAULT_SPEED
        elif est.speed is not None:
            speeds = float(est.speed)
        else:
            speeds = np.array([float(r.payload.get("speed", np.nan)) for r in block])
        step = self.history.steps(periods, speeds, np.maximum(counts, 1))
        follows, gap = self._missing(periods, counts, step)
        step = step + gap  # the metres of a stretch linked across count to its end
        if not np.all(np.isfinite(step)):
            i = int(np.flatnonzero(~np.isfinite(step))[0])
            raise ValueError(
                f"run {self.name!r}, scan {scans[i]}: no ego speed, which turns scan "
                "counts into lengths: the scans carry none (payload \"speed\") and "
                "the detector's speed is None; pass speed=M/S (e.g. speed=11.1 at "
                "40 km/h), or speed=\"paper\" for the paper's 40 km/h")
        ranges = np.stack([np.asarray(r.ranges, dtype=np.float64) for r in block])
        roi = roi_points(ranges, self.geometry, self.history,
                         tilt_compensation=est.tilt_compensation, max_tilt=est.max_tilt,
                         min_height=est.min_height, max_height=est.max_height)
        if est.spray_beams:  # echoes from raindrops and spray build nothing
            keep = ~spray(roi.scan, roi.beam, roi.points, roi.above, roi.below,
                          est.spray_beams, est.cut, roi.sensor, roi.passes)
            roi = roi._replace(scan=roi.scan[keep], beam=roi.beam[keep],
                               points=roi.points[keep], above=roi.above[keep],
                               below=roi.below[keep], passes=roi.passes[keep])
        # intra-scan clusters, numbered over the block
        local = single_linkage(roi.points, est.cut, groups=roi.scan)
        x, y = roi.points[:, 0], roi.points[:, 1]
        n = len(block)
        n_clusters = np.zeros(n, dtype=np.int64)
        np.maximum.at(n_clusters, roi.scan, local + 1)
        start = np.cumsum(n_clusters) - n_clusters
        cluster = start[roi.scan] + local
        k = int(n_clusters.sum())
        position = np.repeat(np.arange(n), n_clusters)
        n_points = np.bincount(cluster, minlength=k)
        depth = np.bincount(cluster, weights=x, minlength=k) / np.maximum(n_points, 1)
        top = np.full(k, -np.inf)
        np.maximum.at(top, cluster, y)
        side = np.full(k, np.inf)  # near side of the body (above kerb and sidewalk)
        body = y >= SIDE_HEIGHT
        np.minimum.at(side, cluster[body], x[body])
        far = np.full(k, -np.inf)
        np.maximum.at(far, cluster[body], x[body])
        far[~np.isfinite(side)] = np.nan
        # what the beam just below every cluster's lowest point ends on (its occluder)
        lowest = np.lexsort((roi.beam, cluster))
        lowest = lowest[concat(True, cluster[lowest][1:] != cluster[lowest][:-1])[
            :len(lowest)]]
        occluder = np.full(k, np.nan)
        occluder[cluster[lowest]] = roi.below[lowest, 0]
        # hanging in the air: lowest point above the clearance, nothing nearer below
        suspended = np.zeros(k, dtype=bool)
        with np.errstate(invalid="ignore"):
            suspended[cluster[lowest]] = ((y[lowest] >= est.min_clearance)
                                          & ~(roi.below[lowest, 0] < x[lowest]))
        roof, wall, raised, hidden = section_evidence(
            x, y, cluster, roi.beam, roi.above, roi.below, n_clusters=k,
            roof_width=est.roof_width, max_height=est.max_height, cut=est.cut,
            min_clearance=est.min_clearance, min_roof_height=est.min_roof_height)
        passed = passed_under(y, cluster, roi.passes[:, 1], n_clusters=k,
                              min_clearance=est.min_clearance)
        flags = (roof.astype(np.int8) | (wall.astype(np.int8) << 1)
                 | (raised.astype(np.int8) << 2) | (hidden.astype(np.int8) << 3)
                 | (passed.astype(np.int8) << 4)
                 | np.where(suspended, SUSPENDED_FLAG, 0).astype(np.int8))
        near = np.full(n, np.inf)
        np.minimum.at(near, position, depth)
        # inter-scan links: the previous scan's clusters against the block's
        first_new = self.cluster_base + len(self.position)
        n_prev = int(self.n_clusters[-1]) if len(self.n_clusters) else 0
        old = slice(len(self.depth) - n_prev, len(self.depth))
        occlusion = {}
        if est.separate_ground:  # the footway never carries a body into what is behind
            occlusion.update(top=concat(self.top[old], top), ground_height=SIDE_HEIGHT)
        if est.object_ends:  # an object's ends: its widest part seen alone
            span_e = np.column_stack([concat(self.side[old], side),
                                      concat(self.far[old], far)])
            span_e[~np.isfinite(span_e[:, 0])] = np.nan
            occlusion.update(top=concat(self.top[old], top), span=span_e,
                             end_tolerance=self.resolution(span_e[:, 1]),
                             suspended=concat(self.flags[old], flags) & SUSPENDED_FLAG > 0)
        if est.beam_occlusion:  # clusters seen past an occluder (lower part hidden)
            span = np.column_stack([concat(self.side[old], side),
                                    concat(self.far[old], far)])
            span[~np.isfinite(span[:, 0])] = np.nan
            occlusion.update(span=span, hidden=concat(
                (self.flags[old] & HIDDEN_FLAG) > 0, hidden),
                occluder=concat(self.occluder[old], occluder))
        earlier, later = link_pairs(
            concat(np.zeros(n_prev, np.int64), position + 1),
            concat(self.depth[old], depth),
            concat(False, follows), est.link_distance, **occlusion)
        absolute = concat(np.arange(first_new - n_prev, first_new),
                         first_new + np.arange(k))
        # append to the window
        bounds = np.searchsorted(roi.scan, np.arange(n + 1))
        for a, b in zip(bounds[:-1], bounds[1:], strict=True):
            self.payload.append((roi.points[a:b], roi.beam[a:b], local[a:b]))
            self.under.append(roi.below[a:b])
        self.records.extend(block)
        self.scans = concat(self.scans, scans)
        self.follows = concat(self.follows, follows)
        self.near = concat(self.near, near)
        self.cum = concat(self.cum, np.cumsum(concat(self.cum[-1], step))[1:])
        self.gap = concat(self.gap, gap)
        self.tilt = concat(self.tilt, roi.tilt)
        self.kerb = concat(self.kerb, self.history.fill_kerbs(roi.kerb))
        self.horizon = (roi.horizon if not len(self.horizon)
                        else np.concatenate([self.horizon, roi.horizon]))
        self.n_clusters = concat(self.n_clusters, n_clusters)
        self.first_cluster = concat(self.first_cluster, first_new + start)
        self.position = concat(self.position, self.n_seen + position)
        self.depth = concat(self.depth, depth)
        self.top = concat(self.top, top)
        self.n_points = concat(self.n_points, n_points.astype(np.float64))
        self.flags = concat(self.flags, flags)
        self.side = concat(self.side, side)
        self.far = concat(self.far, far)
        self.occluder = concat(self.occluder, occluder)
        self.object_id = concat(self.object_id, np.zeros(k, np.int64))
        self.links = (concat(self.links[0], absolute[earlier]),
                      concat(self.links[1], absolute[later]))
        self.n_seen += n

    def metres_from(self, first):
        """``cum`` as an object whose first scan is window position ``first`` sees
        it: the metres of lost scans right before that scan (``gap``), which count
        to its own stretch in ``cum``, are not the object's.  Nothing of it was
        seen there: only an object seen on both sides of a stretch (linked across
        it) spans its metres."""
        return metres_from(self.cum, self.gap, first)

    def resolution(self, depth):
        """Depth and height resolution (m) of the beams at ``depth``: two beam
        spacings, at least ``MIN_RESOLUTION`` (range noise); NaN depth gives it."""
        step = abs(float(self.geometry.angle_increment))
        with np.errstate(invalid="ignore"):
            return np.fmax(2 * step * np.asarray(depth, float), MIN_RESOLUTION)

    def edges(self, positions):
        """Region edges (m) at window ``positions``, shape (n, 2): the detector's
        ``regions``, moved with the kerb seen there when ``follow_kerb``."""
        est = self.est
        edges = np.broadcast_to(est.region_edges_, (len(positions), 2))
        if not est.follow_kerb:
            return edges
        shift = self.kerb[np.asarray(positions, dtype=np.int64)] - est.kerb_depth
        return edges + np.where(np.isfinite(shift), shift, 0.0)[:, None]

    def drop(self, d):
        """Drop the oldest ``d`` scans and their clusters."""
        self.base += d
        del self.records[:d]
        del self.payload[:d]
        del self.under[:d]
        for name in ("scans", "follows", "near", "cum", "gap", "tilt", "kerb", "horizon",
                     "n_clusters",
                     "first_cluster"):
            setattr(self, name, getattr(self, name)[d:])
        dropped = (int(self.first_cluster[0]) - self.cluster_base
                   if len(self.first_cluster) else len(self.position))
        if dropped > 0:
            self.cluster_base += dropped
            for name in ("position", "depth", "top", "n_points", "flags", "side",
                         "far", "occluder", "object_id"):
                setattr(self, name, getattr(self, name)[dropped:])
            keep = self.links[0] >= self.cluster_base
            self.links = (self.links[0][keep], self.links[1][keep])
