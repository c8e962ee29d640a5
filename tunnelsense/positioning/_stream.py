"""The positioner's online state: one odometry sample in, one position out.

A fix is known only when its trajectory has ended, a few frames after the sign has
left the image; by then the camera is past the sign.  The fix is applied as a
delayed measurement: the state at the frame of the pass is corrected and the
odometry since is propagated again (cheap in 1-D).  A pass still ahead (the sign
left the image but the camera has not reached it yet) waits until the odometry
reaches it.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from tunnelsense.exceptions import InputFormatError
from tunnelsense.positioning._filter import forward, rts_smooth, transition
from tunnelsense.positioning._fixes import detection_table, estimate_pass
from tunnelsense.positioning._tables import ESTIMATE_COLUMNS

__all__ = ["FIX_COLUMNS", "PositionStream"]

#: Columns of the fix log (``PositionStream.fixes``).
FIX_COLUMNS = ("track_id", "first_frame", "last_frame", "pass_frame", "pass_distance",
               "indicator_id", "indicator_chainage", "predicted", "sigma",
               "mahalanobis", "accepted", "reason")


class PositionStream:
    """Stream state of a fitted :class:`TunnelPositioner` (``start_stream()``).

    ``push(frame, stamp, speed, ...)`` takes the odometry sample of the next frame
    (and any detections the detector has released since) and returns that frame's
    position at once; ``close()`` ends the tour and returns the whole table.
    """

    def __init__(self, positioner):
        p = positioner
        self._p = p
        self._map = np.asarray(p.indicator_chainage_, np.float64)
        self._ids = np.asarray(p.indicator_ids_, np.int64)
        self._frames, self._stamps, self._dist = [], [], []
        self._inc, self._qs, self._qc = [], [], []
        self._prior, self._prior_cov, self._post, self._post_cov = [], [], [], []
        self._index = {}
        self._fixes = {}  # frame index -> [(u, z, r)]
        self._tracks = {}  # track id -> ([index], [height])
        self._pending = []  # passes ahead of the odometry: (distance, log row)
        self._speed = None
        self._online = []
        self._log = []
        self._closed = False

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
        position : tuple
            ``(frame, stamp, chainage, sigma)`` of this frame.
        """
        self._advance(frame, stamp, speed)
        if detections is not None:
            self.add_detections(detections)
        return self._finish(frame if until is None else until)

    def _advance(self, frame, stamp, speed):
        """Append the frame's odometry sample; apply the passes it reaches."""
        if self._closed:
            raise RuntimeError("the stream is closed")
        frame, stamp, speed = int(frame), float(stamp), float(speed)
        if not np.isfinite(stamp) or not np.isfinite(speed):
            raise InputFormatError(f"frame {frame}: stamp and speed must be finite")
        if self._frames and (frame <= self._frames[-1] or stamp <= self._stamps[-1]):
            raise InputFormatError(
                f"frame {frame}: frames and stamps must increase (last frame "
                f"{self._frames[-1]} at {self._stamps[-1]} s)")
        p = self._p
        if not self._frames:
            x = np.array([float(p.initial_chainage), 1.0])
            P = np.diag([float(p.initial_sigma) ** 2,
                         float(p.scale_sigma) ** 2 if p.estimate_scale else 0.0])
            d = 0.0
        else:
            dt = stamp - self._stamps[-1]
            u = self._speed * dt
            q_s = (float(p.speed_noise) * dt) ** 2
            q_c = float(p.scale_drift) ** 2 * dt if p.estimate_scale else 0.0
            F, Q = transition(u, q_s, q_c)
            x, P = F @ self._post[-1], F @ self._post_cov[-1] @ F.T + Q
            d = self._dist[-1] + u
            self._inc.append(u)
            self._qs.append(q_s)
            self._qc.append(q_c)
        self._index[frame] = len(self._frames)
        self._frames.append(frame)
        self._stamps.append(stamp)
        self._dist.append(d)
        self._speed = speed
        self._prior.append(x)
        self._prior_cov.append(P)
        self._post.append(x)
        self._post_cov.append(P)
        # passes the odometry has now reached
        due = [item for item in self._pending if item[0] <= d]
        self._pending = [item for item in self._pending if item[0] > d]
        for dist, row in due:
            self._apply(dist, row)

    def _finish(self, until):
        """End the trajectories complete by ``until``; the last frame's position."""
        p = self._p
        horizon = int(until)
        for track in [t for t, (idx, _) in self._tracks.items()
                      if self._frames[idx[-1]] + int(p.max_gap) < horizon]:
            self._end_track(track)
        x, P = self._post[-1], self._post_cov[-1]
        out = (self._frames[-1], self._stamps[-1], float(x[0]),
               float(np.sqrt(max(P[0, 0], 0.0))))
        self._online.append(out)
        return out

    def close(self):
        """End the tour: use the last trajectories; return every frame's position.

        Returns
        -------
        positions : DataFrame
            ``frame, stamp, chainage, sigma``: what :meth:`push` returned (the
            filter), or, with ``smooth=True``, the RTS smoother's estimate given
            every fix.
        """
        if not self._closed:
            for track in list(self._tracks):
                self._end_track(track)
            for _, row in self._pending:
                row.update(accepted=False, reason="pass after the end of the tour")
                self._log.append(row)
            self._pending = []
            self._closed = True
        if not self._p.smooth or not self._frames:
            return pd.DataFrame(self._online, columns=list(ESTIMATE_COLUMNS))
        inc = np.asarray(self._inc)
        prior, post, prior_cov, post_cov = forward(
            self._prior[0], self._prior_cov[0], inc, np.asarray(self._qs),
            np.asarray(self._qc), self._fixes)
        x, cov = rts_smooth(inc, prior, post, prior_cov, post_cov)
        return pd.DataFrame({
            "frame": np.asarray(self._frames, np.int64),
            "stamp": np.asarray(self._stamps, np.float64),
            "chainage": x[:, 0],
            "sigma": np.sqrt(np.maximum(cov[:, 0, 0], 0.0)),
        })

    @property
    def fixes(self) -> pd.DataFrame:
        """Every trajectory's fix: where it passed, its indicator, kept or why not."""
        rows = sorted(self._log, key=lambda r: (r["last_frame"], r["track_id"]))
        return pd.DataFrame(rows, columns=list(FIX_COLUMNS))

    # ------------------------------------------------------------------ fixes
    def add_detections(self, detections):
        """Take detections released after the last push (e.g. at the tour's end).

        Their frames must have been pushed; the fixes they make are used at the next
        push or at :meth:`close`.
        """
        if self._closed:
            raise RuntimeError("the stream is closed")
        table = detection_table(detections)
        self._add_rows(table["frame"].tolist(), table["track_id"].tolist(),
                       table["bb_height"].tolist())

    def _add_rows(self, frames, tracks, heights):
        for f, t, h in zip(frames, tracks, heights, strict=True):
            i = self._index.get(f)
            if i is None:
                raise InputFormatError(
                    f"detections: frame {f} has no odometry sample before it (frames "
                    f"so far {self._frames[0]}..{self._frames[-1]})")
            idx, hs = self._tracks.setdefault(t, ([], []))
            idx.append(i)
            hs.append(h)

    def _end_track(self, track):
        p = self._p
        idx, hs = self._tracks.pop(track)
        idx, hs = np.asarray(idx), np.asarray(hs)
        keep = hs >= float(p.min_height)
        row = {"track_id": track, "first_frame": self._frames[idx[0]],
               "last_frame": self._frames[idx[-1]], "pass_frame": -1,
               "pass_distance": np.nan, "indicator_id": -1,
               "indicator_chainage": np.nan, "predicted": np.nan, "sigma": np.nan,
               "mahalanobis": np.nan, "accepted": False, "reason": ""}
        if keep.sum() < int(p.min_detections):
            row["reason"] = f"fewer than {p.min_detections} boxes of >= {p.min_height} px"
            self._log.append(row)
            return
        d = np.asarray(self._dist)[idx[keep]]
        slope = None
        if p.focal_length_px is not None and p.sign_height_m is not None:
            scale = self._post[idx[-1]][1]
            slope = -scale / (float(p.focal_length_px) * float(p.sign_height_m))
        dist, var = estimate_pass(d, hs[keep], slope=slope)
        row["pass_distance"] = dist
        if not np.isfinite(dist):
            row["reason"] = "the object does not approach"
            self._log.append(row)
            return
        ahead = dist - d[-1]
        if not (-2.0 <= ahead <= float(p.max_extrapolation)):
            row["reason"] = (f"passes {ahead:.1f} m past its last box (expected 0 to "
                             f"{p.max_extrapolation} m)")
            self._log.append(row)
            return
        if dist < self._dist[0]:
            row["reason"] = "passed before the first frame"
            self._log.append(row)
            return
        row["_var"] = var
        if dist > self._dist[-1]:
            self._pending.append((dist, row))
        else:
            self._apply(dist, row)

    def _apply(self, dist, row):
        """Gate and apply the fix of a pass at odometry distance ``dist``."""
        p = self._p
        var = row.pop("_var")
        k = int(np.searchsorted(self._dist, dist, side="right")) - 1
        u = dist - self._dist[k]
        x, P = self._post[k], self._post_cov[k]
        h = np.array([1.0, u])
        pred = float(h @ x)
        r = float(p.fix_sigma) ** 2 + x[1] ** 2 * var
        s = float(h @ P @ h) + r
        j = int(np.argmin(np.abs(self._map - pred)))
        m = abs(self._map[j] - pred) / np.sqrt(s)
        row.update(pass_frame=self._frames[k], indicator_id=int(self._ids[j]),
                   indicator_chainage=float(self._map[j]), predicted=pred,
                   sigma=float(np.sqrt(s)), mahalanobis=float(m))
        if m > float(p.gate):
            row.update(accepted=False, reason=f"outside the gate ({m:.1f} sigma)")
            self._log.append(row)
            return
        row.update(accepted=True, reason="")
        self._log.append(row)
        self._fixes.setdefault(k, []).append((u, float(self._map[j]), r))
        # delayed measurement: correct at the pass, propagate the odometry since
        prior, post, prior_cov, post_cov = forward(
            self._prior[k], self._prior_cov[k], self._inc[k:], self._qs[k:],
            self._qc[k:], self._fixes, start=k)
        n = len(self._frames)
        self._prior[k:n] = list(prior)
        self._prior_cov[k:n] = list(prior_cov)
        self._post[k:n] = list(post)
        self._post_cov[k:n] = list(post_cov)
