"""The position stream's input: the detector's boxes, gathered per trajectory, and
each ended trajectory's pass (where it passed the camera, in odometry distance).
"""

from __future__ import annotations

import math

import numpy as np

from tunnelsense.exceptions import InputFormatError
from tunnelsense.positioning._defaults import SIDE_MIN_T
from tunnelsense.positioning._fixes import (
    _estimate_pass,
    detection_table,
    scale_from_slope,
)
from tunnelsense.positioning._side import side_statistic

__all__ = []

#: A trajectory with this many degrees of freedom (boxes beyond the line's two
#: parameters) tells the detector's box-height noise (its estimate within a third).
_NOISE_DOF = 20


class _TrackInput:
    """Trajectories in, passes out (mixed into :class:`PositionStream`)."""

    def add_detections(self, detections):
        """Take detections released after the last push (e.g. at the tour's end).

        Their frames must have been pushed; the fixes they make are used at the next
        push or at :meth:`close`.
        """
        if self._closed:
            raise RuntimeError("the stream is closed")
        if isinstance(detections, list) and all(
                hasattr(r, "payload") for r in detections):
            frames, tracks, heights, centres = _from_records(detections)
        else:
            table = detection_table(detections)
            frames, tracks, heights = (table["frame"].tolist(),
                                       table["track_id"].tolist(),
                                       table["bb_height"].tolist())
            centres = (table["bb_centre_x"].tolist() if "bb_centre_x" in table.columns
                       else None)
        self._add_rows(frames, tracks, heights, centres)

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

    def _add_rows(self, frames, tracks, heights, centres=None):
        """Boxes in: frame, trajectory, height (px) and horizontal centre (px; None
        or NaN: not given) of each."""
        if centres is None:
            centres = [math.nan] * len(frames)
        last_f, last_k = None, None
        for f, t, h, x in zip(frames, tracks, heights, centres, strict=True):
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
                entry = self._tracks[t] = [[], [], f, last_k, f, []]
            entry[0].append(float(self._d[last_k % self._W]))
            entry[1].append(h)
            entry[5].append(x)
            entry[2], entry[3] = f, last_k

    def _end_track(self, track):
        p = self._p
        d, hs, last_frame, last_k, first_frame, xs = self._tracks.pop(track)
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
        if self._side_used:
            # the wall it was seen on: a likelihood factor of the lock-on, now or
            # at a relock (a pass the gate rejects may be replayed into one)
            t = side_statistic(hs[keep], np.asarray(xs, np.float64)[keep])
            if abs(t) >= SIDE_MIN_T:  # NaN: unknown
                row["_side"], row["_side_t"] = (1 if t > 0 else -1), t
        self._apply(dist, row)


def _from_records(records):
    """``frame, track_id, bb_height`` lists of the detector's frame records."""
    frames, tracks, heights, centres = [], [], [], []
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
        centres.extend((det[order, 0] + det[order, 2] / 2.0).tolist())
    return frames, tracks, heights, centres
