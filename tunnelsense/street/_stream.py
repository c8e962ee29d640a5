"""The street detector's online state: scans in one at a time, objects out.

:class:`ScanStream` is what :meth:`ScanClusterer.start_stream` returns, and what
:meth:`ScanClusterer.transform`, :meth:`~ScanClusterer.predict` and
:meth:`~ScanClusterer.detect` run over every run, so that streaming and batch give
identical results by construction: the decisions below never depend on *when* they are
taken (after every scan, or once at the end of a run), only on the scans seen.

A run's first scans are held until they give the run's scan period (from its first
32 stamp differences: ``ScanWindow.can_begin``), then ingested, as in batch.
This module decides finality; the scans are restored, clustered and linked as they
arrive by the window (``_window``), the final object-clusters are split, tested and
queued by ``_labelling`` with the rules of ``_vehicles``, and numbered and released by
``_release``.
The state keeps a *window* of scans: those not yet released plus a short history.  An
object-cluster (a component of the fragments the three-region merge joins) is **final**
once no fragment of it can link or merge with anything still to come: none of its
fragments has a cluster in the newest scan; no fragment still growing, or starting
later, can join one of its fragments; and enough scans (``max(min_length,
occluded_length)`` metres) follow it to tell whether its ends are hidden by an
occluder.  A final object-cluster is split and labelled at once.  Objects
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

from tunnelsense._records import RUN_LABELS
from tunnelsense._streaming import StreamState
from tunnelsense.street._classes import faces_end_on, stands_across
from tunnelsense.street._clustering import (
    components,
    concat,
    first_appearance,
)
from tunnelsense.street._geometry import HORIZON_STEP
from tunnelsense.street._labelling import _Labelling
from tunnelsense.street._objects import (
    ObjectProfiles,
    bridged,
    depth_region,
    merge_fragments,
    near_side,
    receding_side,
)
from tunnelsense.street._release import _Release
from tunnelsense.street._window import SIDE_HEIGHT, ScanWindow

__all__ = ["ScanStream"]

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
        """Scans held now (not yet released, plus history, plus a run's first scans
        waiting for its period)."""
        if self._run is None:
            return 0
        return len(self._run.records) + len(self._run.held or ())

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
            block = records[i:j]
            if run.held is not None:  # a run's first scans wait for its period
                run.held.extend(block)
                block = []
                if run.can_begin(run.held):
                    block = run.held
                    run.begin(block)
                    run.held = None
            out.extend(self._ingest(block))
            i = j
        return out

    def _ingest(self, block):
        """Ingest consecutive scans of the current run, deciding at every check."""
        out = []
        run = self._run
        k = 0
        while k < len(block):  # ingest up to each check (every CHECK_EVERY scans)
            stop = min(len(block), k + CHECK_EVERY - run.n_seen % CHECK_EVERY)
            run.ingest(block[k:stop])
            k = stop
            if run.n_seen % CHECK_EVERY == 0 and run.overdue_possible():
                out.extend(self._decide(ended=False, check=True))
        if run.decided_at != run.n_seen:
            out.extend(self._decide(ended=False))
        return out

    def _close(self):
        out = self._decide(ended=True)
        self._run = None
        return out

    def _decide(self, *, ended, check=False):
        if self._run is None:
            return []
        if ended and self._run.held:  # a run shorter than its period's reading
            held, self._run.held = self._run.held, None
            self._run.begin(held)
            return self._ingest(held) + self._decide(ended=True)
        out, self.n_objects = self._run.decide(self.n_objects, ended=ended, check=check)
        return out


class _RunState(_Release, _Labelling, ScanWindow):
    """A run's window of scans with its pending objects: finality and release."""

    def __init__(self, estimator, name):
        super().__init__(estimator, name)
        est = estimator
        self.decided_at = -1  # n_seen at the last decision
        self.held = []  # the run's first scans, until they give its period (None)
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
        if self.no_period:  # no metres: no object (ScanWindow.begin)
            self.object_id[self.object_id == 0] = -1
            return self._number_and_release(np.inf if ended else self.n_seen, ended,
                                            next_id)
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

    def _region_depth(self, objects, clusters, prof, *, reaching=False):
        """The depth that decides every object's region: the mean depth, or (``"near"``)
        the near side for the boundary of region III (a car half on the sidewalk), and
        (``"span"``) the far side for the boundary of region I (a body reaching into
        the parking lane from the traffic lane's side), or (``"across"``, the default)
        that far side only for a body standing across the street or obliquely (not
        along it, as traffic drives).  With ``reaching`` also, per
        object, whether its far side gave it (it reaches from region I into II)."""
        if self.est.region_depth == "mean":
            return (prof.depth, np.zeros(prof.n, dtype=bool)) if reaching else prof.depth
        across = np.zeros(prof.n, dtype=bool)
        side = near_side(objects, self.side[clusters], prof.n)
        lo, hi = self.edges(prof.first).T
        with np.errstate(invalid="ignore"):
            inside = (prof.depth >= hi) & (side < hi)
        depth = np.where(inside, np.maximum(side, lo), prof.depth)
        if self.est.region_depth in ("span", "across"):
            # the far side (median farthest body depth) reaching region II from
            # region I: a body across the lane edge stands in the parking lane
            far = -near_side(objects, -self.far[clusters], prof.n)
            if self.est.region_depth == "across":
                # a body seen by its faces only (a van taller than the sensor shows
                # no roof) is no deeper than its near side; an oblique one's near
                # side recedes along its flank into the parking lane: how far it
                # does stands for its far side (stands_across then asks it to be
                # oblique or across the street)
                reach = receding_side(objects, self.side[clusters], prof.n)
                with np.errstate(invalid="ignore"):
                    far = np.where((far < lo) & (reach >= lo), reach, far)
            with np.errstate(invalid="ignore"):
                across = (depth < lo) & (far >= lo) & (far < hi)
            if self.est.region_depth == "across":
                # ... when it stands across the street or obliquely (no traffic)
                est = self.est
                for o in np.flatnonzero(across):
                    mine = objects == o
                    c = clusters[mine]
                    across[o] = stands_across(
                        prof.position[mine], self.side[c], self.far[c],
                        self.metres_from(int(prof.first[o])),
                        width=est.motorbike_width, min_car_length=est.min_car_length,
                        depth=est.roof_width, longest=est.van_length)
                # (end_on_faces) a tall face shorter than a car along the street (a
                # van end on, its body out of sight behind it), not at the run's edges
                face = ((depth < lo) & ~across & (self.base + prof.first > 0)
                        & (prof.last + 1 < len(self.records)) & est.end_on_faces)
                for o in np.flatnonzero(face):
                    mine = objects == o
                    face[o] = faces_end_on(
                        prof.position[mine], self.flags[clusters[mine]],
                        self.metres_from(int(prof.first[o])),
                        width=est.motorbike_width, min_car_length=est.min_car_length)
                far = np.where(face, lo, far)
                across |= face
            depth = np.where(across, far, depth)
        return (depth, across) if reaching else depth

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
