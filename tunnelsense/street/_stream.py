"""The street detector's online state machine: scans in one at a time, objects out.

:class:`ScanStream` is what :meth:`ScanClusterer.start_stream` returns, and what
:meth:`ScanClusterer.transform`, :meth:`~ScanClusterer.predict` and
:meth:`~ScanClusterer.detect` run over every run, so that streaming and batch give
identical results by construction: the decisions below never depend on *when* they are
taken (after every scan, or once at the end of a run), only on the scans seen.

How it bounds memory
--------------------
Every scan is restored, clustered and linked as it arrives (per-scan work, with the
tilt fallback and the scan period taken from the recent past, never from the future).
The state keeps a *window* of scans: those not yet released plus a short history.
An object-cluster (a component of the fragments the three-region merge joins) is
**final** once no fragment of it can link or merge with anything still to come:

* none of its fragments has a cluster in the newest scan (linking is scan to scan);
* no fragment still growing, or starting later, can join one of its fragments: a
  later fragment starts farther than ``max_length + merge_gap`` from it, or after a
  gap longer than ``merge_gap`` that is not hidden in every scan by something nearer,
  or after a missing scan;
* enough scans follow it (``max(min_length, occluded_length)`` metres) to tell
  whether its ends are hidden by an occluder.

A final object-cluster is split and labelled at once (exactly as in batch: these steps
look only at the object's own scans and their near neighbours).  Objects are numbered
in the order of their first scan (then mean depth), so an object gets its id once no
object that is not yet final can start before it; a scan's record is released once
every object in it has its id and no later object can be extended over it (the
occlusion extension reaches at most ``occluded_length`` back).  Memory therefore
follows the longest object in view (plus a few metres), not the run's length.

An object-cluster the merge keeps joining (a kerb, hedge or facade bridged behind
passing vehicles) would never become final; so at every ``_CHECK_EVERY``-th scan of a
run (absolute positions, the same in batch, where the scans are ingested up to each
check), an object-cluster that is not final and reaches back more than
``max_pending_length`` metres (at least ``max_length`` in a region labelled as
vehicles) is closed up to that scan as if it ended there; what links to it later
starts a new object-cluster.  The check sees exactly the scans up to it whatever the
chunking, so the memory is bounded by about ``max_pending_length`` plus a check
interval, and streaming still equals batch.
"""

from __future__ import annotations

import numpy as np

from tunnelsense._records import RUN_LABELS
from tunnelsense.street._clustering import _ranges_expand, _single_linkage_groups
from tunnelsense.street._restoration import (
    compensate_tilt,
    estimate_tilt,
    no_return,
    restore_points,
)
from tunnelsense.street._roi import roi_mask
from tunnelsense.street._sections import section_evidence

__all__ = ["ScanStream"]

_BODY = 0b0111  # bits of the per-cluster evidence flags: roof, wall, raised
#: Shortest visible part (m) of a vehicle cut short by an occluder.
_MIN_VISIBLE = 0.5
#: Ego speed (m/s) assumed when neither the parameter nor the scans give one:
#: the paper's measurement vehicle drove at about 40 km/h.
DEFAULT_SPEED = 40 / 3.6
#: Scan period (s) assumed when the stamps do not give one yet (75 scans/s).
DEFAULT_SCAN_PERIOD = 1 / 75
#: Scans over which the scan period, the ego speed and the fallback tilt are medians.
_HISTORY = 151
#: Every this many scans of a run (absolute positions), object-clusters pending for
#: longer than ``max_pending_length`` are closed (the same scans in batch and online).
_CHECK_EVERY = 64


def _cat(*parts):
    """``np.r_`` of 1-d arrays and scalars, without its per-call indexing overhead."""
    return np.concatenate([np.atleast_1d(p) for p in parts])


def _running_median(history, values, window=_HISTORY):
    """Median of the finite values among the last ``window`` (history then values),
    for every new value; NaN where there is none."""
    full = np.concatenate([np.full(window - 1, np.nan), history[-(window - 1):], values])
    full = full[-(len(values) + window - 1):]
    win = np.lib.stride_tricks.sliding_window_view(full, window)
    srt = np.sort(win, axis=1)  # NaN last
    k = np.isfinite(win).sum(axis=1)
    rows = np.arange(len(values))
    lo = srt[rows, np.maximum((k - 1) // 2, 0)]
    hi = srt[rows, np.maximum(k // 2, 0)]
    return np.where(k > 0, (lo + hi) / 2, np.nan)


def _hidden_ends(near, follows, first, last, depth, cum, cap, ended):
    """Scans right before ``first`` and after ``last`` (within one stretch of
    consecutive scans) whose nearest cluster is nearer than ``depth``; each walk stops
    once it covers ``cap`` metres (no decision looks farther)."""
    n = len(near)
    before = 0
    p = first - 1
    while (p >= 0 and follows[p + 1] and near[p] < depth
           and cum[first] - cum[p + 1] < cap):
        before += 1
        p -= 1
    after = 0
    p = last + 1
    while p < n and follows[p] and near[p] < depth and cum[p] - cum[last + 1] < cap:
        after += 1
        p += 1
    return before, after


class _Profiles:
    """Per object-cluster aggregates and per-(object, scan) profiles."""

    def __init__(self, cobj, cpos, cdepth, ctop, w, cflag=None):
        self.cpos = cpos
        self.p_flag = np.empty(0, dtype=np.int8)
        n = int(cobj.max()) + 1 if len(cobj) else 0
        self.n = n
        if n == 0:
            e = np.empty(0, dtype=np.int64)
            self.p_obj = self.p_pos = self.first = self.last = e
            self.rows = np.zeros(1, dtype=np.int64)
            self.p_top = self.start_depth = self.end_depth = np.empty(0)
            self.pts = self.depth = self.top = np.empty(0)
            return
        order = np.lexsort((cpos, cobj))
        so, sp = cobj[order], cpos[order]
        # one row per (object, scan)
        key_new = _cat(True, (so[1:] != so[:-1]) | (sp[1:] != sp[:-1]))
        starts = np.flatnonzero(key_new)
        sw = w[order]
        pw = np.add.reduceat(sw, starts)
        pdepth = np.add.reduceat(sw * cdepth[order], starts) / np.maximum(pw, 1)
        ptop = np.maximum.reduceat(ctop[order], starts)
        pobj, ppos = so[starts], sp[starts]
        if cflag is not None:
            self.p_flag = np.bitwise_or.reduceat(cflag[order], starts)
        self.p_obj, self.p_pos, self.p_top = pobj, ppos, ptop
        obj_new = _cat(True, pobj[1:] != pobj[:-1])
        ofirst_row = np.flatnonzero(obj_new)
        olast_row = _cat(ofirst_row[1:], len(pobj)) - 1
        self.rows = _cat(ofirst_row, len(pobj))
        self.first = ppos[ofirst_row]
        self.last = ppos[olast_row]
        self.start_depth = pdepth[ofirst_row]
        self.end_depth = pdepth[olast_row]
        self.pts = np.bincount(cobj, weights=w, minlength=n)
        self.depth = np.bincount(cobj, weights=w * cdepth, minlength=n) / np.maximum(
            self.pts, 1
        )
        self.top = np.maximum.reduceat(ptop, ofirst_row)

    def scan_profile(self, o):
        a, b = self.rows[o], self.rows[o + 1]
        return self.p_pos[a:b], self.p_top[a:b]

    def scan_flags(self, o):
        return self.p_flag[self.rows[o]:self.rows[o + 1]]


def _components(n, a, b):
    """Connected components of the graph of ``n`` nodes and edges ``a - b``: a label
    per node (the smallest node of its component).

    Hooking and pointer jumping in NumPy: a few passes even for long chains (the
    links of a fragment join consecutive scans), without SciPy's sparse-matrix set-up
    cost, which dominates on the small graphs of a single scan's decision.
    """
    lab = np.arange(n)
    if len(a) == 0:
        return lab
    while True:
        la, lb = lab[a], lab[b]
        diff = la != lb
        if not diff.any():
            return lab
        la, lb = la[diff], lb[diff]
        lo = np.minimum(la, lb)
        np.minimum.at(lab, la, lo)  # hook the larger root under the smaller label
        np.minimum.at(lab, lb, lo)
        while True:  # pointer jumping: every node to its root
            nxt = lab[lab]
            if np.array_equal(nxt, lab):
                break
            lab = nxt


class ScanStream:
    """Online state of a fitted :class:`~tunnelsense.street.ScanClusterer`.

    Feed scans with :meth:`push` (or :meth:`push_many`), in increasing scan order per
    run (a new run name starts that run afresh); finished records come back in input
    order, with the payload of :meth:`ScanClusterer.transform` plus ``"in_view"``, the
    ``(k, 2)`` array ``(object id, label code)`` of :meth:`ScanClusterer.predict`.
    :meth:`pop_objects` returns the object-table rows finished so far, in id order.

    Parameters
    ----------
    estimator : ScanClusterer
        A fitted detector.
    """

    def __init__(self, estimator):
        self.est = estimator
        self._next_id = 0
        self._run = None
        self._rows = []
        self.max_window = 0  # largest number of scans held at once (for tests)

    # ---------------------------------------------------------------- input
    def push(self, record):
        """Take the next scan; return the records finished by it (maybe none)."""
        return self.push_many([record])

    def push_many(self, records):
        """Take consecutive scans at once (same result as pushing them one by one)."""
        out = []
        i, n = 0, len(records)
        while i < n:
            name = records[i].run
            j = i + 1
            while j < n and records[j].run == name:
                j += 1
            if self._run is None or self._run.name != name:
                if self._run is not None:
                    out.extend(self._run.decide(ended=True))
                self._run = _RunState(self, name)
            run = self._run
            k = i
            while k < j:  # ingest up to each check (every _CHECK_EVERY scans)
                stop = min(j, k + _CHECK_EVERY - run.n_seen % _CHECK_EVERY)
                run.ingest(records[k:stop])
                k = stop
                if run.n_seen % _CHECK_EVERY == 0 and run.overdue_possible():
                    out.extend(run.decide(ended=False, check=True))
                    self.max_window = max(self.max_window, run.n_held)
            if run.decided_at != run.n_seen:
                out.extend(run.decide(ended=False))
            self.max_window = max(self.max_window, run.n_held)
            i = j
        return out

    def close(self):
        """End of the stream: return the records still held."""
        if self._run is None:
            return []
        out = self._run.decide(ended=True)
        self._run = None
        return out

    def pop_objects(self):
        """Object-table rows finished since the last call (tuples, in id order).

        Each row holds the values of :data:`~tunnelsense.street.OBJECT_COLUMNS`.
        """
        rows, self._rows = self._rows, []
        return rows


class _RunState:
    """Window of one run's scans, clusters and pending objects."""

    def __init__(self, stream, name):
        self.stream = stream
        self.est = est = stream.est
        self.name = name
        self.geom = None
        self.nb = None
        self.last_scan = None
        self.last_stamp = None
        self.n_seen = 0  # scans seen in this run (absolute position of the next)
        self.decided_at = -1  # n_seen at the last decision
        # histories for the causal medians
        self.h_dt = np.empty(0)
        self.h_speed = np.empty(0)
        self.h_tilt = np.empty(0)  # known tilts (the last _HISTORY)
        # window of scans: absolute positions base .. base + len - 1
        self.base = 0
        self.recs = []
        self.scans = np.empty(0, np.int64)
        self.follows = np.empty(0, bool)
        self.near = np.empty(0)
        self.cum = np.zeros(1)  # cum[p] - cum[0]: metres from the run's start to scan p
        self.tilt = np.empty(0)
        self.payload = []  # per scan (points, beams, local)
        self.n_cl = np.empty(0, np.int64)
        self.cl_start = np.empty(0, np.int64)  # absolute cluster number of the first
        # clusters: absolute numbers cbase .. cbase + len - 1
        self.cbase = 0
        self.c_pos = np.empty(0, np.int64)
        self.c_depth = np.empty(0)
        self.c_top = np.empty(0)
        self.c_w = np.empty(0)
        self.c_flag = np.empty(0, np.int8)
        self.c_oid = np.empty(0, np.int64)  # object id; 0 not final, -1 no id yet
        self.e_a = np.empty(0, np.int64)  # inter-scan links (absolute cluster numbers)
        self.e_b = np.empty(0, np.int64)
        self.queue = []  # final objects waiting for their id, sorted by key
        self.numbered = []  # (region, last) of numbered vehicles still near
        self.spans = []  # (first, last, id, code) of numbered objects not yet released
        self.released = 0  # absolute position of the next scan to release
        self.reach = est.max_length + est.merge_gap
        self.cap = (max(est.min_length, est.occluded_length)
                    if est.occluded_length is not None else 0.0)

    @property
    def n_held(self):
        return len(self.recs)

    # --------------------------------------------------------- per-scan work
    def ingest(self, block):
        est = self.est
        if self.geom is None:
            self.geom, self.nb = block[0].geometry, len(block[0].ranges)
            if self.nb == 0:
                raise ValueError(f"run {self.name!r}: scans have no beams")
            g = self.geom
            if not (np.isfinite(g.mount_height) and np.isfinite(g.angle_increment)):
                raise ValueError(f"run {self.name!r}: geometry is not finite: {g}")
        geom, nb = self.geom, self.nb
        first_scan = self.last_scan
        for r in block:
            if len(r.ranges) != nb:
                raise ValueError(
                    f"scan {r.scan} of run {r.run!r} has {len(r.ranges)} ranges but "
                    f"its run's first scan has {nb}: expected the same number of "
                    "beams (angles) in every scan of a run"
                )
            if r.geometry != geom:
                raise ValueError(
                    f"scan {r.scan} of run {r.run!r} has another LaserGeometry than "
                    "its run's first scan: expected one geometry per run"
                )
        scans = np.array([r.scan for r in block], dtype=np.int64)
        stamps = np.array([r.stamp for r in block], dtype=np.float64)
        prev_s = _cat(scans[0] - 1 if first_scan is None else first_scan, scans[:-1])
        if np.any(scans <= prev_s):
            i = int(np.flatnonzero(scans <= prev_s)[0])
            raise ValueError(
                f"scan {scans[i]} of run {self.name!r} comes after scan {prev_s[i]}: "
                "expected each (run, scan) once, in increasing scan order"
            )
        prev_t = _cat(np.nan if self.last_stamp is None else self.last_stamp,
                       stamps[:-1])
        dt = stamps - prev_t
        if np.any(dt < 0):
            i = int(np.flatnonzero(dt < 0)[0])
            raise ValueError(
                f"stamps of run {self.name!r} are not sorted: scan {scans[i]} "
                f"({stamps[i]}) comes after scan {prev_s[i]} ({prev_t[i]}); expected "
                "non-decreasing stamps"
            )
        follows = scans == prev_s + 1
        if first_scan is None:
            follows[0] = False
        self.last_scan, self.last_stamp = int(scans[-1]), float(stamps[-1])
        # metres travelled per scan: recent median ego speed x recent median period
        dt = np.where(np.isfinite(dt) & (dt > 0), dt, np.nan)
        period = _running_median(self.h_dt, dt)
        self.h_dt = _cat(self.h_dt, dt)[-_HISTORY:]
        if est.speed is not None:
            speed = np.full(len(block), float(est.speed))
        else:
            v = np.array([float(r.payload.get("speed", np.nan)) for r in block])
            v = np.where(np.isfinite(v) & (v > 0), v, np.nan)
            speed = _running_median(self.h_speed, v)
            self.h_speed = _cat(self.h_speed, v)[-_HISTORY:]
        step = (np.where(np.isfinite(speed), speed, DEFAULT_SPEED)
                * np.where(np.isfinite(period), period, DEFAULT_SCAN_PERIOD))
        # restoration and tilt compensation
        ranges = np.stack([np.asarray(r.ranges, dtype=np.float64) for r in block])
        r = np.where(no_return(ranges, geom.range_min, geom.range_max), np.nan, ranges)
        angles = geom.angles(nb)
        if est.tilt_compensation:
            t, off = estimate_tilt(r, angles, geom.mount_height, max_tilt=est.max_tilt,
                                   tolerance=est.min_height)
            t = np.asarray(t, dtype=np.float64)
            for i in range(len(t)):  # unknown: median of the recent known tilts
                if np.isfinite(t[i]):
                    self.h_tilt = _cat(self.h_tilt[-(_HISTORY - 1):], t[i])
                else:
                    t[i] = float(np.median(self.h_tilt)) if len(self.h_tilt) else 0.0
            depth, height, t = compensate_tilt(r, angles, geom.mount_height, t, off)
        else:
            t = np.zeros(len(r))
            depth, height = restore_points(r, angles, geom.mount_height)
        m = roi_mask(depth, height, min_height=est.min_height, max_height=est.max_height)
        rows, cols = np.nonzero(m)
        x, y = depth[rows, cols], height[rows, cols]
        up, dn = np.minimum(cols + 1, nb - 1), np.maximum(cols - 1, 0)
        above = np.column_stack([depth[rows, up], height[rows, up]])
        above[cols + 1 >= nb] = np.nan
        below = np.column_stack([depth[rows, dn], height[rows, dn]])
        below[cols == 0] = np.nan
        # intra-scan clusters
        local = _single_linkage_groups(x, y, rows, float(est.cut))
        n = len(block)
        n_cl = np.zeros(n, dtype=np.int64)
        if len(rows):
            np.maximum.at(n_cl, rows, local + 1)
        cl0 = np.cumsum(n_cl) - n_cl
        cid = cl0[rows] + local
        k = int(n_cl.sum())
        cpos = np.repeat(np.arange(n), n_cl)
        npts = np.bincount(cid, minlength=k)
        cdepth = np.bincount(cid, weights=x, minlength=k) / np.maximum(npts, 1)
        ctop = np.full(k, -np.inf)
        np.maximum.at(ctop, cid, y)
        roof, wall, raised, hidden = section_evidence(
            x, y, cid, cols, above, below, n_clusters=k, roof_width=est.roof_width,
            max_height=est.max_height, cut=est.cut, min_clearance=est.min_clearance)
        cflag = (roof.astype(np.int8) | (wall.astype(np.int8) << 1)
                 | (raised.astype(np.int8) << 2) | (hidden.astype(np.int8) << 3))
        near = np.full(n, np.inf)
        if k:
            np.minimum.at(near, cpos, cdepth)
        # inter-scan links: every cluster against the previous scan's clusters
        c_abs0 = self.cbase + len(self.c_pos)
        prev_n = _cat(self.n_cl[-1] if len(self.n_cl) else 0, n_cl[:-1])
        prev_start = _cat(self.cl_start[-1] if len(self.cl_start) else 0,
                           c_abs0 + cl0[:-1])
        cnt = np.where(follows, prev_n, 0)[cpos]
        pb, owner = _ranges_expand(prev_start[cpos], cnt)
        all_depth = _cat(self.c_depth, cdepth)
        ea = pb
        eb = c_abs0 + owner
        good = np.abs(all_depth[ea - self.cbase] - all_depth[eb - self.cbase]) < (
            est.link_distance)
        # append to the window
        pts = np.column_stack([x, y])
        bounds = np.searchsorted(rows, np.arange(n + 1))
        for i in range(n):
            a, b = bounds[i], bounds[i + 1]
            self.payload.append((pts[a:b], cols[a:b], local[a:b]))
        self.recs.extend(block)
        self.scans = _cat(self.scans, scans)
        self.follows = _cat(self.follows, follows)
        self.near = _cat(self.near, near)
        self.cum = _cat(self.cum, np.cumsum(_cat(self.cum[-1], step))[1:])
        self.tilt = _cat(self.tilt, t)
        self.n_cl = _cat(self.n_cl, n_cl)
        self.cl_start = _cat(self.cl_start, c_abs0 + cl0)
        self.c_pos = _cat(self.c_pos, self.n_seen + cpos)
        self.c_depth = all_depth
        self.c_top = _cat(self.c_top, ctop)
        self.c_w = _cat(self.c_w, npts.astype(np.float64))
        self.c_flag = _cat(self.c_flag, cflag)
        self.c_oid = _cat(self.c_oid, np.zeros(k, np.int64))
        self.e_a = _cat(self.e_a, ea[good])
        self.e_b = _cat(self.e_b, eb[good])
        self.n_seen += n

    # ------------------------------------------------------------- decisions
    def overdue_possible(self):
        """Whether an object-cluster may be pending for longer than
        ``max_pending_length`` (its oldest cluster that is not final is that old)."""
        limit = self.est.max_pending_length
        if limit is None:
            return False
        act = np.flatnonzero(self.c_oid == 0)
        if not len(act):
            return False
        p0 = int(self.c_pos[act[0]]) - self.base
        return bool(self.cum[len(self.recs)] - self.cum[p0] > limit)

    def decide(self, *, ended, check=False):
        """Finalize, number and release what the scans seen so far allow.

        With ``check`` (at every ``_CHECK_EVERY``-th scan), object-clusters pending for
        longer than ``max_pending_length`` are closed as one object up to the newest
        scan; a continuation starts a new object-cluster.
        """
        est = self.est
        self.decided_at = self.n_seen
        n = len(self.recs)
        if n == 0:
            return []
        base, cum, near, follows = self.base, self.cum, self.near, self.follows
        act = np.flatnonzero(self.c_oid == 0)
        frontier = np.inf if ended else self.n_seen  # no non-final object starts before
        if len(act):
            lookup = np.full(len(self.c_oid), -1, dtype=np.int64)
            lookup[act] = np.arange(len(act))
            ea, eb = lookup[self.e_a - self.cbase], lookup[self.e_b - self.cbase]
            keep = (ea >= 0) & (eb >= 0)
            frag = _components(len(act), ea[keep], eb[keep])
            _, firsts, frag = np.unique(frag, return_index=True, return_inverse=True)
            renum = np.empty(len(firsts), dtype=np.int64)
            renum[np.argsort(firsts)] = np.arange(len(firsts))
            frag = renum[frag.ravel()]
            cpos = self.c_pos[act] - base
            cdepth, ctop, w = self.c_depth[act], self.c_top[act], self.c_w[act]
            prof = _Profiles(frag, cpos, cdepth, ctop, w)
            parent = est._merge(prof, near, cum, follows)
            final = self._final_fragments(prof, parent, ended)
            comp_final = np.ones(prof.n, dtype=bool)
            np.logical_and.at(comp_final, parent, final)
            if check and est.max_pending_length is not None:
                comp_first = np.full(prof.n, n, dtype=np.int64)
                np.minimum.at(comp_first, parent, prof.first)
                roots = np.flatnonzero(~comp_final & (comp_first < n))
                span = cum[n] - cum[comp_first[roots]]
                # a vehicle region's object-cluster also when it cannot be one vehicle
                vehicle = np.isin(np.asarray(est.labels_)[est._region(prof.depth[roots])],
                                  list(RUN_LABELS))
                limit = np.where(vehicle, max(est.max_pending_length, est.max_length),
                                 est.max_pending_length)
                comp_final[roots[span > limit]] = True
            fin_frag = comp_final[parent]
            if not fin_frag.all():
                frontier = base + int(prof.first[~fin_frag].min())
            if fin_frag.any():
                sel = fin_frag[frag]
                _, cobj = np.unique(parent[frag[sel]], return_inverse=True)
                self._finalize(act[sel], cobj.ravel(), cpos[sel], ended)
        return self._number_and_release(frontier, ended)

    def _final_fragments(self, prof, parent, ended):
        """Whether every fragment is complete and can join nothing still to come."""
        est = self.est
        n = len(self.recs)
        t = n - 1
        first, last = prof.first, prof.last
        cum, near, follows = self.cum, self.near, self.follows
        if ended:
            return np.ones(prof.n, dtype=bool)
        alive = last == t
        seg = np.cumsum(~follows) - 1
        # a fragment starting after scan t: same stretch, within reach, bridged gap
        sufmax = np.maximum.accumulate(near[::-1])[::-1]
        nxt = np.minimum(last + 1, t)
        hid = sufmax[nxt] < prof.end_depth - est.occlusion_margin
        gap_ok = (cum[t + 1] - cum[last + 1] <= est.merge_gap) | (
            est.bridge_occluded & hid)
        future = (~alive & (seg[last] == seg[t]) & (cum[t + 1] - cum[first] <= self.reach)
                  & gap_ok)
        # a growing fragment (a cluster in scan t) that may still join
        blocked = future | alive
        for b in np.flatnonzero(alive):
            fb = first[b]
            cand = (~blocked & (seg[first] == seg[fb])
                    & (np.abs(cum[fb] - cum[first]) <= self.reach))
            for a in np.flatnonzero(cand):
                if fb <= last[a]:
                    blocked[a] = True
                    continue
                if not abs(prof.end_depth[a] - prof.start_depth[b]) < est.link_distance:
                    continue
                gap = cum[fb] - cum[last[a] + 1]
                ref = min(prof.end_depth[a], prof.start_depth[b])
                hidden = near[last[a] + 1:fb] < ref - est.occlusion_margin
                if gap <= est.merge_gap or (est.bridge_occluded and bool(np.all(hidden))):
                    blocked[a] = True
        # enough scans after the object-cluster to see whether its end is hidden
        comp_last = np.full(prof.n, -1, dtype=np.int64)
        np.maximum.at(comp_last, parent, last)
        cl = comp_last[parent]
        brk = _cat(~follows[1:], False)  # scan p is the last of its stretch
        stretch_end = np.flatnonzero(brk)
        ends_known = np.zeros(prof.n, dtype=bool)
        if len(stretch_end):
            j = np.searchsorted(stretch_end, cl)
            ends_known = j < len(stretch_end)
        seen_after = (cl < t) & ((cum[t + 1] - cum[np.minimum(cl + 1, t)] >= self.cap)
                                 | ends_known)
        return ~blocked & seen_after

    def _finalize(self, cidx, cobj, cpos, ended):
        """Split and label the final object-clusters (clusters ``cidx``, window-relative
        positions ``cpos``, object-cluster ``cobj``); queue them for numbering."""
        est = self.est
        cum, near, follows = self.cum, self.near, self.follows
        cdepth, ctop, w = self.c_depth[cidx], self.c_top[cidx], self.c_w[cidx]
        cflag = self.c_flag[cidx]
        if est.split_merged:
            cobj = est._split(_Profiles(cobj, cpos, cdepth, ctop, w), cobj, near, cum)
        prof = _Profiles(cobj, cpos, cdepth, ctop, w, cflag)
        self.c_oid[cidx] = -1  # final, waiting for its id
        n_win = len(self.recs)
        for o in range(prof.n):
            first, last = int(prof.first[o]), int(prof.last[o])
            depth = float(prof.depth[o])
            length = cum[last + 1] - cum[first]
            region = int(est._region(depth))
            vehicle = length <= est.max_length
            hb = ha = 0
            if est.occluded_length is not None and vehicle:
                hb, ha = _hidden_ends(near, follows, first, last,
                                      depth - est.occlusion_margin, cum, self.cap, ended)
            hid_len = (cum[first] - cum[first - hb]) + (cum[last + 1 + ha] - cum[last + 1])
            cut_short = hid_len > 0 and length >= _MIN_VISIBLE
            vehicle = vehicle and (length >= est.min_length or (
                cut_short and length + hid_len >= est.min_length))
            if vehicle:
                pos, _ = prof.scan_profile(o)
                hidden = near < depth - est.link_distance
                seen = hidden[pos[0]:pos[-1] + 1].copy()
                seen[pos - pos[0]] = True
                brk = np.flatnonzero(~seen)
                edges = _cat(-1, brk, len(seen)) + pos[0]
                run_len = cum[edges[1:]] - cum[edges[:-1] + 1]
                seen_len = (cum[pos + 1] - cum[pos]).sum()
                if cut_short:
                    vehicle = bool((seen_len >= _MIN_VISIBLE)
                                   & (run_len.max() + hid_len >= est.min_length))
                else:
                    vehicle = bool(min(run_len.max(), seen_len) >= est.min_length)
            body = float(np.mean((prof.scan_flags(o) & _BODY) > 0))
            vehicle = vehicle and body >= est.min_body_fraction
            at_start = not follows[first]
            at_end = not (last + 1 < n_win and follows[last + 1])
            extend = (est.occluded_length is not None and vehicle and hid_len > 0
                      and not at_start and not at_end)
            mine = (cidx[cobj == o] if prof.n > 1 else cidx) + self.cbase
            a = self.base
            self.queue.append({
                "key": (a + first, depth), "first": a + first, "last": a + last,
                "hb": hb, "ha": ha, "extend": extend, "vehicle": vehicle,
                "region": region, "depth": depth, "top": float(prof.top[o]),
                "pts": float(prof.pts[o]), "clusters": mine,
            })
        self.queue.sort(key=lambda q: q["key"])

    def _number_and_release(self, frontier, ended):
        est = self.est
        stream = self.stream
        labels = est.labels_
        base, cum = self.base, self.cum
        while self.queue:
            q = self.queue[0]
            if q["first"] >= frontier:
                break
            if q["extend"] and q["last"] + q["ha"] >= frontier:
                break
            self.queue.pop(0)
            first, last = q["first"], q["last"]
            if q["extend"]:
                first, last = self._extend(q)
            stream._next_id += 1
            oid = stream._next_id
            self.c_oid[q["clusters"] - self.cbase] = oid
            label = labels[q["region"]] if q["vehicle"] else "other"
            if q["vehicle"]:
                self.numbered.append((q["region"], last))
            length = float(cum[last - base + 1] - cum[first - base])
            stream._rows.append((
                self.name, oid, int(self.scans[first - base]),
                int(self.scans[last - base]), label, q["depth"], q["region"] + 1,
                length, q["top"], int(q["pts"]),
            ))
            code = RUN_LABELS.get(label)
            if code is not None:
                self.spans.append((first, last, oid, code))
        # release scans: every object in them numbered, none can be extended over them
        stop = min(self.queue[0]["first"], frontier) if self.queue else frontier
        if ended and not self.queue:
            rel_end = base + len(self.recs)
        else:
            rel_end = min(int(stop), base + len(self.recs))
            if est.occluded_length is not None and rel_end > self.released:
                c_stop = cum[rel_end - base]
                lim = c_stop - est.occluded_length
                # p releasable when cum[p] < lim
                rel_end = min(rel_end, base + int(np.searchsorted(cum, lim, side="left")))
        out = []
        if rel_end > self.released:
            in_view = self._in_view(self.released, rel_end)
            for p in range(self.released, rel_end):
                i = p - base
                c0 = self.cl_start[i] - self.cbase
                nc = self.n_cl[i]
                pts, beams, local = self.payload[i]
                out.append(self.recs[i].evolve(
                    points=pts, beams=beams, clusters=local,
                    objects=self.c_oid[c0:c0 + nc].copy(), tilt=float(self.tilt[i]),
                    in_view=in_view[p - self.released]))
        if rel_end > self.released:
            self.released = rel_end
            self.spans = [s for s in self.spans if s[1] >= rel_end]
        self._trim(stop, ended)
        return out

    def _in_view(self, lo, hi):
        """Per scan ``lo .. hi - 1``: ``(k, 2)`` (id, label code), by id."""
        n = hi - lo
        if not self.spans:
            return [np.empty((0, 2), np.int64) for _ in range(n)]
        sp = np.array(self.spans, dtype=np.int64)
        f = np.maximum(sp[:, 0], lo)
        la = np.minimum(sp[:, 1], hi - 1)
        counts = np.maximum(la - f + 1, 0)
        p, owner = _ranges_expand(f - lo, counts)
        srt = np.lexsort((sp[owner, 2], p))
        p, owner = p[srt], owner[srt]
        pairs = sp[owner][:, 2:4]
        bounds = np.searchsorted(p, np.arange(n + 1))
        return [pairs[bounds[i]:bounds[i + 1]] for i in range(n)]

    def _extend(self, q):
        """Extend an object cut short by an occluder into the hidden scans (never
        beyond them, never into another vehicle of the same region)."""
        est = self.est
        base, cum = self.base, self.cum
        first, last = q["first"] - base, q["last"] - base
        want = est.occluded_length - (cum[last + 1] - cum[first])
        if want <= 0:
            return q["first"], q["last"]
        lo, hi = first - q["hb"], last + q["ha"]
        prev = [lst - base for reg, lst in self.numbered
                if reg == q["region"] and lst - base < first]
        nxt = [o["first"] - base for o in self.queue
               if o["vehicle"] and o["region"] == q["region"] and o["first"] - base > last]
        if prev:
            lo = max(lo, max(prev) + 1)
        if nxt:
            hi = min(hi, min(nxt) - 1)
        room_b = cum[first] - cum[lo]
        room_a = cum[hi + 1] - cum[last + 1]
        take_b = min(room_b, max(want / 2, want - room_a))
        take_a = min(room_a, want - take_b)
        if take_b > 0:
            first = int(np.searchsorted(cum, cum[first] - take_b, side="left"))
            first = max(first, lo)
        if take_a > 0:
            last = int(np.searchsorted(cum, cum[last + 1] + take_a, side="left")) - 1
            last = min(last, hi)
        return first + base, last + base

    def _trim(self, stop, ended):
        """Drop the scans and clusters no decision can need any more."""
        base = self.base
        n = len(self.recs)
        if ended and not self.queue:
            keep_from = base + n
        else:
            keep_from = min(self.released, int(min(stop, base + n)))
            # history for the hidden-end walks of objects starting at ``stop`` or later
            lim = self.cum[min(stop, base + n) - base] - self.cap
            # p kept when cum[p + 1] > lim
            hist = base + int(np.searchsorted(self.cum[1:], lim, side="right"))
            keep_from = min(keep_from, hist)
        d = keep_from - base
        if d <= 0:
            return
        d = min(d, n - 1) if not ended else d  # keep the newest scan for linking
        if d <= 0:
            return
        self.base += d
        del self.recs[:d]
        del self.payload[:d]
        self.scans = self.scans[d:]
        self.follows = self.follows[d:]
        self.near = self.near[d:]
        self.cum = self.cum[d:]
        self.tilt = self.tilt[d:]
        self.n_cl = self.n_cl[d:]
        self.cl_start = self.cl_start[d:]
        cd = (int(self.cl_start[0]) - self.cbase) if len(self.cl_start) else len(self.c_pos)
        if cd > 0:
            self.cbase += cd
            self.c_pos = self.c_pos[cd:]
            self.c_depth = self.c_depth[cd:]
            self.c_top = self.c_top[cd:]
            self.c_w = self.c_w[cd:]
            self.c_flag = self.c_flag[cd:]
            self.c_oid = self.c_oid[cd:]
            ok = self.e_a >= self.cbase
            self.e_a, self.e_b = self.e_a[ok], self.e_b[ok]
        self.numbered = [v for v in self.numbered if v[1] >= self.base]
