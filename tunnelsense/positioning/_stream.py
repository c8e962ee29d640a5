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
"""

from __future__ import annotations

import math
from collections import deque
from typing import NamedTuple

import numpy as np
import pandas as pd

from tunnelsense.exceptions import InputFormatError
from tunnelsense.positioning._fixes import (
    _estimate_pass,
    detection_table,
    scale_from_slope,
)
from tunnelsense.positioning._lock import LockOn
from tunnelsense.positioning._tables import ESTIMATE_COLUMNS

__all__ = ["FIX_COLUMNS", "Position", "PositionStream"]

#: A trajectory with this many degrees of freedom (boxes beyond the line's two
#: parameters) tells the detector's box-height noise (its estimate within a third).
_NOISE_DOF = 20

#: Columns of the fix log (``PositionStream.fixes``).
FIX_COLUMNS = ("track_id", "first_frame", "last_frame", "pass_frame", "pass_distance",
               "indicator_id", "indicator_chainage", "predicted", "sigma",
               "mahalanobis", "accepted", "reason")

_NAN5 = (math.nan,) * 5


class Position(NamedTuple):
    """One frame's position (a row of ``ESTIMATE_COLUMNS``)."""

    frame: int
    stamp: float
    chainage: float
    sigma: float
    locked: bool
    scale: float
    scale_sigma: float


class _Rows:
    """Released rows, in fixed-size numpy blocks until taken."""

    def __init__(self):
        self._blocks, self._buf, self._n = [], np.empty((1024, 7)), 0

    def add(self, row):
        if self._n == len(self._buf):
            self._blocks.append(self._buf)
            self._buf, self._n = np.empty((1024, 7)), 0
        self._buf[self._n] = row
        self._n += 1

    def take(self) -> pd.DataFrame:
        a = np.concatenate([*self._blocks, self._buf[:self._n]])
        self._blocks, self._buf, self._n = [], np.empty((1024, 7)), 0
        return rows_table(a)


def rows_table(a) -> pd.DataFrame:
    """An ``(n, 7)`` array of rows as the positions table."""
    a = np.asarray(a, np.float64).reshape(-1, 7)
    return pd.DataFrame({
        "frame": a[:, 0].astype(np.int64), "stamp": a[:, 1], "chainage": a[:, 2],
        "sigma": a[:, 3], "locked": a[:, 4] > 0, "scale": a[:, 5],
        "scale_sigma": a[:, 6]}, columns=list(ESTIMATE_COLUMNS))


def _row(frame, stamp, x):
    """The output row of a state ``x = (s, c, P00, P01, P11)``."""
    s, c, a, _, e = x
    if s != s:  # not locked
        return (frame, stamp, math.nan, math.nan, 0.0, math.nan, math.nan)
    return (frame, stamp, s, math.sqrt(max(a, 0.0)), 1.0, c, math.sqrt(max(e, 0.0)))


def _update(x, u, z, r):
    """Kalman update of ``x = (s, c, P00, P01, P11)`` with ``z = s + c u`` (NaN
    ``u``: a measurement of the scale, ``z = c``)."""
    s, c, a, b, e = x
    if u != u:
        S = e + r
        k0, k1 = b / S, e / S
        res = z - c
        return (s + k0 * res, c + k1 * res, a - k0 * k0 * S, b - k0 * k1 * S,
                e - k1 * k1 * S)
    ha, hb = a + u * b, b + u * e  # P h
    S = ha + u * hb + r
    k0, k1 = ha / S, hb / S
    res = z - (s + u * c)
    return (s + k0 * res, c + k1 * res, a - k0 * k0 * S, b - k0 * k1 * S,
            e - k1 * k1 * S)


class PositionStream:
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
        self._tracks = {}  # track id -> [distances, heights, last frame, last index]
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

    def _start_lockon(self, start=0.0):
        p = self._p
        self._lock_k = None
        self._lock_q = None  # cumulative noise at the last pass given to the lock-on
        self._lockon = LockOn(
            self._map, scale=self._c0, scale_sigma=math.sqrt(self._sc2),
            fix_sigma=p.fix_sigma, gate=p.gate, miss_rate=p.miss_rate,
            false_pass_rate=p.false_pass_rate / 1000.0, margin=p.lock_margin,
            min_passes=p.lock_passes, start=start, clearance=p.max_extrapolation)

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

    def _release(self, upto):
        """Smooth the held frames backwards; release those before ``upto``."""
        lo, n, W = self._released, self._n, self._W
        if upto <= lo:
            return
        post, prior, us = self._post, self._prior, self._u
        nxt = post[(n - 1) % W].tolist()  # smoothed state of frame i + 1
        out = []
        for i in range(n - 1, lo - 1, -1):
            sl = i % W
            x = post[sl].tolist()
            if i < n - 1 and x[0] == x[0] and nxt[0] == nxt[0]:
                sn = (i + 1) % W
                A, B, E = prior[sn, 2], prior[sn, 3], prior[sn, 4]
                xp0, xp1 = prior[sn, 0], prior[sn, 1]
                u = us[sn]
                s, c, a, b, e = x
                # G = P F^T M^-1, F = [[1, u], [0, 1]], M the prior covariance at i+1
                m00, m01, m10, m11 = a + b * u, b, b + e * u, e
                det = A * E - B * B
                if E > 0 and det > 1e-12 * A * E:
                    g00 = (m00 * E - m01 * B) / det
                    g01 = (m01 * A - m00 * B) / det
                    g10 = (m10 * E - m11 * B) / det
                    g11 = (m11 * A - m10 * B) / det
                else:  # no scale state
                    g00, g01, g10, g11 = m00 / A, 0.0, 0.0, 0.0
                d0, d1 = nxt[0] - xp0, nxt[1] - xp1
                D00, D01, D11 = nxt[2] - A, nxt[3] - B, nxt[4] - E
                # G D G^T
                t00, t01 = g00 * D00 + g01 * D01, g00 * D01 + g01 * D11
                t10, t11 = g10 * D00 + g11 * D01, g10 * D01 + g11 * D11
                x = (s + g00 * d0 + g01 * d1, c + g10 * d0 + g11 * d1,
                     a + t00 * g00 + t01 * g01, b + t00 * g10 + t01 * g11,
                     e + t10 * g10 + t11 * g11)
            nxt = x
            if i < upto:
                out.append(_row(int(self._fr[sl]), float(self._st[sl]), x))
        for row in reversed(out):
            self._rows.add(row)
        self._released = upto

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
        if places > 1:
            return (f"not locked on: after {lk.n_passes} passes, {places} places of the "
                    "map explain them equally (a map with evenly spaced indicators "
                    "needs a start: give the chainage of the first frame)")
        return f"not locked on: {lk.n_passes} passes do not single out a place yet"

    # ------------------------------------------------------------------ fixes
    def add_detections(self, detections):
        """Take detections released after the last push (e.g. at the tour's end).

        Their frames must have been pushed; the fixes they make are used at the next
        push or at :meth:`close`.
        """
        if self._closed:
            raise RuntimeError("the stream is closed")
        if isinstance(detections, list) and all(
                hasattr(r, "payload") for r in detections):
            frames, tracks, heights = _from_records(detections)
        else:
            table = detection_table(detections)
            frames, tracks, heights = (table["frame"].tolist(),
                                       table["track_id"].tolist(),
                                       table["bb_height"].tolist())
        self._add_rows(frames, tracks, heights)

    def _index(self, frame):
        """The index of a frame still held; None when it has left the window."""
        n, W = self._n, self._W
        j = (n - 1) % W
        if n and int(self._fr[j]) == frame:
            return n - 1
        lo = max(0, n - W)
        order = self._ordered(self._fr, lo)
        k = int(np.searchsorted(order, frame))
        if k < len(order) and order[k] == frame:
            return lo + k
        return None

    def _ordered(self, a, lo):
        """``a`` of the frames ``lo .. n-1`` in frame order (a view when it can)."""
        n, W = self._n, self._W
        i0, i1 = lo % W, (n - 1) % W + 1
        return a[i0:i1] if i0 < i1 else np.concatenate([a[i0:], a[:i1]])

    def _add_rows(self, frames, tracks, heights):
        last_f, last_k = None, None
        for f, t, h in zip(frames, tracks, heights, strict=True):
            if f != last_f:
                k = self._index(f)
                if k is None:
                    n, W = self._n, self._W
                    first = int(self._fr[max(0, n - W) % W]) if n else None
                    raise InputFormatError(
                        f"detections: frame {f} has no odometry sample held (frames "
                        f"held {first}..{int(self._fr[(n - 1) % W]) if n else None}; "
                        f"the positioner holds the last window={W} frames)")
                last_f, last_k = f, k
            entry = self._tracks.get(t)
            if entry is None:
                entry = self._tracks[t] = [[], [], f, last_k, f]
            entry[0].append(float(self._d[last_k % self._W]))
            entry[1].append(h)
            entry[2], entry[3] = f, last_k

    def _end_track(self, track):
        p = self._p
        d, hs, last_frame, last_k, first_frame = self._tracks.pop(track)
        d, hs = np.asarray(d), np.asarray(hs, np.float64)
        keep = hs >= float(p.min_height)
        row = {"track_id": track, "first_frame": first_frame,
               "last_frame": last_frame, "pass_frame": -1,
               "pass_distance": np.nan, "indicator_id": -1,
               "indicator_chainage": np.nan, "predicted": np.nan, "sigma": np.nan,
               "mahalanobis": np.nan, "accepted": False, "reason": ""}
        if keep.sum() < int(p.min_detections):
            row["reason"] = f"fewer than {p.min_detections} boxes of >= {p.min_height} px"
            self._log.append(row)
            return
        d = d[keep]
        pooled = self.pooled_box_noise()
        floor = None if pooled is None else math.sqrt(pooled)
        if (p.focal_length_px is not None and p.sign_height_m is not None
                and p.estimate_scale):
            # the sign's size is known: its box growth measures the scale (the pass
            # is still fitted with a free slope: a slope fixed by a scale not yet
            # known would bias it)
            size = float(p.focal_length_px) * float(p.sign_height_m)
            row["_scale"] = scale_from_slope(d, hs[keep], size, floor)
        dist, var, noise2, dof = _estimate_pass(d, hs[keep], None, floor)
        row["pass_distance"] = dist
        if not np.isfinite(dist):
            row["reason"] = "the object does not approach"
            self._log.append(row)
            return
        if dof >= _NOISE_DOF:
            self._box_noise.append(noise2)
            if self._box_noise_known is None and len(self._box_noise) >= 3:
                self._box_noise_known = self.pooled_box_noise()
                self._reweight_early()
        ahead = dist - d[-1]
        if not (-2.0 <= ahead <= float(p.max_extrapolation)):
            row["reason"] = (f"passes {ahead:.1f} m past its last box (expected 0 to "
                             f"{p.max_extrapolation} m)")
            self._log.append(row)
            return
        if dist < 0.0:
            row["reason"] = "passed before the first frame"
            self._log.append(row)
            return
        row["_var"], row["_noise2"] = var, noise2
        self._apply(dist, row)

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

    # ------------------------------------------------------------------ lock-on
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
        lock = self._lockon.add(dist, var, q[0], q[1], tag=(k, u, var, row))
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


def _from_records(records):
    """``frame, track_id, bb_height`` lists of the detector's frame records."""
    frames, tracks, heights = [], [], []
    for record in records:
        det = record.payload.get("detections") if record.payload else None
        if det is None:
            raise InputFormatError(
                "detections: expected frame records from the indicator pipeline's "
                "predict (payload['detections']) or a results table")
        det = np.asarray(det, np.float64).reshape(-1, 6)
        if not len(det):
            continue
        h = det[:, 3]
        if not np.all(np.isfinite(h)) or np.any(h <= 0):
            raise InputFormatError("detections: bb_height must be finite and positive")
        order = np.argsort(det[:, 4], kind="stable")
        frames.extend([int(record.frame)] * len(det))
        tracks.extend(det[order, 4].astype(np.int64).tolist())
        heights.extend(h[order].tolist())
    return frames, tracks, heights
