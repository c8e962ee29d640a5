"""Numbering and release of the street detector's final objects.

:class:`_Release` (mixed into the run state of ``_stream``) gives the objects that
``_labelling`` queued their ids in the order of their first scan, once no object that
is not yet final can start before them; extends those cut short by an occluder into the
hidden scans (``_vehicles.extend_occluded``); releases a scan's record once every
object in it has its id and no later object can be extended over it; and drops the
scans and clusters no decision can need any more.
"""

from __future__ import annotations

import numpy as np

from tunnelsense._payload import FINISHED_OBJECTS
from tunnelsense._records import RUN_LABELS
from tunnelsense.street._classes import vehicle_class
from tunnelsense.street._clustering import expand_ranges
from tunnelsense.street._history import metres_from
from tunnelsense.street._vehicles import extend_occluded

__all__ = []


class _Release:
    """Numbering, extension into hidden scans, release and trimming of a run's window
    (the state's attributes are set by ``_stream._RunState``)."""

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
                # a motorbike is shorter than the shortest car, and a vehicle seen end
                # on shows its width along the street: not extended beyond it
                short = kind == "motorbike" or q["end_on"]
                first, last = self._extend(q, est.occluded_length if not short
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
                float(cum[last - base + 1] - cum[first - base] - self.gap[first - base]),
                q["top"],
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
        first, last = extend_occluded(metres_from(self.cum, self.gap, first), first,
                                      last, lowest, highest, length)
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
