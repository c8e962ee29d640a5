"""The street detector's online state: scans in one at a time, objects out.

:class:`ScanStream` is what :meth:`ScanClusterer.start_stream` returns, and what
:meth:`ScanClusterer.transform`, :meth:`~ScanClusterer.predict` and
:meth:`~ScanClusterer.detect` run over every run, so that streaming and batch give
identical results by construction: the decisions below never depend on *when* they are
taken (after every scan, or once at the end of a run), only on the scans seen.

This module decides finality and releases records; the scans are restored, clustered
and linked as they arrive by the window (``_window``), and the object rules are the
functions of ``_objects``.  The state keeps a *window* of scans: those not yet
released plus a short history.  An object-cluster (a component of the fragments the three-region merge
joins) is **final** once no fragment of it can link or merge with anything still to
come: none of its fragments has a cluster in the newest scan; no fragment still
growing, or starting later, can join one of its fragments; and enough scans
(``max(min_length, occluded_length)`` metres) follow it to tell whether its ends are
hidden by an occluder.  A final object-cluster is split and labelled at once.  Objects
are numbered in the order of their first scan (then mean depth), so an object gets its
id once no object that is not yet final can start before it; a scan's record is
released once every object in it has its id and no later object can be extended over
it.  Memory therefore follows the longest object in view, not the run's length.

An object-cluster the merge keeps joining (a kerb, hedge or facade bridged behind
passing vehicles) would never become final; so at every ``CHECK_EVERY``-th scan of a
run (absolute positions, the same in batch), one that is not final and reaches back
more than ``max_pending_length`` metres is closed up to that scan.
"""

from __future__ import annotations

import numpy as np

from tunnelsense._payload import FINISHED_OBJECTS
from tunnelsense._records import RUN_LABELS
from tunnelsense._streaming import StreamState
from tunnelsense.street._carving import (
    protrusions,
    raised_section,
    scan_near_side,
    widen,
)
from tunnelsense.street._classes import class_features, vehicle_class
from tunnelsense.street._clustering import (
    components,
    concat,
    expand_ranges,
    first_appearance,
)
from tunnelsense.street._geometry import HORIZON_STEP
from tunnelsense.street._objects import (
    ObjectProfiles,
    bridged,
    depth_region,
    end_match,
    extend_occluded,
    hidden_ends,
    is_vehicle,
    length_share,
    merge_fragments,
    near_side,
)
from tunnelsense.street._splitting import split_objects
from tunnelsense.street._window import SIDE_HEIGHT, ScanWindow

__all__ = ["ScanStream"]

#: Payload key of the object-table rows that became final by a released record.
#: Every this many scans of a run (absolute positions), object-clusters pending for
#: longer than ``max_pending_length`` are closed (the same scans in batch and online).
CHECK_EVERY = 64


class ScanStream(StreamState):
    """Online state of a fitted :class:`~tunnelsense.street.ScanClusterer`.

    Feed scans with :meth:`push` (or :meth:`push_many`), in increasing scan order per
    run (a new run name starts that run afresh); finished records come back in input
    order, with the payload of :meth:`ScanClusterer.transform`: ``"in_view"``, the
    ``(k, 2)`` array ``(object id, label code)`` of :meth:`ScanClusterer.predict`,
    and ``"finished_objects"``, the object-table rows that became final by the time
    the record was released (tuples of :data:`~tunnelsense.street.OBJECT_COLUMNS`,
    in id order).

    Parameters
    ----------
    estimator : ScanClusterer
        A fitted detector.
    """

    def __init__(self, estimator):
        self.estimator = estimator
        self.n_objects = 0  # objects numbered so far (ids count on over the runs)
        self._run = None

    @property
    def n_held(self):
        """Scans held now (not yet released, plus history)."""
        return 0 if self._run is None else len(self._run.records)

    def _push(self, record):
        return self._push_many([record])

    def _push_many(self, records):
        out = []
        i = 0
        while i < len(records):
            name = records[i].run
            j = i + 1
            while j < len(records) and records[j].run == name:
                j += 1
            if self._run is None or self._run.name != name:
                out.extend(self._decide(ended=True))
                self._run = _RunState(self.estimator, name)
            run = self._run
            k = i
            while k < j:  # ingest up to each check (every CHECK_EVERY scans)
                stop = min(j, k + CHECK_EVERY - run.n_seen % CHECK_EVERY)
                run.ingest(records[k:stop])
                k = stop
                if run.n_seen % CHECK_EVERY == 0 and run.overdue_possible():
                    out.extend(self._decide(ended=False, check=True))
            if run.decided_at != run.n_seen:
                out.extend(self._decide(ended=False))
            i = j
        return out

    def _close(self):
        out = self._decide(ended=True)
        self._run = None
        return out

    def _decide(self, *, ended, check=False):
        if self._run is None:
            return []
        out, self.n_objects = self._run.decide(self.n_objects, ended=ended, check=check)
        return out


class _RunState(ScanWindow):
    """A run's window of scans with its pending objects: finality and release."""

    def __init__(self, estimator, name):
        super().__init__(estimator, name)
        est = estimator
        self.decided_at = -1  # n_seen at the last decision
        self.queue = []  # final objects waiting for their id, sorted by key
        self.numbered = []  # (region, last) of numbered vehicles still near
        self.spans = []  # (first, last, id, code) of numbered objects not yet released
        self.rows = []  # object-table rows numbered, not yet given to a record
        self.released = 0  # absolute position of the next scan to release
        # (first, last, region, body) of final fragments still in the window
        self.blockers = np.empty((0, 4), dtype=np.int64)
        self.reach = est.max_length + est.merge_gap
        self.cap = (max(est.min_length, est.occluded_length)
                    if est.occluded_length is not None else 0.0)
        self.rule = dict(link_distance=est.link_distance, merge_gap=est.merge_gap,
                         occlusion_margin=est.occlusion_margin,
                         bridge_occluded=est.bridge_occluded)

    def overdue_possible(self):
        """Whether an object-cluster may be pending longer than ``max_pending_length``
        (its oldest cluster that is not final is that old)."""
        limit = self.est.max_pending_length
        pending = np.flatnonzero(self.object_id == 0)
        if limit is None or not len(pending):
            return False
        oldest = int(self.position[pending[0]]) - self.base
        return bool(self.cum[len(self.records)] - self.cum[oldest] > limit)

    def decide(self, next_id, *, ended, check=False):
        """Finalize, number and release what the scans seen so far allow.

        With ``check`` (at every ``CHECK_EVERY``-th scan), object-clusters pending
        longer than ``max_pending_length`` are closed as one object up to the newest
        scan.  Returns the released records and the number of objects numbered so far.
        """
        est = self.est
        self.decided_at = self.n_seen
        n = len(self.records)
        if n == 0:
            return [], next_id
        pending = np.flatnonzero(self.object_id == 0)
        frontier = np.inf if ended else self.n_seen  # no non-final object starts before
        if len(pending):
            lookup = np.full(len(self.object_id), -1, dtype=np.int64)
            lookup[pending] = np.arange(len(pending))
            earlier = lookup[self.links[0] - self.cluster_base]
            later = lookup[self.links[1] - self.cluster_base]
            keep = (earlier >= 0) & (later >= 0)
            fragment = first_appearance(
                components(len(pending), earlier[keep], later[keep]))
            position = self.position[pending] - self.base
            occlusion = {}
            if est.beam_occlusion:
                occlusion = dict(flags=self.flags[pending], span=np.column_stack(
                    [np.where(np.isfinite(self.side[pending]), self.side[pending],
                              np.nan), self.far[pending], self.occluder[pending]]))
            prof = ObjectProfiles(fragment, position, self.depth[pending],
                                  self.top[pending], self.n_points[pending], **occlusion)
            region = depth_region(self._region_depth(fragment, pending, prof),
                                  self.edges(prof.first))
            self.blockers = self.blockers[self.blockers[:, 1] >= self.base]
            root = merge_fragments(prof, region, self.cum, self.near, self.follows,
                                   reach=self.reach, **self.rule, **self._horizon(),
                                   gap_regions=np.isin(est.labels_, list(RUN_LABELS)),
                                   blockers=self.blockers - [self.base, self.base, 0, 0])
            final = np.ones(prof.n, dtype=bool)
            np.logical_and.at(final, root, self._final_fragments(prof, root, ended))
            if check and est.max_pending_length is not None:
                final |= self._overdue(prof, root, region, final)
            final_fragment = final[root]
            if not final_fragment.all():
                frontier = self.base + int(prof.first[~final_fragment].min())
            if final_fragment.any():
                # final fragments still bar bridges across them (as when pending)
                self.blockers = np.concatenate([self.blockers, np.column_stack([
                    self.base + prof.first[final_fragment],
                    self.base + prof.last[final_fragment], region[final_fragment],
                    prof.top[final_fragment] >= SIDE_HEIGHT])])
                done = final_fragment[fragment]  # clusters of final object-clusters
                _, objects = np.unique(root[fragment[done]], return_inverse=True)
                self._finalize(pending[done], objects.ravel(), position[done], ended)
        return self._number_and_release(frontier, ended, next_id)

    def _horizon(self):
        """The window's beam horizon for :func:`bridged` (none for the paper's)."""
        if not self.est.beam_occlusion:
            return {}
        return dict(horizon=self.horizon, step=HORIZON_STEP,
                    bridge_gap=self.est.occluded_length)

    def _region_depth(self, objects, clusters, prof):
        """The depth that decides every object's region: the mean depth, or (``"near"``)
        the near side for the boundary of region III (a car half on the sidewalk)."""
        if self.est.region_depth == "mean":
            return prof.depth
        side = near_side(objects, self.side[clusters], prof.n)
        lo, hi = self.edges(prof.first).T
        with np.errstate(invalid="ignore"):
            inside = (prof.depth >= hi) & (side < hi)
        return np.where(inside, np.maximum(side, lo), prof.depth)

    def _overdue(self, prof, root, region, final):
        """Object-clusters (roots) not final that reach back beyond the limit."""
        est = self.est
        n = len(self.records)
        first = np.full(prof.n, n, dtype=np.int64)
        np.minimum.at(first, root, prof.first)
        roots = np.flatnonzero(~final & (first < n))
        span = self.cum[n] - self.cum[first[roots]]
        # in a region labelled as vehicles, also when it cannot be one vehicle
        vehicle = np.isin(np.asarray(est.labels_)[region[roots]], list(RUN_LABELS))
        limit = np.where(vehicle, max(est.max_pending_length, est.max_length),
                         est.max_pending_length)
        overdue = np.zeros(prof.n, dtype=bool)
        overdue[roots[span > limit]] = True
        return overdue

    def _final_fragments(self, prof, root, ended):
        """Whether every fragment is complete and can join nothing still to come."""
        if ended:
            return np.ones(prof.n, dtype=bool)
        t = len(self.records) - 1
        first, last = prof.first, prof.last
        cum, near, follows = self.cum, self.near, self.follows
        alive = last == t
        stretch = np.cumsum(~follows) - 1
        # a fragment starting after scan t: same stretch, within reach, bridged gap
        farthest_after = np.maximum.accumulate(near[::-1])[::-1]
        hidden = (farthest_after[np.minimum(last + 1, t)]
                  < prof.end_depth - self.est.occlusion_margin)
        gap_ok = (cum[t + 1] - cum[last + 1] <= self.est.merge_gap) | (
            self.est.bridge_occluded & hidden)
        blocked = alive | (~alive & (stretch[last] == stretch[t])
                           & (cum[t + 1] - cum[first] <= self.reach) & gap_ok)
        # a growing fragment (a cluster in scan t) that may still join
        for b in np.flatnonzero(alive):
            fb = first[b]
            candidates = (~blocked & (stretch[first] == stretch[fb])
                          & (np.abs(cum[fb] - cum[first]) <= self.reach))
            for a in np.flatnonzero(candidates):
                blocked[a] = fb <= last[a] or bridged(
                    prof.end_depth[a], prof.start_depth[b], last[a] + 1, fb, cum, near,
                    **prof.seen(a, b), **self.rule,
                    **dict(self._horizon(), bridge_gap=None))
        # enough scans after the object-cluster to see whether its end is hidden
        last_of_root = np.full(prof.n, -1, dtype=np.int64)
        np.maximum.at(last_of_root, root, last)
        end = last_of_root[root]
        stretch_end = np.flatnonzero(concat(~follows[1:], False))
        ends_known = np.searchsorted(stretch_end, end) < len(stretch_end)
        seen_after = (end < t) & ((cum[t + 1] - cum[np.minimum(end + 1, t)] >= self.cap)
                                  | ends_known)
        return ~blocked & seen_after

    def _finalize(self, clusters, objects, position, ended):
        """Split and label the final object-clusters; queue them for numbering."""
        est = self.est
        depth, top = self.depth[clusters], self.top[clusters]
        n_points, flags = self.n_points[clusters], self.flags[clusters]
        if est.split_merged:
            objects = split_objects(
                ObjectProfiles(objects, position, depth, top, n_points), objects,
                self.cum, self.near, min_length=est.min_length, ratio=est.split_ratio,
                link_distance=est.link_distance,
                **(dict(horizon=self.horizon, step=HORIZON_STEP) if est.beam_occlusion
                   else {}))
        prof = ObjectProfiles(objects, position, depth, top, n_points, flags)
        region_depth = self._region_depth(objects, clusters, prof)
        self.object_id[clusters] = -1  # final, waiting for its id
        cum, follows = self.cum, self.follows
        for o in range(prof.n):
            first, last = int(prof.first[o]), int(prof.last[o])
            mean_depth = float(prof.depth[o])
            before = after = 0
            if (est.occluded_length is not None
                    and cum[last + 1] - cum[first] <= est.max_length):
                before, after = hidden_ends(self.near, follows, first, last,
                                            mean_depth - est.occlusion_margin, cum,
                                            self.cap)
            hidden_length = (cum[first] - cum[first - before]) + (
                cum[last + 1 + after] - cum[last + 1])
            region = int(depth_region(region_depth[o], self.edges([first])[0]))
            parked = est.labels_[region] == "parked"  # motorbikes across park
            inside = follows[first] and last + 1 < len(self.records) and follows[last + 1]
            # a run's first or last scans may cut a van short to a motorbike's
            # length; a van's end reaches van_height, a motorbike's screen does not
            passed_ok = bool(inside) or float(prof.top[o]) < est.van_height
            vehicle_test = dict(
                min_length=est.min_length, max_length=est.max_length,
                link_distance=est.link_distance,
                min_body_fraction=est.min_body_fraction,
                min_car_length=est.min_car_length,
                min_raised_fraction=est.min_raised_fraction,
                min_across_length=est.min_across_length if parked else None,
                min_across_raised=est.min_across_raised, top=float(prof.top[o]),
                min_across_top=est.min_across_top, inside=passed_ok)
            vehicle = is_vehicle(prof.profile(o)[0], prof.flags(o), mean_depth,
                                 hidden_length, cum, self.near, **vehicle_test)
            of = objects == o if prof.n > 1 else slice(None)
            mine = clusters[of]
            if (not vehicle and est.object_ends and parked and hidden_length == 0
                    and est.min_across_length is not None
                    and cum[last + 1] - cum[first] < est.min_length):
                # its ends joined to something behind still count (end_match)
                lo, hi = self._merged_ends(mine, position[of], first, last)
                if lo or hi:
                    vehicle = is_vehicle(
                        prof.profile(o)[0], prof.flags(o), mean_depth, 0.0, cum,
                        self.near, end_length=(cum[first] - cum[first - lo])
                        + (cum[last + 1 + hi] - cum[last + 1]), **vehicle_test)
                    if vehicle:
                        first, last = first - lo, last + hi
            # (a passing vehicle's seen length follows the two speeds, not its body)
            features = class_features(
                prof.flags(o), prof.profile(o)[1], position[of], self.side[mine],
                self.far[mine], cum[last + 1] - cum[first] if parked else np.nan,
                seen=prof.profile(o)[0], metres=np.diff(cum))
            self.queue.append({
                "key": (self.base + first, mean_depth), "first": self.base + first,
                "last": self.base + last, "before": before, "after": after,
                "extend": bool(est.occluded_length is not None and vehicle
                               and hidden_length > 0 and inside),
                "vehicle": vehicle,
                "region": region,
                "depth": mean_depth, "top": float(prof.top[o]),
                "n_points": int(prof.n_points[o]),
                "clusters": mine + self.cluster_base,
                "features": features,
            })
            if est.carve_protrusions and not (vehicle and parked):
                self.queue.extend(self._carve(mine, position[of], first, last))
        self.queue.sort(key=lambda q: q["key"])

    def _carve(self, mine, pos, first, last):
        """Queue entries of motorbikes standing against the structure of clusters
        ``mine`` (window positions ``pos``, scans ``first .. last``); see ``_carving``."""
        est = self.est
        if est.min_across_length is None or last - first < 2:
            return []
        cum = self.cum
        near = scan_near_side(pos, self.side[mine], first, last)
        face, runs = protrusions(near, est.link_distance, cum[first:last + 2],
                                 est.min_car_length)
        out = []
        cut_at = face - float(self.resolution(face))
        wide = []  # widened runs, those that overlap joined (one object's parts)
        for a, b in runs:
            a, b = widen(near, a, b, cut_at, cum[first:last + 2], est.merge_gap)
            if wide and a <= wide[-1][1] + 1:
                a = wide.pop()[0]
            wide.append((a, b))
        for a, b in wide:
            lo, hi = first + a, first + b
            parts, raised = [], np.zeros(hi - lo + 1, dtype=bool)
            for p in range(lo, hi + 1):
                points, beams, local = self.payload[p]
                want = mine[pos == p] + self.cluster_base - self.first_cluster[p]
                section = np.isin(local, want) & (points[:, 0] < cut_at)
                parts.append(points[section])
                raised[p - lo] = raised_section(points, beams,
                                         section & (points[:, 1] >= est.min_clearance),
                                         est.min_clearance,
                                         float(self.resolution(face)))
            pts = np.concatenate(parts)
            body = [q[q[:, 1] >= SIDE_HEIGHT] for q in parts]
            if not all(len(q) for q in body):
                continue
            length = float(cum[hi + 1] - cum[lo])
            # its ends, at the face, may lie up to half a scan spacing beyond
            bound = length + 0.5 * float(cum[lo] - cum[max(lo - 1, 0)]
                                         + cum[min(hi + 2, len(cum) - 1)] - cum[hi + 1])
            top = float(pts[:, 1].max())
            depth = float(pts[:, 0].mean())
            side = np.array([q[:, 0].min() for q in body])
            far = np.array([q[:, 0].max() for q in body])
            lo_edge, hi_edge = self.edges([lo])[0]
            region_depth = (max(float(np.median(side)), lo_edge)
                            if depth >= hi_edge > np.median(side) else depth)
            region = int(depth_region(region_depth, self.edges([lo])[0]))
            if not (est.labels_[region] == "parked" and bound >= est.min_across_length
                    and face - side.min() >= est.motorbike_width
                    and length_share(raised, np.diff(cum[lo:hi + 2]))
                    >= est.min_across_raised):
                continue
            if self._taken(self.base + lo, self.base + hi, region):
                continue  # already a vehicle there (carved from another object)
            features = class_features(
                np.zeros(hi - lo + 1, np.int64),
                np.array([q[:, 1].max() for q in parts]), np.arange(lo, hi + 1),
                side, far, length, seen=np.arange(lo, hi + 1), metres=np.diff(cum))
            out.append({
                "key": (self.base + lo, depth), "first": self.base + lo,
                "last": self.base + hi, "before": 0, "after": 0, "extend": False,
                "vehicle": True, "region": region, "depth": depth, "top": top,
                "n_points": len(pts), "clusters": np.empty(0, np.int64),
                "features": features,
            })
        return out

    def _taken(self, first, last, region):
        """Whether a vehicle of ``region`` already holds a scan of ``first .. last``
        (absolute positions): queued, or numbered and not yet released."""
        code = RUN_LABELS.get(self.est.labels_[region])
        return any(q["vehicle"] and q["region"] == region and q["first"] <= last
                   and first <= q["last"] for q in self.queue) or any(
            c == code and f <= last and first <= e for f, e, _, c in self.spans)

    def _object_points(self, mine, pos, p):
        """``(depth, height)`` of the points of clusters ``mine`` (window indices,
        at window positions ``pos``) in the scan at window position ``p``."""
        points, _, local = self.payload[p]
        want = mine[pos == p] + self.cluster_base - self.first_cluster[p]
        return points[np.isin(local, want)]

    def _merged_ends(self, mine, pos, first, last):
        """Scans before ``first`` and after ``last`` (at most ``merge_gap`` each
        way, consecutive) whose points reach the object's top where the scan next
        to them saw it (:func:`~tunnelsense.street._objects.end_match`)."""
        cum, gap = self.cum, self.est.merge_gap
        out = []
        for start, step in ((first, -1), (last, 1)):
            ref = self._object_points(mine, pos, start)
            n = 0
            if len(ref):
                tol = float(self.resolution(ref[:, 0].max()))
                upper = ref[ref[:, 1] >= ref[:, 1].max() - tol]
                p = start + step
                while 0 <= p < len(self.records) and self.follows[max(p, p - step)]:
                    reach = cum[first] - cum[p] if step < 0 else cum[p + 1] - cum[last + 1]
                    if reach > gap + 1e-9:
                        break
                    upper = end_match(upper, self.payload[p][0], tol)
                    if not len(upper):
                        break
                    n += 1
                    p += step
            out.append(n)
        return out

    def _number_and_release(self, frontier, ended, next_id):
        est = self.est
        base, cum = self.base, self.cum
        while self.queue:
            q = self.queue[0]
            if q["first"] >= frontier or (
                    q["extend"] and q["last"] + q["after"] >= frontier):
                break
            self.queue.pop(0)
            first, last = q["first"], q["last"]
            kind = vehicle_class(q["features"], **est._class_params()) if q[
                "vehicle"] else ""
            if q["extend"]:
                # a motorbike is shorter than the shortest car: not extended beyond
                first, last = self._extend(q, est.occluded_length if kind != "motorbike"
                                           else min(est.occluded_length,
                                                    est.min_car_length))
            next_id += 1
            self.object_id[q["clusters"] - self.cluster_base] = next_id
            label = est.labels_[q["region"]] if q["vehicle"] else "other"
            if q["vehicle"]:
                self.numbered.append((q["region"], last))
            self.rows.append((
                self.name, next_id, int(self.scans[first - base]),
                int(self.scans[last - base]), label, q["depth"], q["region"] + 1,
                float(cum[last - base + 1] - cum[first - base]), q["top"],
                q["n_points"], kind))
            code = RUN_LABELS.get(label)
            if code is not None:
                self.spans.append((first, last, next_id, code))
        # release scans: every object in them numbered, none can be extended over them
        stop = min(self.queue[0]["first"], frontier) if self.queue else frontier
        if ended and not self.queue:
            release_end = base + len(self.records)
        else:
            release_end = min(int(stop), base + len(self.records))
            if est.object_ends and release_end > self.released:
                # an object's ends may reach merge_gap before its first scan
                limit = cum[release_end - base] - est.merge_gap
                release_end = min(release_end,
                                  base + int(np.searchsorted(cum, limit, side="left")))
            if est.occluded_length is not None and release_end > self.released:
                limit = cum[release_end - base] - est.occluded_length
                release_end = min(release_end,
                                  base + int(np.searchsorted(cum, limit, side="left")))
        out = []
        if release_end > self.released:
            in_view = self._in_view(self.released, release_end)
            for p in range(self.released, release_end):
                i = p - base
                c0 = self.first_cluster[i] - self.cluster_base
                points, beams, local = self.payload[i]
                out.append(self.records[i].evolve(
                    points=points, beams=beams, clusters=local,
                    objects=self.object_id[c0:c0 + self.n_clusters[i]].copy(),
                    tilt=float(self.tilt[i]), in_view=in_view[p - self.released],
                    **{FINISHED_OBJECTS: ()}))
            out[-1] = out[-1].evolve(**{FINISHED_OBJECTS: tuple(self.rows)})
            self.rows = []
            self.released = release_end
            self.spans = [s for s in self.spans if s[1] >= release_end]
        self._trim(stop, ended)
        return out, next_id

    def _in_view(self, lo, hi):
        """Per scan ``lo .. hi - 1``: ``(k, 2)`` (id, label code), by id."""
        n = hi - lo
        if not self.spans:
            return [np.empty((0, 2), np.int64) for _ in range(n)]
        spans = np.array(self.spans, dtype=np.int64)
        first = np.maximum(spans[:, 0], lo)
        counts = np.maximum(np.minimum(spans[:, 1], hi - 1) - first + 1, 0)
        p, owner = expand_ranges(first - lo, counts)
        order = np.lexsort((spans[owner, 2], p))
        p, owner = p[order], owner[order]
        pairs = spans[owner][:, 2:4]
        bounds = np.searchsorted(p, np.arange(n + 1))
        return [pairs[bounds[i]:bounds[i + 1]] for i in range(n)]

    def _extend(self, q, length):
        """Extend an object cut short by an occluder into the hidden scans to
        ``length`` metres (never beyond them, never into another vehicle of the
        same region)."""
        base = self.base
        first, last = q["first"] - base, q["last"] - base
        lowest, highest = first - q["before"], last + q["after"]
        previous = [end - base for region, end in self.numbered
                    if region == q["region"] and end - base < first]
        following = [o["first"] - base for o in self.queue if o["vehicle"]
                     and o["region"] == q["region"] and o["first"] - base > last]
        if previous:
            lowest = max(lowest, max(previous) + 1)
        if following:
            highest = min(highest, min(following) - 1)
        first, last = extend_occluded(self.cum, first, last, lowest, highest, length)
        return first + base, last + base

    def _trim(self, stop, ended):
        """Drop the scans and clusters no decision can need any more."""
        base, n = self.base, len(self.records)
        if ended and not self.queue:
            keep_from = base + n
        else:
            keep_from = min(self.released, int(min(stop, base + n)))
            # history for the hidden-end walks of objects starting at ``stop`` or later
            limit = self.cum[min(stop, base + n) - base] - self.cap
            keep_from = min(keep_from, base + int(
                np.searchsorted(self.cum[1:], limit, side="right")))
        d = keep_from - base
        if not ended:
            d = min(d, n - 1)  # keep the newest scan for linking
        if d <= 0:
            return
        self.drop(d)
        self.numbered = [v for v in self.numbered if v[1] >= self.base]
