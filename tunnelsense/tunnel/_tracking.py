"""Keypoint cluster tracking (section 3.5): online linking into trajectories.

A pool of trajectories is kept per tour; the keypoint clusters of each new frame are
the detection responses.  The link likelihood ``P_link(n | T)`` combines the distance
of the response from the position the trajectory's straight-line model predicts, the
scale change (at most ``max_scale_change``, 4 in the paper), the appearance difference
and the time gap; each trajectory links at most one response and each response at most
one trajectory.  The paper solves this assignment greedily (best pair first, until no
pair is left); the Hungarian algorithm is an option.
"""

from __future__ import annotations

import math
import numbers
from collections import deque

import numpy as np
from scipy.optimize import linear_sum_assignment
from sklearn.base import BaseEstimator, TransformerMixin, _fit_context
from sklearn.utils._param_validation import Interval, StrOptions

from tunnelsense._records import FrameSequence, check_frames
from tunnelsense._streaming import StreamingMixin, StreamState, stream_order
from tunnelsense.tunnel._appearance import boxes_of

__all__ = ["TrajectoryLinker", "link_log_likelihood"]


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

    def predict(self, frame):
        """Position at ``frame`` by a straight-line fit of the kept positions in time."""
        k = len(self.frames)
        if k == 1:
            return self.xs[0], self.ys[0]
        t, xs, ys = self.frames, self.xs, self.ys
        tm = sum(t) / k
        xm = sum(xs) / k
        ym = sum(ys) / k
        stt = sum((ti - tm) ** 2 for ti in t)
        vx = sum((ti - tm) * (xi - xm) for ti, xi in zip(t, xs, strict=True)) / stt
        vy = sum((ti - tm) * (yi - ym) for ti, yi in zip(t, ys, strict=True)) / stt
        return xm + vx * (frame - tm), ym + vy * (frame - tm)


class _LinkerStream(StreamState):
    """Stream state of :class:`TrajectoryLinker`: its pool of trajectories, one tour at a time.

    A record of another tour starts afresh.  A trajectory *ends* as soon as it can no
    longer link a later frame: it missed more than ``max_gap`` frames, or its duration
    reached ``max_track_length`` frames.
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
        self.reach = int(linker.max_gap) + 1
        self.history = int(linker.history)
        self.max_length = (
            math.inf if linker.max_track_length is None else int(linker.max_track_length)
        )
        self.hungarian = linker.assignment == "hungarian"
        self.tour = None
        self.alive: list[_Track] = []
        self.next_id = 1
        self._count = 0

    def _can_link(self, t, frame):
        return frame - t.last <= self.reach and frame - t.first < self.max_length

    def _push(self, record):
        boxes = boxes_of(record, self._count, "TrajectoryLinker")
        self._count += 1
        ids, ended = self._step(record, boxes)
        return [record.evolve(track_ids=ids, ended_tracks=ended)]

    def _close(self):
        self.tour = None
        self.alive = []
        return []

    def _step(self, record, boxes):
        """Link one frame; return ``(track_ids, ended_tracks)``."""
        frame = record.frame
        if record.tour != self.tour:
            self.tour, self.alive, self.next_id = record.tour, [], 1
        ended = [t.id for t in self.alive if not self._can_link(t, frame)]
        alive = [t for t in self.alive if self._can_link(t, frame)]
        m = len(boxes)
        out = np.zeros(m, dtype=np.int64)
        if m:
            hists = record.payload.get("cluster_histograms")
            if hists is not None and len(hists) != m:
                hists = None
            bl = boxes.tolist()
            cx = [L + w / 2 for L, _, w, _ in bl]
            cy = [T + h / 2 for _, T, _, h in bl]
            size = [math.sqrt(w * h) for _, _, w, h in bl]
            pairs = []
            kw = self.kw
            for ti, t in enumerate(alive):
                px, py = t.predict(frame)
                gap = frame - t.last
                for j in range(m):
                    ll = link_log_likelihood(
                        (px, py), t.size, t.hist, (cx[j], cy[j]), size[j],
                        None if hists is None else hists[j], gap, **kw,
                    )
                    if ll > -math.inf:
                        pairs.append((ll, ti, j))
            linked = TrajectoryLinker._assign(pairs, len(alive), m, self.hungarian)
            taken = set()
            for ti, j in linked:
                t = alive[ti]
                t.add(frame, cx[j], cy[j], size[j], None if hists is None else hists[j])
                out[j] = t.id
                taken.add(j)
            for j in range(m):
                if j not in taken:
                    alive.append(
                        _Track(
                            self.next_id, frame, cx[j], cy[j], size[j],
                            None if hists is None else hists[j], self.history,
                        )
                    )
                    out[j] = self.next_id
                    self.next_id += 1
        # what cannot link the next frame has ended
        nxt = frame + 1
        ended += [t.id for t in alive if not self._can_link(t, nxt)]
        self.alive = [t for t in alive if self._can_link(t, nxt)]
        return out, np.array(sorted(ended), dtype=np.int64)


class TrajectoryLinker(StreamingMixin, TransformerMixin, BaseEstimator):
    """Link keypoint clusters of consecutive frames into trajectories (section 3.5).

    Stage 5 of the FIR indicator detector, a frame stage with nothing to learn.  The
    records are processed tour by tour in frame order (whatever order they come in);
    trajectories never cross a tour boundary, and a trajectory that has missed more
    than ``max_gap`` frames (in the tour's frame numbers, so a gap in the records
    counts) ends; so does a trajectory whose duration reaches ``max_track_length``
    frames (the next cluster on the same object starts a new trajectory).
    ``transform`` returns the frames in their input order, each evolved
    with

    * ``payload["track_ids"]``: ndarray of shape (m,), int64 -- the trajectory of
      every keypoint cluster of ``payload["cluster_boxes"]``, numbered 1, 2, ... per
      tour in order of birth;
    * ``payload["ended_tracks"]``: ndarray of int64 -- the trajectories that ended at
      this frame: they cannot link any later frame (they missed more than
      ``max_gap`` frames, or reached ``max_track_length``).  :class:`PCCVerifier`
      decides a trajectory as soon as it has ended, which bounds its memory when
      streaming.  Trajectories still alive at the end of a tour end with it.

    Each trajectory's per-frame appearance decisions stay with its clusters
    (``payload["appearance"]``), where :class:`PCCVerifier` reads them.

    The log-likelihood of linking a response to a trajectory is
    :func:`link_log_likelihood`: position (distance from the position predicted by a
    straight-line fit, in time, of the trajectory's last ``history`` positions), scale
    (at most ``max_scale_change``), appearance (the clusters' histograms,
    ``payload["cluster_histograms"]`` from :class:`WeightedAdaBoost`, when present) and
    time gap.  Distances are measured relative to the cluster's size, as everything in
    the image grows as it approaches.

    Parameters
    ----------
    max_gap : int, default=3
        Largest number of consecutive frames a trajectory may miss and still link.
    max_track_length : int or None, default=300
        Longest duration of a trajectory, in frames (first to last, gaps included);
        a trajectory that reaches it ends and the object's next cluster starts a new
        one.  ``None``: unbounded.  This bounds the delay after which a frame's
        decisions are final and the memory of online detection (a vehicle followed
        for minutes would otherwise hold its frames for minutes).  The default is
        10 s at 30 fps, from the physics of an indicator's passage: a sign of about
        0.5 m seen by an 800 px camera is a cluster (>= 7 px tall) from about 57 m
        away and leaves the image about 10 m before it is passed, so it is in view
        for about 50 m of travel -- less than 10 s above 18 km/h.  In slower traffic
        an indicator's trajectory is cut into 10-s pieces, each still long and
        straight.
    max_scale_change : float, default=4.0
        Largest ratio of the sizes of linked responses (the paper's 4).
    gate : float, default=1.0
        A response farther than ``gate`` times its size (at least ``min_gate`` px)
        from the predicted position cannot link.
    min_gate : float, default=12.0
        Smallest position gate (px): about two keypoint grid steps.
    position_sigma : float, default=0.35
        Standard deviation of the position error, relative to the size.
    scale_sigma : float, default=0.35
        Standard deviation of the log scale change.
    appearance_sigma : float, default=0.3
        Standard deviation of the appearance difference (half the L1 distance of
        the histograms).
    gap_penalty : float, default=1.0
        Log-likelihood lost per missed frame.
    history : int, default=5
        Number of last positions of the straight-line prediction.
    assignment : {"greedy", "hungarian"}, default="greedy"
        ``"greedy"``: the paper's best pair first; ``"hungarian"``: the assignment
        maximizing the sum of log-likelihoods (:func:`scipy.optimize.linear_sum_assignment`).

    Attributes
    ----------
    n_frames_fit_ : int
        Number of frames seen by ``fit``.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import FrameRecord
    >>> from tunnelsense.tunnel import TrajectoryLinker
    >>> img = np.zeros((48, 64), np.uint8)
    >>> X = [FrameRecord("t", f, img, {"cluster_boxes": np.array([[10. + 2 * f, 20, 4, 8]])})
    ...      for f in range(1, 5)]
    >>> [r.payload["track_ids"].tolist() for r in TrajectoryLinker().fit_transform(X)]
    [[1], [1], [1], [1]]
    """

    _parameter_constraints: dict = {
        "max_gap": [Interval(numbers.Integral, 0, None, closed="left")],
        "max_track_length": [Interval(numbers.Integral, 2, None, closed="left"), None],
        "max_scale_change": [Interval(numbers.Real, 1, None, closed="left")],
        "gate": [Interval(numbers.Real, 0, None, closed="neither")],
        "min_gate": [Interval(numbers.Real, 0, None, closed="left")],
        "position_sigma": [Interval(numbers.Real, 0, None, closed="neither")],
        "scale_sigma": [Interval(numbers.Real, 0, None, closed="neither")],
        "appearance_sigma": [Interval(numbers.Real, 0, None, closed="neither")],
        "gap_penalty": [Interval(numbers.Real, 0, None, closed="left")],
        "history": [Interval(numbers.Integral, 2, None, closed="left")],
        "assignment": [StrOptions({"greedy", "hungarian"})],
    }

    def __init__(
        self,
        *,
        max_gap=3,
        max_track_length=300,
        max_scale_change=4.0,
        gate=1.0,
        min_gate=12.0,
        position_sigma=0.35,
        scale_sigma=0.35,
        appearance_sigma=0.3,
        gap_penalty=1.0,
        history=5,
        assignment="greedy",
    ):
        self.max_gap = max_gap
        self.max_track_length = max_track_length
        self.max_scale_change = max_scale_change
        self.gate = gate
        self.min_gate = min_gate
        self.position_sigma = position_sigma
        self.scale_sigma = scale_sigma
        self.appearance_sigma = appearance_sigma
        self.gap_penalty = gap_penalty
        self.history = history
        self.assignment = assignment

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.two_d_array = False
        tags.transformer_tags.preserves_dtype = []
        return tags

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y=None):
        """Validate the frames (nothing is learned).

        Parameters
        ----------
        X : sequence of FrameRecord
            Frames with ``payload["cluster_boxes"]``.
        y : ignored (per-frame boxes are validated if given)

        Returns
        -------
        self : TrajectoryLinker
        """
        records = self._check_records(X, y)
        stream_order(records)
        self.n_frames_fit_ = len(records)
        return self

    _sequence = FrameSequence

    def _check_records(self, X, y=None):
        records, _ = check_frames(X, y)
        for i, r in enumerate(records):
            boxes_of(r, i, "TrajectoryLinker")
        return records

    def _stream_state(self, *, batch=False):
        return _LinkerStream(self)

    def transform(self, X):
        """Link the clusters of every tour into trajectories.

        Runs the same state machine as :meth:`start_stream` over each tour's frames in
        frame order, so batch and streaming give identical trajectories.

        Parameters
        ----------
        X : sequence of FrameRecord
            Frames with ``payload["cluster_boxes"]`` (and, optionally,
            ``payload["cluster_histograms"]``).

        Returns
        -------
        X_new : FrameSequence
            The frames in input order, with ``payload["track_ids"]`` and
            ``payload["ended_tracks"]``.
        """
        return super().transform(X)

    def start_stream(self):
        """Link frames online, one at a time (the streaming protocol).

        Returns
        -------
        state : object
            ``state.push(record)`` takes the next frame (frames of a tour in
            increasing order; a record of another tour starts that tour afresh) and
            returns it at once, evolved as :meth:`transform` does; ``state.close()``
            ends the stream and returns ``[]``.  Memory is bounded: at most the live
            trajectories, each keeping its last ``history`` positions.

        Examples
        --------
        >>> import numpy as np
        >>> from tunnelsense import FrameRecord
        >>> from tunnelsense.tunnel import TrajectoryLinker
        >>> img = np.zeros((48, 64), np.uint8)
        >>> X = [FrameRecord("t", 1, img, {"cluster_boxes": np.empty((0, 4))})]
        >>> state = TrajectoryLinker(max_gap=1).fit(X).start_stream()
        >>> for f in (1, 2, 5):
        ...     (out,) = state.push(FrameRecord("t", f, img,
        ...                         {"cluster_boxes": np.array([[10. + f, 20, 4, 8]])}))
        ...     print(f, out.payload["track_ids"], out.payload["ended_tracks"])
        1 [1] []
        2 [1] []
        5 [2] [1]
        """
        return super().start_stream()

    @staticmethod
    def _assign(pairs, n_tracks, m, hungarian):
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
