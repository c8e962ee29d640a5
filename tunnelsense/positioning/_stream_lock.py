"""The position stream without a start: the passes go to the hypotheses over the map
(:class:`~tunnelsense.positioning._lock.LockOn`) until one wins; the filter then
starts from it.  After several passes rejected in a row, the position is dropped
and found again the same way.
"""

from __future__ import annotations

import math

import numpy as np

from tunnelsense.positioning._lock import LockOn
from tunnelsense.positioning._stream_state import _NAN5

__all__ = []


class _LockingOn:
    """Lock-on of :class:`PositionStream` (mixed into it)."""

    def _start_lockon(self, start=0.0):
        p = self._p
        self._lock_k = None
        self._lock_q = None  # cumulative noise at the last pass given to the lock-on
        self._lockon = LockOn(
            self._map, scale=self._c0, scale_sigma=math.sqrt(self._sc2),
            fix_sigma=p.fix_sigma, gate=p.gate, miss_rate=p.miss_rate,
            false_pass_rate=p.false_pass_rate / 1000.0, margin=p.lock_margin,
            min_passes=p.lock_passes, start=start, clearance=p.max_extrapolation,
            sides=self._sides, side_error=p.side_error,
            side_margin=p.side_margin, side_passes=p.side_passes)

    def lock_status(self) -> str:
        """A sentence on the lock: where it was taken, or why there is none."""
        if self.lock_frame == "start":
            return "started from the given chainage"
        if self.lock_frame is not None:
            return f"locked on to the map at frame {self.lock_frame}"
        lk = self._lockon
        places = lk.n_explaining() if lk is not None else 0
        if lk is None or lk.n_passes == 0:
            return "not locked on: no indicator pass"
        if lk.side_withheld == "side_margin":
            return (f"not locked on: after {lk.n_passes} passes the side of the road "
                    "singles out a place, but the spacing of the passes alone does not "
                    "rank it first (side_margin)")
        if lk.side_withheld == "side_passes":
            return (f"not locked on: after {lk.n_passes} passes the side of the road "
                    f"singles out a place; a lock that needs it waits for "
                    f"{lk.side_passes} passes (side_passes)")
        if places > 1:
            return (f"not locked on: after {lk.n_passes} passes, {places} places of the "
                    "map explain them equally (a map with evenly spaced indicators "
                    "needs a start: give the chainage of the first frame)")
        return f"not locked on: {lk.n_passes} passes do not single out a place yet"

    def _to_lockon(self, dist, var, k, u, row):
        """Give a pass to the hypotheses over the map; lock when one wins."""
        W = self._W
        cq = self._cq[k % W].tolist()
        q = (0.0, 0.0) if self._lock_q is None else (cq[0] - self._lock_q[0],
                                                     cq[1] - self._lock_q[1])
        self._lock_q = cq
        # the scale the boxes measure (sign size known) is not given to the
        # hypotheses: with a false pass and a missed sign among the first passes, a
        # scale known that well let a wrong place explain them best (1 tour in 200
        # with such failures); it is used from the lock on
        lock = self._lockon.add(dist, var, q[0], q[1], tag=(k, u, var, row),
                                side=row.get("_side", 0),
                                side_t=row.get("_side_t", math.inf))
        row.update(accepted=False, reason=(f"{row['reason']}; " if row["reason"] else "")
                   + "locking on")
        if lock is not None:
            self._take_lock(lock, k, u)

    def _silence(self, horizon):
        """No pass since the last one up to the frame ``horizon`` (every trajectory
        whose last box came before it has been ended): lock if the indicators the
        rivals put behind the vehicle by then, unseen, single out a place."""
        n, W = self._n, self._W
        lo = max(0, n - W)
        k = lo + int(np.searchsorted(self._ordered(self._fr, lo), horizon)) - 1
        if k < lo:
            return
        # a pass up to 2 m before a trajectory's last box is taken (_end_track)
        lock = self._lockon.silence(float(self._d[k % W]), 2.0)
        if lock is not None:
            (kk, uu, _, _), _ = lock["passes"][-1]
            if kk >= lo:  # the last pass is still held
                self._take_lock(lock, kk, uu, at=k)

    def _take_lock(self, lock, k, u, at=None):
        """Start the filter from the lock's state at the last pass (frame ``k``,
        ``u`` m of odometry after it); the explained passes become its fixes.
        ``at``: the frame index where it was decided (default ``k``)."""
        p, W = self._p, self._W
        s, c = lock["state"]
        P = lock["cov"]
        # the state at the pass, moved back to its frame (u before it)
        a, b, e = P[0, 0], P[0, 1], P[1, 1]
        x = (s - c * u, c, a - 2 * u * b + u * u * e, b - u * e, e)
        for (kk, uu, vv, rr), j in lock["passes"]:
            if j < 0:
                continue
            z = float(self._map[j])
            rr.pop("_noise2", None)
            if self.fix_list is not None:
                self.fix_list.append((kk, uu, z, float(p.fix_sigma) ** 2 + c * c * vv))
            x = self._scale_fix(x, k, rr, held=False)
            rr.update(accepted=True, reason="lock-on", indicator_id=int(self._ids[j]),
                      indicator_chainage=z)
        self._lock_k = k
        self.lock_frame = int(self._fr[(k if at is None else at) % W])
        self._lockon = None
        self._prior[k % W] = x
        self._post[k % W] = x
        self._propagate(k)

    def _unlock(self):
        """The gate has rejected several passes in a row: find the place again."""
        rejected, self._rejected = self._rejected, []
        self._start_lockon(start=None)  # where it was since the lock: unknown
        self.lock_frame = None
        self.relocked = True
        self.fix_list = [] if self.fix_list is not None else None
        self._fixes = {}
        self._early = []
        n, W = self._n, self._W
        first = rejected[0][2]
        for i in range(max(first, n - W), n):  # unknown from the first rejected pass
            self._post[i % W] = _NAN5
        for dist, var, k, u, row in rejected:
            if k < n - W:
                continue
            if self._lock_k is None:
                self._to_lockon(dist, var, k, u, row)
            elif k >= self._lock_k:
                self._gate(dist, var, k, u, row)
