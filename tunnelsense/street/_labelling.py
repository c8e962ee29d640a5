"""Labelling the final object-clusters: the street-parking vehicles and the rest.

Section III-F of the paper regards an object-cluster by its region: Region I holds
street-parking vehicles, Region II vehicles passing between them and the LRF, Region III
bushes and the like at the road's edge.  :class:`_Labelling` (mixed into the run state of
``_stream``) takes the object-clusters that became final, splits those that hold more
than one vehicle (``_splitting``), tests each with the rules of ``_vehicles`` (its ends
hidden by an occluder, its body, its ends joined to something behind), gathers its class
features (``_classes``), carves motorbikes out of the structure they stand against
(``_carving``) and queues every object for its id.
"""

from __future__ import annotations

import numpy as np

from tunnelsense._records import RUN_LABELS
from tunnelsense.street._carving import (
    flat_face,
    long_runs,
    protrusions,
    raised_section,
    scan_near_side,
    widen,
)
from tunnelsense.street._classes import ROOF_FLAG, WALL_FLAG, class_features
from tunnelsense.street._geometry import HORIZON_STEP
from tunnelsense.street._objects import (
    BODY_FLAGS,
    RAISED_FLAG,
    SUSPENDED_FLAG,
    ObjectProfiles,
    depth_region,
)
from tunnelsense.street._sections import lowest_marks
from tunnelsense.street._splitting import split_echelon, split_objects
from tunnelsense.street._vehicles import (
    beams_below,
    end_match,
    hidden_ends,
    is_vehicle,
    length_share,
)
from tunnelsense.street._window import SIDE_HEIGHT

__all__ = []

#: Percentile of an object's near sides that gives the face of a wall behind
#: parked vehicles: the wall lies behind them, and they may cover half its length.
WALL_QUANTILE = 75.0
#: Evidence bits a flat face lacks: a roof, a body raised between wheels or hanging.
NOT_FLAT = ROOF_FLAG | RAISED_FLAG | SUSPENDED_FLAG


class _Labelling:
    """Split, test and queue the final object-clusters of a run's window (mixed into
    the run state of :class:`~tunnelsense.street._stream.ScanStream`)."""

    def _finalize(self, clusters, objects, position, ended):
        """Split and label the final object-clusters; queue them for numbering."""
        est = self.est
        depth, top = self.depth[clusters], self.top[clusters]
        n_points, flags = self.n_points[clusters], self.flags[clusters]
        if est.split_merged:
            objects = split_objects(
                ObjectProfiles(objects, position, depth, top, n_points), objects,
                self.cum, self.near, min_length=est.min_length, ratio=est.split_ratio,
                link_distance=est.link_distance, gap=self.gap,
                **(dict(horizon=self.horizon, step=HORIZON_STEP) if est.beam_occlusion
                   else {}))
        if est.split_merged and est.region_depth == "across" and len(objects):
            # vehicles in echelon (bays at an angle), joined by overlapping ends
            n = int(objects.max()) + 1
            first = np.full(n, len(self.records), dtype=np.int64)
            last = np.zeros(n, dtype=np.int64)
            np.minimum.at(first, objects, position)
            np.maximum.at(last, objects, position)
            objects = split_echelon(objects, position, self.side[clusters],
                                    self.far[clusters], first, last, self.cum,
                                    min_length=est.min_car_length, depth=est.roof_width,
                                    gap=self.gap)
        prof = ObjectProfiles(objects, position, depth, top, n_points, flags)
        region_depth, reaching = self._region_depth(objects, clusters, prof,
                                                    reaching=True)
        self.object_id[clusters] = -1  # final, waiting for its id
        follows = self.follows
        for o in range(prof.n):
            first, last = int(prof.first[o]), int(prof.last[o])
            cum = self.metres_from(first)  # lost scans right before it are not its
            mean_depth = float(prof.depth[o])
            before = after = 0
            hidden_length, cut = 0.0, False
            if (est.occluded_length is not None
                    and cum[last + 1] - cum[first] <= est.max_length):
                before, after = hidden_ends(
                    self.near, follows, first, last, mean_depth - est.occlusion_margin,
                    cum, self.cap, beams_below(self.horizon, HORIZON_STEP, mean_depth,
                                               float(prof.top[o]))
                    if est.beam_occlusion else None)
                hidden_length = (cum[first] - cum[first - before]) + (
                    cum[last + 1 + after] - cum[last + 1])
                cut = self._cut(first - before, last + 1 + after, ended)
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
                min_across_top=est.min_across_top, inside=passed_ok,
                where_seen=est.seen_evidence)
            of = objects == o if prof.n > 1 else slice(None)
            mine = clusters[of]
            vehicle = any(
                is_vehicle(prof.profile(o)[0], prof.flags(o), mean_depth, hidden, cum,
                           self.near, **vehicle_test)
                for hidden in self._completions(
                    hidden_length, cut, cum[last + 1] - cum[first],
                    cut and not self._flat(mine, position[of], first, last)))
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
                        cum = self.metres_from(first)
            # a wall, fence or facade (no vehicle): vehicles in front are carved out
            whole = bool(est.carve_protrusions
                         and cum[last + 1] - cum[first] > est.van_length
                         and self._flat(mine, position[of], first, last))
            vehicle = vehicle and not whole
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
                # parked for standing across the street ("across"), shorter than a
                # car along it: seen end on
                "end_on": bool(est.region_depth == "across" and reaching[o]
                               and cum[last + 1] - cum[first] < est.min_car_length),
                "region": region,
                "depth": mean_depth, "top": float(prof.top[o]),
                "n_points": int(prof.n_points[o]),
                "clusters": mine + self.cluster_base,
                "features": features,
            })
            if whole:
                self.queue.extend(self._carve(mine, position[of], first, last, True))
            if est.carve_protrusions and not (vehicle and parked):
                self.queue.extend(self._carve(mine, position[of], first, last))
        self.queue.sort(key=lambda q: q["key"])

    def _cut(self, lo, hi, ended):
        """Whether an object whose ends, with their hidden scans, are scans ``lo``
        and ``hi - 1`` is cut by the data: it reaches the run's first or last scan.
        The run's last scan cuts only once the run has ``ended`` (before, an object
        reaching the newest scan is never final).  Scans missing inside the run do
        not cut: a stretch of them up to ``max_missing_length`` is linked across
        (the object goes on), and at a longer one the objects on either side end,
        each tested on what was seen of it, as if nothing lay beyond."""
        return bool(self.base + lo == 0 or (hi == len(self.records) and ended))

    def _completions(self, hidden, cut, length, body):
        """The hidden lengths (m) to test an object of ``length`` seen metres with:
        ``hidden`` metres its occluders hide and, when the data cut it (``cut``),
        what the cut may hide: as much as any decision looks at (``cap``: a car or
        van) when its seen part shows a ``body`` a flat vertical face lacks (a
        roof, or a body raised between wheels or hanging: :meth:`_flat` fails; a
        wall's or hedge's face cut there shows none), or just enough for the
        shortest vehicle (``min_length``: a motorbike, whose test asks for a
        raised or hanging body itself).  The object is cut, not absent: it is a
        vehicle when the evidence seen so far makes it one under any of these."""
        if not cut:
            return (hidden,)
        car = (hidden + self.cap,) if body else ()
        return (hidden, *car, max(hidden, self.est.min_length - length))

    def _scan_flags(self, mine, pos, first, last):
        """The OR of the evidence flags of clusters ``mine`` in every scan."""
        out = np.zeros(last - first + 1, dtype=np.int64)
        np.bitwise_or.at(out, pos - first, self.flags[mine].astype(np.int64))
        return out

    def _flat(self, mine, pos, first, last):
        """Whether the object of clusters ``mine`` is a flat vertical face (a
        wall, fence or facade) wherever nothing stands in front of it: a roof or a
        raised body in less than ``min_raised_fraction`` of that face's length
        (:func:`~tunnelsense.street._carving.flat_face`); ``flat_by_ground``: its
        lowest point raised (:meth:`_raised_scans`) behind the parking lane."""
        est, cum = self.est, self.metres_from(first)
        near = scan_near_side(pos, self.side[mine], first, last)
        face, runs = protrusions(near, est.link_distance, cum[first:last + 2],
                                 est.max_length, ends=True, quantile=WALL_QUANTILE)
        flags, evidence = self._scan_flags(mine, pos, first, last), NOT_FLAT
        if (est.flat_by_ground and np.isfinite(face) and est.labels_[
                int(depth_region(face, self.edges([first])[0]))] != "passing"):
            flags, evidence = self._raised_scans(mine, pos, first, last, face), 1
        return flat_face(near, flags, face, runs, est.link_distance,
                         np.diff(cum[first:last + 2]), evidence,
                         est.min_raised_fraction)

    def _raised_scans(self, mine, pos, first, last, face):
        """Per scan ``first .. last``, whether the lowest point of clusters ``mine``
        stands above ``min_clearance`` with the beam below it passing farther or
        returning nothing in the region of interest (it reached the road under it;
        :func:`~tunnelsense.street._carving.raised_section`), or, over a stretch of
        at least ``min_gap_length`` metres and ``min_gap_scans`` scans, the beam
        below it passes under it to the ground
        (:func:`~tunnelsense.street._carving.under_gap`); all scans at once
        (:func:`~tunnelsense.street._sections.lowest_marks`)."""
        est = self.est
        scans = range(first, last + 1)
        sizes = np.array([len(self.payload[p][1]) for p in scans], dtype=np.int64)
        points = np.concatenate([self.payload[p][0] for p in scans])
        beams = np.concatenate([self.payload[p][1] for p in scans])
        local = np.concatenate([self.payload[p][2] for p in scans])
        under = np.concatenate([self.under[p] for p in scans])
        scan = np.repeat(np.arange(last - first + 1), sizes)
        # window cluster numbers (a scan's clusters are numbered from its first)
        cluster = local + (self.first_cluster[first:last + 1]
                           - self.cluster_base)[scan]
        raised, gap = lowest_marks(points, beams, scan, under,
                                   np.isin(cluster, mine), last - first + 1,
                                   est.min_clearance, float(self.resolution(face)))
        gap = long_runs(gap, np.diff(self.metres_from(first)[first:last + 2]),
                        est.min_gap_length,
                        est.min_gap_scans)
        return (raised | gap).astype(np.int64)

    def _own_step(self, p):
        """Metres of scan position ``p``'s own stretch, lost scans before it left
        out; 0 outside the window."""
        if p < 0 or p + 1 >= len(self.cum):
            return 0.0
        return float(self.cum[p + 1] - self.cum[p] - self.gap[p])

    def _carve(self, mine, pos, first, last, whole=False):
        """Queue entries of motorbikes standing against the structure of clusters
        ``mine`` (window positions ``pos``, scans ``first .. last``); see ``_carving``.
        ``whole``: of vehicles of any class standing in front of a flat face (a
        wall), at least ``min_length`` long with a body in ``min_body_fraction`` of
        their length."""
        est = self.est
        if (est.min_across_length is None and not whole) or last - first < 2:
            return []
        cum = self.metres_from(first)
        near = scan_near_side(pos, self.side[mine], first, last)
        face, runs = protrusions(
            near, est.link_distance, cum[first:last + 2],
            est.max_length if whole else est.min_car_length, ends=whole,
            quantile=WALL_QUANTILE if whole else 50.0)
        scan_flags = self._scan_flags(mine, pos, first, last)
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
            # a piece starting right after lost scans: their metres are not its own
            cum = self.metres_from(lo)
            length = float(cum[hi + 1] - cum[lo])
            # its ends, at the face, may lie up to half a scan spacing beyond (a
            # scan's own spacing: the metres of lost scans next to it are not)
            bound = length + 0.5 * (self._own_step(lo - 1) + self._own_step(hi + 1))
            top = float(pts[:, 1].max())
            depth = float(pts[:, 0].mean())
            side = np.array([q[:, 0].min() for q in body])
            far = np.array([q[:, 0].max() for q in body])
            lo_edge, hi_edge = self.edges([lo])[0]
            region_depth = (max(float(np.median(side)), lo_edge)
                            if depth >= hi_edge > np.median(side) else depth)
            region = int(depth_region(region_depth, self.edges([lo])[0]))
            metres = np.diff(cum[lo:hi + 2])
            if whole:
                # the wall bit is the face's behind it (one cluster joins them)
                fl = scan_flags[lo - first:hi - first + 1] & ~WALL_FLAG
                if not (est.labels_[region] == "parked" and bound >= est.min_length
                        and length_share((fl & BODY_FLAGS) > 0, metres)
                        >= est.min_body_fraction
                        and length_share((fl & NOT_FLAT) > 0, metres)
                        >= est.min_raised_fraction):
                    continue  # too short, or itself flat (a nearer stretch of wall)
            elif not (est.labels_[region] == "parked"
                      and bound >= est.min_across_length
                      and face - side.min() >= est.motorbike_width
                      and length_share(raised, metres) >= est.min_across_raised):
                continue
            if self._taken(self.base + lo, self.base + hi, region):
                continue  # already a vehicle there (carved from another object)
            features = class_features(
                fl if whole else np.zeros(hi - lo + 1, np.int64),
                np.array([q[:, 1].max() for q in parts]), np.arange(lo, hi + 1),
                side, far, length, seen=np.arange(lo, hi + 1), metres=np.diff(cum))
            out.append({
                "key": (self.base + lo, depth), "first": self.base + lo,
                "last": self.base + hi, "before": 0, "after": 0, "extend": False,
                "end_on": False,
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
        to them saw it (:func:`~tunnelsense.street._vehicles.end_match`)."""
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
