"""Keypoint cluster tracking (section 3.5), the math and the stream state.

:func:`link_log_likelihood` scores a response given a trajectory; :func:`assign_pairs`
links the responses of a frame; :class:`LinkerStream` is the state
:class:`~tunnelsense.tunnel.TrajectoryLinker` runs over the frames of each tour.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
from scipy.optimize import linear_sum_assignment

from tunnelsense._payload import (
    CONTINUED_TRACKS,
    CUT_TRACKS,
    ENDED_TRACKS,
    TRACK_IDS,
    boxes_of,
    frame_rate_of,
    histograms_of,
    scaled_count,
)
from tunnelsense._streaming import StreamState

__all__ = [
    "MIN_GAP",
    "MIN_GAP_FIT_POINTS",
    "MIN_TRAJECTORY_POINTS",
    "REFERENCE_FRAME_RATE",
    "LinkerStream",
    "assign_pairs",
    "gated_pairs",
    "link_log_likelihood",
    "rate_ratio",
]

#: The frame rate (fps) the trajectory stages' frame counts are given in by default:
#: the paper's camera.
REFERENCE_FRAME_RATE = 30.0
#: Fewest points of a trajectory's straightness test when frame counts are scaled
#: down to a lower frame rate: with fewer, a chance alignment of jittering positions
#: (or a quadratic's three parameters per coordinate) fits too easily.
MIN_TRAJECTORY_POINTS = 7
#: Fewest missed frames a trajectory may bridge when ``max_gap`` is scaled down.
MIN_GAP = 1
#: Fewest kept positions of a trajectory whose speed lets it bridge more than
#: ``max_gap`` frames (``max_gap_travel``).
MIN_GAP_FIT_POINTS = 3


def link_log_likelihood(
    predicted, last_size, last_hist, centre, size, hist, gap, *,
    max_scale_change=4.0, gate=1.0, min_gate=12.0, position_sigma=0.35,
    scale_sigma=0.35, appearance_sigma=0.3, gap_penalty=1.0,
):
    """``ln P_link`` of a response given a trajectory, or ``-inf`` outside the gates.

    Parameters
    ----------
    predicted : (float, float)
        Position ``(x, y)`` the trajectory's straight-line model predicts for the
        response's frame.
    last_size, size : float
        Scale (square root of the rectangle's area) of the trajectory's last response
        and of the new one.
    last_hist, hist : ndarray of shape (bins,) or None
        Normalized histograms (appearance); ``None`` leaves appearance out.
    centre : (float, float)
        Centre of the response's rectangle.
    gap : int
        Frames between the trajectory's last response and this one (>= 1).

    Returns
    -------
    float
        ``-0.5 (d / (position_sigma s))^2 - 0.5 (ln(size ratio) / scale_sigma)^2
        - 0.5 (a / appearance_sigma)^2 - gap_penalty (gap - 1)``, where ``d`` is the
        distance to the prediction, ``s`` the larger size (at least ``min_gate /
        gate``) and ``a`` half the L1 distance of the histograms (in [0, 1]).
        ``-inf`` when the scale changes by more than ``max_scale_change`` or ``d``
        exceeds ``max(min_gate, gate * s)``.
    """
    ratio = size / last_size if last_size > 0 and size > 0 else math.inf
    if not (1.0 / max_scale_change <= ratio <= max_scale_change):
        return -math.inf
    s = max(size, last_size)
    dx = centre[0] - predicted[0]
    dy = centre[1] - predicted[1]
    d = math.hypot(dx, dy)
    if d > max(min_gate, gate * s):
        return -math.inf
    sigma = position_sigma * max(s, min_gate / gate)
    ll = -0.5 * (d / sigma) ** 2 - 0.5 * (math.log(ratio) / scale_sigma) ** 2
    if last_hist is not None and hist is not None:
        a = 0.5 * float(np.abs(last_hist - hist).sum())
        ll -= 0.5 * (a / appearance_sigma) ** 2
    return ll - gap_penalty * (gap - 1)


def gated_pairs(px, py, last_size, cx, cy, size, gate, min_gate, max_scale_change):
    """The (trajectory, response) pairs :func:`link_log_likelihood` may score above
    ``-inf``: two lists of int, in row-major order.

    Trajectory ``i`` is predicted at ``(px[i], py[i])`` and its last scale is
    ``last_size[i]``; response ``j`` is centred at ``(cx[j], cy[j])`` with scale
    ``size[j]`` (all arrays).  The pairs left out lie outside the gates for
    certain: a scale ratio out of range (the same division and comparisons), or a
    distance to the prediction whose square exceeds the gate's by more than a
    relative 1e-6 (the function's ``hypot`` may differ from the squares' sum in the
    last bits, never by that much).  A trajectory without a positive scale keeps
    every response (left to the function).  Scoring only these pairs gives the same
    links as scoring every pair.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.tunnel._linking import gated_pairs
    >>> cx, cy = np.array([10.0, 60.0, 11.0]), np.array([10.0, 10.0, 9.0])
    >>> size = np.array([8.0, 8.0, 80.0])
    >>> gated_pairs(np.array([10.0, 60.0]), np.array([10.0, 10.0]), np.array([8.0, 8.0]),
    ...             cx, cy, size, 1.0, 12.0, 4.0)
    ([0, 1], [0, 1])
    """
    last = np.asarray(last_size, dtype=np.float64)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = size / last
    limit = np.maximum(np.maximum(size, last) * gate, min_gate)
    dx, dy = cx - np.asarray(px)[:, None], cy - np.asarray(py)[:, None]
    out = (dx * dx + dy * dy > limit * limit * (1.0 + 1e-6)) | (size > 0) & (
        (ratio < 1.0 / max_scale_change) | (ratio > max_scale_change))
    out &= last > 0
    rows, cols = np.nonzero(~out)
    return rows.tolist(), cols.tolist()


class _Track:
    """A trajectory being linked: its last ``history`` positions (bounded memory)."""

    __slots__ = ("id", "first", "frames", "xs", "ys", "size", "hist", "last")

    def __init__(self, track_id, frame, x, y, size, hist, history):
        self.id = track_id
        self.first = frame
        self.frames = deque([frame], maxlen=history)
        self.xs = deque([x], maxlen=history)
        self.ys = deque([y], maxlen=history)
        self.size = size
        self.hist = hist
        self.last = frame

    def add(self, frame, x, y, size, hist):
        self.frames.append(frame)
        self.xs.append(x)
        self.ys.append(y)
        self.size = size
        self.hist = hist
        self.last = frame

    def _fit(self):
        """``(tm, xm, ym, vx, vy)``: the kept positions' straight-line fit in time."""
        k = len(self.frames)
        t, xs, ys = self.frames, self.xs, self.ys
        tm = sum(t) / k
        xm = sum(xs) / k
        ym = sum(ys) / k
        stt = sum((ti - tm) ** 2 for ti in t)
        vx = sum((ti - tm) * (xi - xm) for ti, xi in zip(t, xs, strict=True)) / stt
        vy = sum((ti - tm) * (yi - ym) for ti, yi in zip(t, ys, strict=True)) / stt
        return tm, xm, ym, vx, vy

    def predict(self, frame):
        """Position at ``frame`` by a straight-line fit of the kept positions in time."""
        if len(self.frames) == 1:
            return self.xs[0], self.ys[0]
        tm, xm, ym, vx, vy = self._fit()
        return xm + vx * (frame - tm), ym + vy * (frame - tm)

    def gap_travel(self, frame):
        """How far, in units of its size, the straight-line fit moves the trajectory
        from its last response to ``frame``; infinite with fewer than
        :data:`MIN_GAP_FIT_POINTS` positions kept (no speed to go by)."""
        if len(self.frames) < MIN_GAP_FIT_POINTS:
            return math.inf
        _, _, _, vx, vy = self._fit()
        return math.hypot(vx, vy) * (frame - self.last) / max(self.size, 1e-9)


class LinkerStream(StreamState):
    """Stream state of :class:`TrajectoryLinker`: its pool of trajectories, one tour at a time.

    A record of another tour starts afresh.  A trajectory *ends* as soon as it can no
    longer link a later frame: it missed more than ``max_gap`` frames (and, with
    ``max_gap_travel``, its straight-line fit would have moved it by more than that
    many times its size since its last response), or its duration reached
    ``max_track_length`` frames.  A trajectory ended at ``max_track_length`` while
    its object could still link is *cut* (``payload["cut_tracks"]``): it stays as
    long as it could link, and the first new trajectory whose first response it
    would have linked continues it (``payload["continued_tracks"]``, a row ``(new,
    cut)``; a row ``(0, cut)`` when it can link no more).  This leaves the
    trajectories and their ids as they are.
    """

    def __init__(self, linker):
        self.kw = dict(
            max_scale_change=float(linker.max_scale_change),
            gate=float(linker.gate),
            min_gate=float(linker.min_gate),
            position_sigma=float(linker.position_sigma),
            scale_sigma=float(linker.scale_sigma),
            appearance_sigma=float(linker.appearance_sigma),
            gap_penalty=float(linker.gap_penalty),
        )
        self.max_gap = int(linker.max_gap)
        # models saved before the parameter existed bridge max_gap frames only
        travel = getattr(linker, "max_gap_travel", None)
        self.max_gap_travel = None if travel is None else float(travel)
        self.max_track_length = linker.max_track_length
        # models saved before the parameter existed count frames at 30 fps
        self.frame_rate = getattr(linker, "frame_rate", REFERENCE_FRAME_RATE)
        self._scale(1.0)
        self.history = int(linker.history)
        self.hungarian = linker.assignment == "hungarian"
        self.tour = None
        self.alive: list[_Track] = []
        self.cut: list[_Track] = []
        self.next_id = 1
        self._count = 0

    def _scale(self, ratio):
        """The frame counts of a tour at ``ratio`` times the counts' frame rate."""
        self.reach = scaled_count(self.max_gap, ratio, MIN_GAP) + 1
        self.max_length = (
            math.inf if self.max_track_length is None
            else scaled_count(self.max_track_length, ratio, MIN_TRAJECTORY_POINTS)
        )

    def _can_link(self, t, frame):
        if frame - t.first >= self.max_length:
            return False
        return self._within_gap(t, frame)

    def _within_gap(self, t, frame):
        return frame - t.last <= self.reach or (
            self.max_gap_travel is not None
            and t.gap_travel(frame) <= self.max_gap_travel
        )

    def _push(self, record):
        index = self._count
        self._count += 1
        boxes = boxes_of(record, index, "TrajectoryLinker")
        ids, ended, cut, continued = self._step(record, boxes, index)
        return [record.evolve(**{TRACK_IDS: ids, ENDED_TRACKS: ended, CUT_TRACKS: cut,
                                 CONTINUED_TRACKS: continued})]

    def _close(self):
        self.tour = None
        self.alive = []
        self.cut = []
        return []

    def _ending(self, tracks, frame, ended, cut):
        """The tracks that can link ``frame``; the others' ids go to ``ended`` (and
        those ended at ``max_track_length`` that could still link, to ``cut``)."""
        keep = []
        for t in tracks:
            if self._can_link(t, frame):
                keep.append(t)
                continue
            ended.append(t.id)
            if self._within_gap(t, frame):
                cut.append(t.id)
                self.cut.append(t)
        return keep

    def _may_continue(self, t, frame):
        return frame - t.last < self.max_length and self._within_gap(t, frame)

    def _continue_cut(self, frame, fresh, cx, cy, size, hists, pairs_out):
        """Pair the cut trajectories with this frame's new ones (``fresh``: ``(j,
        track)``) by the link likelihood, as :meth:`_step` links; drop those that
        can link no more."""
        # bounded: with max_gap_travel a still object's fit bridges any gap
        cut = [t for t in self.cut if self._may_continue(t, frame)]
        for t in self.cut:
            if not self._may_continue(t, frame):
                pairs_out.append((0, t.id))
        pairs = []
        for ti, t in enumerate(cut):
            px, py = t.predict(frame)
            for k, (j, _) in enumerate(fresh):
                ll = link_log_likelihood(
                    (px, py), t.size, t.hist, (cx[j], cy[j]), size[j],
                    None if hists is None else hists[j], frame - t.last, **self.kw)
                if ll > -math.inf:
                    pairs.append((ll, ti, k))
        done = set()
        for ti, k in assign_pairs(pairs, len(cut), len(fresh), self.hungarian):
            pairs_out.append((fresh[k][1].id, cut[ti].id))
            done.add(ti)
        self.cut = [t for ti, t in enumerate(cut) if ti not in done]

    def _step(self, record, boxes, index):
        """Link one frame; return ``(track_ids, ended_tracks)``."""
        frame = record.frame
        if record.tour != self.tour:
            self.tour, self.alive, self.cut, self.next_id = record.tour, [], [], 1
            self._scale(rate_ratio(record, self.frame_rate))
        ended, cut, continued, fresh = [], [], [], []
        alive = self._ending(self.alive, frame, ended, cut)
        m = len(boxes)
        out = np.zeros(m, dtype=np.int64)
        cx = cy = size = hists = None
        if m:
            hists = histograms_of(record, index, m)
            bl = boxes.tolist()
            cx = [L + w / 2 for L, _, w, _ in bl]
            cy = [T + h / 2 for _, T, _, h in bl]
            size = [math.sqrt(w * h) for _, _, w, h in bl]
            pairs = []
            kw = self.kw
            if alive:
                predicted = [t.predict(frame) for t in alive]
                rows, cols = gated_pairs(
                    np.array([p[0] for p in predicted]),
                    np.array([p[1] for p in predicted]),
                    np.array([t.size for t in alive]), np.array(cx), np.array(cy),
                    np.array(size), kw["gate"], kw["min_gate"], kw["max_scale_change"])
                for ti, j in zip(rows, cols, strict=True):
                    t = alive[ti]
                    ll = link_log_likelihood(
                        predicted[ti], t.size, t.hist, (cx[j], cy[j]), size[j],
                        None if hists is None else hists[j], frame - t.last, **kw,
                    )
                    if ll > -math.inf:
                        pairs.append((ll, ti, j))
            linked = assign_pairs(pairs, len(alive), m, self.hungarian)
            taken = set()
            for ti, j in linked:
                t = alive[ti]
                t.add(frame, cx[j], cy[j], size[j], None if hists is None else hists[j])
                out[j] = t.id
                taken.add(j)
            for j in range(m):
                if j not in taken:
                    t = _Track(
                        self.next_id, frame, cx[j], cy[j], size[j],
                        None if hists is None else hists[j], self.history,
                    )
                    alive.append(t)
                    fresh.append((j, t))
                    out[j] = self.next_id
                    self.next_id += 1
        if self.cut:
            self._continue_cut(frame, fresh, cx, cy, size, hists, continued)
        # what cannot link the next frame has ended
        self.alive = self._ending(alive, frame + 1, ended, cut)
        return (out, np.array(sorted(ended), dtype=np.int64),
                np.array(sorted(cut), dtype=np.int64),
                np.array(sorted(continued, key=lambda p: p[1]),
                         dtype=np.int64).reshape(-1, 2))


def rate_ratio(record, frame_rate):
    """The ratio of a record's frame rate to ``frame_rate`` (1 when either is None)."""
    rate = frame_rate_of(record)
    if rate is None or frame_rate is None:
        return 1.0
    return rate / float(frame_rate)


def assign_pairs(pairs, n_tracks, m, hungarian):
    """The links of one frame: ``(track, response)`` pairs, each used at most once.

    ``pairs`` holds ``(log-likelihood, track, response)``.  Greedy (the paper's):
    best pair first, until no pair is left; Hungarian: the assignment maximizing the
    sum of log-likelihoods.
    """
    if not pairs:
        return []
    if hungarian:
        cost = np.full((n_tracks, m), np.inf)
        for ll, ti, j in pairs:
            cost[ti, j] = -ll
        finite = np.isfinite(cost)
        big = (np.abs(cost[finite]).max() + 1.0) * (n_tracks + m + 1)
        rows, cols = linear_sum_assignment(np.where(finite, cost, big))
        return [(a, b) for a, b in zip(rows.tolist(), cols.tolist(), strict=True) if finite[a, b]]
    pairs.sort(key=lambda p: (-p[0], p[1], p[2]))
    used_t, used_c, linked = set(), set(), []
    for _, ti, j in pairs:
        if ti in used_t or j in used_c:
            continue
        used_t.add(ti)
        used_c.add(j)
        linked.append((ti, j))
    return linked
