"""The positioner's online state: one odometry sample in, one position out.

A fix is known only when its trajectory has ended, a few frames after the sign has
left the image.  When the camera is already past the sign, the fix is applied as a
delayed measurement: the state at the frame of the pass is corrected and the
odometry since is propagated again (cheap in 1-D).  A pass still ahead (the sign
left the image some metres before the camera reaches it) is a measurement of the
state now, ``z = s + c u`` with ``u`` the odometry distance still to go, applied at
once: the position is corrected before the camera passes the sign.

Memory does not grow with the tour: the state of the last ``window`` frames is held
in fixed-size arrays (a ring), enough for any delayed pass; with ``smooth`` the
stream is a fixed-lag smoother that releases each frame's smoothed position once at
least ``window // 2`` later frames have been seen.  Without a start, the stream locks
on to the map from the passes (:class:`~tunnelsense.positioning._lock.LockOn`); until
then its rows have ``locked=False`` and no chainage.

The class is put together from private modules: the trajectories in and their
passes (``_stream_tracks``), the lock-on (``_stream_lock``), the rows, the Kalman
update and the fixed-lag smoother's backward pass (``_stream_state``); here are
the filter's frames, its fixes and the gate.
"""

from __future__ import annotations

import math
from collections import deque
from typing import NamedTuple

import numpy as np
import pandas as pd

from tunnelsense.exceptions import InputFormatError
from tunnelsense.positioning._side import sides_used
from tunnelsense.positioning._stream_lock import _LockingOn
from tunnelsense.positioning._stream_state import (
    _NAN5,
    _LaggedRelease,
    _row,
    _Rows,
    _update,
)
from tunnelsense.positioning._stream_tracks import _TrackInput

__all__ = ["FIX_COLUMNS", "Position", "PositionStream"]

#: Columns of the fix log (``PositionStream.fixes``).
FIX_COLUMNS = ("track_id", "first_frame", "last_frame", "pass_frame", "pass_distance",
               "indicator_id", "indicator_chainage", "predicted", "sigma",
               "mahalanobis", "accepted", "reason")


class Position(NamedTuple):
    """One frame's position (a row of ``ESTIMATE_COLUMNS``)."""

    frame: int
    stamp: float
    chainage: float
    sigma: float
    locked: bool
    scale: float
    scale_sigma: float


class PositionStream(_TrackInput, _LockingOn, _LaggedRelease):
    """Stream state of a fitted :class:`TunnelPositioner` (``start_stream()``).

    ``push(frame, stamp, speed, ...)`` takes the odometry sample of the next frame
    (and any detections the detector has released since) and returns that frame's
    position at once; :meth:`drain` takes the rows final so far (the pushed
    positions, or with ``smooth`` the fixed-lag smoother's), :meth:`close` ends the
    tour and returns the rows not yet drained.
    """

    def __init__(self, positioner, *, lagged=None, keep_fixes=False):
        p = positioner
        self._p = p
        self._map = np.asarray(p.indicator_chainage_, np.float64)
        self._ids = np.asarray(p.indicator_ids_, np.int64)
        self._sides = np.asarray(p.indicator_side_, np.int64)
        # both walls named: each pass's side is read (for the lock-on, or a relock)
        self._side_used = sides_used(self._sides, p.side_error) is not None
        W = self._W = max(int(p.window), 2)
        self._fr = np.zeros(W, np.int64)
        self._st, self._d, self._u = np.zeros(W), np.zeros(W), np.zeros(W)
        self._cq = np.zeros((W, 2))  # cumulative process noise (chainage, scale)
        self._prior, self._post = np.zeros((W, 5)), np.zeros((W, 5))
        self._n = 0
        self._lagged = bool(p.smooth) if lagged is None else bool(lagged)
        self._released = 0
        self._speed = None
        self._c0 = float(p.initial_scale)
        self._sc2 = float(p.scale_sigma) ** 2 if p.estimate_scale else 0.0
        self._fixes = {}  # frame index -> [(u, z, r)], applied online
        # (frame index, u, z, r) of every fix, for the whole-tour smoother (offline)
        self.fix_list = [] if keep_fixes else None
        self.relocked = False
        # track id -> [distances, heights, last frame, last index, first frame,
        # box centres]
        self._tracks = {}
        # relative box-height noise (squared) of the last long trajectories: their
        # median is the least noise a short trajectory's pass is given
        self._box_noise = deque(maxlen=31)
        self._box_noise_known = None  # the pooled noise2, once three are seen
        # fixes used before it: (frame index, index among its fixes, noise2, index in
        # fix_list)
        self._early = []
        self._log = []
        self._rows = _Rows()
        self._closed = False
        self._rejected = []  # consecutive passes the gate rejected
        self.lock_frame = None
        if p.initial_chainage is None:
            self._start_lockon()
        else:
            self._lockon, self._lock_k = None, 0
            self.lock_frame = "start"

    def pooled_box_noise(self):
        """Median squared relative box-height noise of the long trajectories seen
        (None before three)."""
        if len(self._box_noise) < 3:
            return None
        return float(np.median(self._box_noise))

    @property
    def locked(self) -> bool:
        """Whether the stream knows where it is on the map."""
        return self._lock_k is not None

    # ------------------------------------------------------------------ online
    def push(self, frame, stamp, speed, yaw_rate=0.0, detections=None, *, until=None):
        """Take the odometry sample of the next frame; return its position.

        Parameters
        ----------
        frame : int
            Frame number, increasing.
        stamp : float
            Time (s), increasing.
        speed : float
            Odometry speed (m/s) from this frame to the next.
        yaw_rate : float, default=0.0
            Not used by the distance filter (the chainage is an arc length).
        detections : DataFrame, sequence of FrameRecord or None, default=None
            Detections released by the detector since the last push (of this frame
            or earlier ones).
        until : int or None, default=None
            The detector's output is final up to this frame (the last frame it has
            released); a trajectory is complete when this is more than ``max_gap``
            frames past its last box.  None: this frame (each frame's detections
            pushed with it).

        Returns
        -------
        position : Position
            ``(frame, stamp, chainage, sigma, locked, scale, scale_sigma)`` of this
            frame, what the filter knows now (NaN chainage while not locked).
        """
        self._advance(frame, stamp, speed)
        if detections is not None:
            self.add_detections(detections)
        return self._finish(frame if until is None else until)

    def _slot(self, i):
        return i % self._W

    def _advance(self, frame, stamp, speed):
        """Append the frame's odometry sample; apply the passes it reaches."""
        if self._closed:
            raise RuntimeError("the stream is closed")
        frame, stamp, speed = int(frame), float(stamp), float(speed)
        if not math.isfinite(stamp) or not math.isfinite(speed):
            raise InputFormatError(f"frame {frame}: stamp and speed must be finite")
        n, W, p = self._n, self._W, self._p
        if n:
            j = (n - 1) % W
            last_frame, last_stamp = int(self._fr[j]), float(self._st[j])
            if frame <= last_frame or stamp <= last_stamp:
                raise InputFormatError(
                    f"frame {frame}: frames and stamps must increase (last frame "
                    f"{last_frame} at {last_stamp} s)")
            if self._lagged and n - self._released >= W:
                self._release(n - W // 2)
            dt = stamp - last_stamp
            u = self._speed * dt
            q_s = (float(p.speed_noise) * dt) ** 2
            q_c = float(p.scale_drift) ** 2 * dt if p.estimate_scale else 0.0
            s, c, a, b, e = self._post[j].tolist()
            x = (s + u * c, c, a + 2 * u * b + u * u * e + q_s, b + u * e, e + q_c)
            d = float(self._d[j]) + u
            cq0, cq1 = self._cq[j].tolist()
            cq = (cq0 + q_s, cq1 + q_c)
        else:
            u, d, cq = 0.0, 0.0, (0.0, 0.0)
            if self._lock_k is None:
                x = _NAN5
            else:
                x = (float(p.initial_chainage), self._c0,
                     float(p.initial_sigma) ** 2, 0.0, self._sc2)
        i = n % W
        self._fr[i], self._st[i], self._d[i], self._u[i] = frame, stamp, d, u
        self._cq[i] = cq
        self._prior[i] = x
        self._post[i] = x
        self._fixes.pop(n - W, None)
        self._n = n + 1
        self._speed = speed

    def _finish(self, until):
        """End the trajectories complete by ``until``; the last frame's position."""
        horizon = int(until) - int(self._p.max_gap)
        if self._tracks:
            for track in [t for t, v in self._tracks.items() if v[2] < horizon]:
                self._end_track(track)
        if self._lockon is not None and self._lockon.n_passes >= self._lockon.min_passes:
            self._silence(horizon)
        j = (self._n - 1) % self._W
        row = _row(int(self._fr[j]), float(self._st[j]), self._post[j].tolist())
        if not self._lagged:
            self._rows.add(row)
        return Position(row[0], row[1], row[2], row[3], bool(row[4]), row[5], row[6])

    def drain(self) -> pd.DataFrame:
        """The rows final since the last call (online: every pushed frame's; with
        ``smooth``: the fixed-lag smoother's, ``window // 2`` frames or more behind)."""
        return self._rows.take()

    def close(self):
        """End the tour: use the last trajectories; return the rows not yet drained.

        Returns
        -------
        positions : DataFrame
            ``frame, stamp, chainage, sigma, locked, scale, scale_sigma``: what
            :meth:`push` returned (the filter), or, with ``smooth``, the fixed-lag
            smoother's estimate.
        """
        if not self._closed:
            for track in list(self._tracks):
                self._end_track(track)
            self._closed = True
            if self._lagged:
                self._release(self._n)
        return self._rows.take()

    @property
    def fixes(self) -> pd.DataFrame:
        """Every trajectory's fix not yet drained: where it passed, its indicator,
        kept or why not."""
        rows = sorted(self._log, key=lambda r: (r["last_frame"], r["track_id"]))
        return pd.DataFrame(rows, columns=list(FIX_COLUMNS))

    def drain_fixes(self) -> pd.DataFrame:
        """:attr:`fixes` so far, then forgotten (memory stays flat); held while
        locking on, since the lock names the indicators of the passes before it."""
        if self._lockon is not None and self._lockon.n_passes:
            return pd.DataFrame(columns=list(FIX_COLUMNS))
        out = self.fixes
        self._log = []
        return out

    # ------------------------------------------------------------------ fixes
    def _apply(self, dist, row):
        """Gate and apply the fix of a pass at odometry distance ``dist``."""
        var = row.pop("_var")
        n, W = self._n, self._W
        lo = max(0, n - W)
        k = lo + int(np.searchsorted(self._ordered(self._d, lo), dist, side="right")) - 1
        self._log.append(row)
        if k < lo:
            row.update(accepted=False, reason=f"pass older than the positioner's window "
                       f"({W} frames)")
            return
        u = dist - float(self._d[k % W])
        row.update(pass_frame=int(self._fr[k % W]))
        if self._lock_k is None:
            self._to_lockon(dist, var, k, u, row)
            return
        if k < self._lock_k:
            row.update(accepted=False, reason="pass before the lock")
            return
        self._gate(dist, var, k, u, row)

    def _gate(self, dist, var, k, u, row):
        """Associate a pass with the nearest indicator; use it if within the gate."""
        p, W = self._p, self._W
        x = self._post[k % W].tolist()
        s, c, a, b, e = x
        pred = s + u * c
        r = float(p.fix_sigma) ** 2 + c * c * var
        S = a + 2 * u * b + u * u * e + r
        j = int(np.argmin(np.abs(self._map - pred)))
        m = abs(self._map[j] - pred) / math.sqrt(S)
        row.update(indicator_id=int(self._ids[j]), indicator_chainage=float(self._map[j]),
                   predicted=pred, sigma=math.sqrt(S), mahalanobis=float(m))
        if m > float(p.gate):
            row.update(accepted=False, reason=f"outside the gate ({m:.1f} sigma)")
            self._rejected.append((dist, var, k, u, row))
            if p.relock_after and len(self._rejected) >= int(p.relock_after):
                self._unlock()
            return
        self._rejected = []
        row.update(accepted=True, reason="")
        z = float(self._map[j])
        here = self._fixes.setdefault(k, [])
        here.append((u, z, r))
        noise2 = row.pop("_noise2", math.nan)
        if self._box_noise_known is None:  # weighted again once the noise is known
            self._early.append((k, len(here) - 1, noise2,
                                None if self.fix_list is None else len(self.fix_list)))
        if self.fix_list is not None:
            self.fix_list.append((k, u, z, r))
        # delayed measurement: correct at the pass, propagate the odometry since
        x = _update(x, u, z, r)
        x = self._scale_fix(x, k, row)
        self._post[k % W] = x
        self._propagate(k)

    def _scale_fix(self, x, k, row, held=True):
        """Use the scale a kept pass's box growth measured (``focal_length_px`` and
        ``sign_height_m`` given), if it agrees with the state's within the gate.
        ``held``: also kept with frame ``k``'s fixes (not at the lock, whose state
        is set at ``k`` with it)."""
        c_meas, var = row.pop("_scale", (math.nan, math.nan))
        if not (c_meas == c_meas and var == var):
            return x
        p = self._p
        r = var + (c_meas * float(p.size_sigma)) ** 2
        if abs(c_meas - x[1]) > float(p.gate) * math.sqrt(x[4] + r):
            return x
        if held:
            self._fixes.setdefault(k, []).append((math.nan, c_meas, r))
        if self.fix_list is not None:
            self.fix_list.append((k, math.nan, c_meas, r))
        return _update(x, math.nan, c_meas, r)

    def _reweight_early(self):
        """The box noise is now known: the fixes used before it, whose trajectories'
        own noise was smaller, get the variance it gives (the first pass, cut short by
        the start of the record, fits a dozen boxes well by chance); the state is
        propagated again from the first of them."""
        pooled, f2 = self._box_noise_known, float(self._p.fix_sigma) ** 2
        first = None
        for k, idx, noise2, at in self._early:
            if k < self._n - self._W or not 0.0 < noise2 < pooled:
                continue
            u, z, r = self._fixes[k][idx]
            r = f2 + (r - f2) * pooled / noise2
            self._fixes[k][idx] = (u, z, r)
            if at is not None:
                self.fix_list[at] = (k, u, z, r)
            first = k if first is None else min(first, k)
        self._early = []
        if first is not None:
            x = self._prior[first % self._W].tolist()
            for fu, z, r in self._fixes[first]:
                x = _update(x, fu, z, r)
            self._post[first % self._W] = x
            self._propagate(first)

    def _propagate(self, k):
        """Propagate the post state of frame ``k`` to the last frame, with the fixes."""
        post, prior, W = self._post, self._prior, self._W
        x = post[k % W].tolist()
        for i in range(k + 1, self._n):
            sl = i % W
            u = float(self._u[sl])
            q_s = float(self._cq[sl, 0] - self._cq[(i - 1) % W, 0])
            q_c = float(self._cq[sl, 1] - self._cq[(i - 1) % W, 1])
            s, c, a, b, e = x
            x = (s + u * c, c, a + 2 * u * b + u * u * e + q_s, b + u * e, e + q_c)
            prior[sl] = x
            for fu, z, r in self._fixes.get(i, ()):
                x = _update(x, fu, z, r)
            post[sl] = x
