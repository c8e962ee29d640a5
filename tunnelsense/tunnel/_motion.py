"""Keypoint cluster verification by motion and object detection (sections 3.6-3.7).

An indicator on the tunnel wall moves, frame after frame, along a straight image line
away from the vanishing point; vehicles ahead and their warm road patches stay nearly
still or wander.  Each trajectory is fitted with a straight line ``y = a0 + a1 x`` and
the Pearson correlation coefficient ``r`` of the fit (eq. 5) decides.  A keypoint
cluster is an indicator iff its appearance label is positive, its trajectory is at
least ``min_length`` long and ``|r| >= min_r``; a trajectory is positive when more
than ``vote`` (80 %) of the decisions it connects are positive.
"""

from __future__ import annotations

import numbers
from collections import deque

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin, _fit_context
from sklearn.utils._param_validation import Interval, StrOptions

from tunnelsense._records import (
    FrameRecord,
    FrameSequence,
    check_frames,
    release_image,
)
from tunnelsense._streaming import StreamingMixin, StreamState
from tunnelsense.tunnel._appearance import boxes_of

__all__ = ["PCCVerifier", "pearson_r", "straightness", "trajectory_r"]

#: Columns of ``payload["detections"]``.
DETECTION_COLUMNS = ("bb_left", "bb_top", "bb_width", "bb_height", "track_id", "score")


def pearson_r(x, y) -> float:
    """Pearson correlation coefficient of the points ``(x_i, y_i)`` (eq. 5).

    0 when either coordinate does not vary (a still cluster has no line; fewer than
    two distinct positions).

    Examples
    --------
    >>> pearson_r([0, 1, 2, 3], [5, 3, 1, -1])
    -1.0
    >>> pearson_r([1, 1, 1], [0, 1, 2])
    0.0
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    x = x - x.mean()
    y = y - y.mean()
    sxx, syy = float(x @ x), float(y @ y)
    scale = max(sxx, syy, 1.0)
    if sxx <= 1e-12 * scale or syy <= 1e-12 * scale:
        return 0.0
    return float(np.clip((x @ y) / np.sqrt(sxx * syy), -1.0, 1.0))


def straightness(x, y) -> float:
    """How well the points ``(x_i, y_i)`` fit a line, whatever its direction.

    ``1 - lambda_min / lambda_max`` of the points' covariance matrix: 1 for points
    on a line, 0 for points spread alike in every direction (or fewer than two
    distinct positions).  Unlike Pearson's r, which is 0 for a perfectly straight
    horizontal or vertical line because one coordinate does not vary, it treats every
    orientation alike.

    Examples
    --------
    >>> straightness([0, 1, 2, 3], [5, 5, 5, 5])  # horizontal: Pearson r is 0 here
    1.0
    >>> round(straightness([0, 1, 0, 1], [0, 0, 1, 1]), 6)
    0.0
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if len(x) < 2:
        return 0.0
    low, high = np.linalg.eigvalsh(np.cov(x, y, bias=True))
    if high <= 1e-12:
        return 0.0
    return float(np.clip(1.0 - max(low, 0.0) / high, 0.0, 1.0))


def trajectory_r(x, y, starts) -> np.ndarray:
    """Pearson r of every trajectory, for points grouped in consecutive segments.

    Parameters
    ----------
    x, y : ndarray of shape (n,)
        Positions, trajectory after trajectory.
    starts : ndarray of shape (n_trajectories,)
        Index of the first point of each trajectory (ascending, ``starts[0] == 0``).

    Returns
    -------
    r : ndarray of shape (n_trajectories,)
        As :func:`pearson_r` of each segment.
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    n = np.diff(np.append(starts, len(x)))
    if len(x) == 0:
        return np.zeros(0)
    seg = np.repeat(np.arange(len(starts)), n)
    xm = np.add.reduceat(x, starts) / n
    ym = np.add.reduceat(y, starts) / n
    dx = x - xm[seg]
    dy = y - ym[seg]
    sxx = np.add.reduceat(dx * dx, starts)
    syy = np.add.reduceat(dy * dy, starts)
    sxy = np.add.reduceat(dx * dy, starts)
    scale = np.maximum(np.maximum(sxx, syy), 1.0)
    ok = (sxx > 1e-12 * scale) & (syy > 1e-12 * scale)
    r = np.zeros(len(starts))
    r[ok] = np.clip(sxy[ok] / np.sqrt(sxx[ok] * syy[ok]), -1.0, 1.0)
    return r


def _payload(record, index, key, m, stage, before):
    try:
        value = np.asarray(record.payload[key])
    except KeyError:
        raise ValueError(
            f"X[{index}] ({record.tour!r}, frame {record.frame}) has no "
            f"payload[{key!r}]: {stage} needs frame records that went through "
            f"{before} first"
        ) from None
    if value.shape != (m,):
        raise ValueError(
            f"X[{index}] ({record.tour!r}, frame {record.frame}): payload[{key!r}] "
            f"must have shape ({m},), one entry per cluster; got shape {value.shape}"
        )
    return value


class _Released:
    """Stands in for the image source of a record released by a stream state."""

    __slots__ = ()

    def load(self):
        raise ValueError(
            "this frame's image was released by the streaming detector (only lazy "
            "sources, such as image files, are kept); keep the image yourself if you "
            "need it after detection"
        )

    def __repr__(self):
        return "Released()"


_RELEASED = _Released()


class _Frame:
    """A frame waiting for the trajectories through it to end."""

    __slots__ = (
        "tag",
        "boxes",
        "tracks",
        "r",
        "length",
        "indicator",
        "positive",
        "fraction",
        "unresolved",
    )

    def __init__(self, tag, boxes, tracks):
        m = len(boxes)
        self.tag = tag
        self.boxes = boxes
        self.tracks = tracks
        self.r = np.zeros(m)
        self.length = np.zeros(m, np.int64)
        self.indicator = np.zeros(m, bool)
        self.positive = np.zeros(m, bool)
        self.fraction = np.zeros(m)
        self.unresolved = m

    def results(self):
        keep = self.positive
        det = np.column_stack(
            [
                self.boxes[keep],
                self.tracks[keep].astype(np.float64),
                self.fraction[keep],
            ]
        )
        return dict(
            motion_r=self.r,
            trajectory_length=self.length,
            indicator=self.indicator,
            trajectory_positive=keep,
            detections=det.reshape(-1, 6),
        )


class _Trajectory:
    __slots__ = ("xs", "ys", "app", "members")

    def __init__(self):
        self.xs, self.ys, self.app, self.members = [], [], [], []


class _PCCStream(StreamState):
    """Stream state of :class:`PCCVerifier`: open trajectories and waiting frames.

    A frame is added with its tag (the record to evolve; a record of another tour
    first ends every trajectory of the previous one).  A trajectory is decided when
    it ends (``payload["ended_tracks"]`` of :class:`TrajectoryLinker`, the end of its
    tour, or :meth:`close`); a frame is final, and returned, when every trajectory
    through it is decided.  ``release=True`` keeps of a held frame's image only a lazy
    source (online, where frames would otherwise pile up in memory).
    """

    def __init__(self, verifier, *, release=True):
        self.measure = pearson_r if verifier.criterion == "pearson" else straightness
        self.min_r = float(verifier.min_r)
        self.min_length = int(verifier.min_length)
        self.vote = float(verifier.vote)
        self.release = release
        self.tour = None
        self.open: dict = {}
        self.waiting: deque = deque()
        self._count = 0

    @property
    def n_waiting(self):
        """Frames held until the trajectories through them end."""
        return len(self.waiting)

    def _decide(self, traj):
        n = len(traj.xs)
        r = self.measure(traj.xs, traj.ys) if n > 1 else 0.0
        motion_ok = n >= self.min_length and abs(r) >= self.min_r
        indicator = [a and motion_ok for a in traj.app]
        fraction = sum(indicator) / n
        positive = fraction > self.vote
        for (entry, j), ind in zip(traj.members, indicator, strict=True):
            entry.r[j] = r
            entry.length[j] = n
            entry.indicator[j] = ind
            entry.positive[j] = positive
            entry.fraction[j] = fraction
            entry.unresolved -= 1

    def _release(self):
        out = []
        waiting = self.waiting
        while waiting and waiting[0].unresolved == 0:
            entry = waiting.popleft()
            out.append(entry.tag.evolve(**entry.results()))
        return out

    def _close(self):
        """End every open trajectory; return every frame still waiting."""
        for traj in self.open.values():
            self._decide(traj)
        self.open = {}
        self.tour = None
        return self._release()

    def _push(self, record):
        boxes, appearance, tracks = _frame_payload(record, self._count)
        self._count += 1
        tag = record
        if self.release:
            source = release_image(record.source)
            if source is None:
                source = _RELEASED
            tag = FrameRecord(record.tour, record.frame, source, record.payload)
        out = []
        if record.tour != self.tour:
            out = self._close()
            self.tour = record.tour
        entry = _Frame(tag, boxes, tracks)
        if len(boxes):
            cx = (boxes[:, 0] + boxes[:, 2] / 2).tolist()
            cy = (boxes[:, 1] + boxes[:, 3] / 2).tolist()
            for j, (tid, a) in enumerate(
                zip(tracks.tolist(), appearance.tolist(), strict=True)
            ):
                traj = self.open.get(tid)
                if traj is None:
                    traj = self.open[tid] = _Trajectory()
                traj.xs.append(cx[j])
                traj.ys.append(cy[j])
                traj.app.append(a)
                traj.members.append((entry, j))
        self.waiting.append(entry)
        ended = record.payload.get("ended_tracks")
        if ended is not None:
            for tid in np.asarray(ended).reshape(-1).tolist():
                traj = self.open.pop(tid, None)
                if traj is not None:
                    self._decide(traj)
        out.extend(self._release())
        return out


def _frame_payload(record, index):
    b = boxes_of(record, index, "PCCVerifier")
    m = len(b)
    app = _payload(record, index, "appearance", m, "PCCVerifier", "WeightedAdaBoost")
    tracks = _payload(record, index, "track_ids", m, "PCCVerifier", "TrajectoryLinker")
    return b, app.astype(bool), tracks.astype(np.int64)


class PCCVerifier(StreamingMixin, TransformerMixin, BaseEstimator):
    """Verify trajectories by straight-line motion; give the detections (3.6-3.7).

    Stage 6, the last one, of the FIR indicator detector: a frame stage with nothing
    to learn (its thresholds are hyperparameters, for :class:`~sklearn.model_selection.GridSearchCV`).
    It reads, per frame, the clusters' rectangles (``payload["cluster_boxes"]``),
    appearance labels (``payload["appearance"]``) and trajectories
    (``payload["track_ids"]``), gathers each trajectory of each tour, and, when the
    trajectory ends (``payload["ended_tracks"]`` of :class:`TrajectoryLinker`, or the
    end of its tour), fits a straight line through the centres of its rectangles.
    ``predict`` runs the same state machine over each tour, in frame order, as
    :meth:`start_stream` does online, so both give identical results.

    A cluster is an **indicator** iff its appearance label is positive, its
    trajectory has at least ``min_length`` clusters and ``|r| >= min_r``.  The
    decision uses the whole trajectory, so it is final once the trajectory has ended
    (an online system reports it with that delay).  A **trajectory is positive** when
    more than ``vote`` of its clusters are indicators.  The detections are the clusters
    of positive trajectories -- every one of them, so that a wrong decision on one frame
    is recovered by the others, as the paper puts it.

    ``predict`` (and ``transform``, the same) return the frames in input order, each
    evolved with

    * ``payload["motion_r"]``: (m,) float64 -- Pearson r of each cluster's trajectory;
    * ``payload["trajectory_length"]``: (m,) int64 -- its number of clusters;
    * ``payload["indicator"]``: (m,) bool -- the per-cluster decision (the paper's
      Table 1 is measured on it);
    * ``payload["trajectory_positive"]``: (m,) bool -- whether the cluster's
      trajectory is positive by the vote;
    * ``payload["detections"]``: (k, 6) float64 -- one row per detection,
      ``(bb_left, bb_top, bb_width, bb_height, track_id, score)``, where ``score`` is
      the fraction of the trajectory's clusters that are indicators (> ``vote``).

    Parameters
    ----------
    min_r : float, default=0.95
        Smallest ``|r|`` of an indicator's trajectory.  An indicator moves along a
        straight line through the vanishing point over tens to hundreds of pixels,
        so its centres fit a line with ``|r|`` close to 1 (0.99 and more on simulated
        tours, where the keypoint grid quantizes the centres by up to 3 px); a vehicle
        ahead at nearly constant distance jitters by a few pixels in both directions
        and gets ``|r|`` far from 1.
    min_length : int, default=10
        Fewest clusters of an indicator's trajectory: a third of a second at 30 fps.
        An indicator stays in view for well over a second at motorway speed, while
        a chance alignment of a few jittering positions gives a high ``|r|``
        only on short trajectories.
    vote : float, default=0.8
        A trajectory is positive when more than this fraction of its clusters are
        indicators (the paper's 80 %).
    criterion : {"pearson", "principal"}, default="pearson"
        The straightness measure compared with ``min_r``: ``"pearson"`` is ``|r|`` of
        eq. 5 (the paper); ``"principal"`` is :func:`straightness`, which does not
        depend on the line's direction. Pearson's r is 0 for a perfectly horizontal
        or vertical line and low for a nearly horizontal one, so a camera mounted
        near the indicators' height (on a truck or bus), which sees them move almost
        horizontally, needs ``"principal"``. ``payload["motion_r"]`` holds the
        chosen measure (signed r for ``"pearson"``).

    Attributes
    ----------
    n_frames_fit_ : int
        Number of frames seen by ``fit``.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import FrameRecord
    >>> from tunnelsense.tunnel import PCCVerifier
    >>> img = np.zeros((48, 64), np.uint8)
    >>> X = [FrameRecord("t", f, img, {"cluster_boxes": np.array([[40. - 3 * f, 30 - f, 4, 8]]),
    ...      "appearance": np.array([True]), "track_ids": np.array([1])}) for f in range(1, 13)]
    >>> out = PCCVerifier().fit(X).predict(X)
    >>> out[0].payload["detections"]
    array([[37., 29.,  4.,  8.,  1.,  1.]])
    """

    _parameter_constraints: dict = {
        "min_r": [Interval(numbers.Real, 0, 1, closed="both")],
        "min_length": [Interval(numbers.Integral, 1, None, closed="left")],
        "vote": [Interval(numbers.Real, 0, 1, closed="left")],
        "criterion": [StrOptions({"pearson", "principal"})],
    }

    def __init__(self, *, min_r=0.95, min_length=10, vote=0.8, criterion="pearson"):
        self.min_r = min_r
        self.min_length = min_length
        self.vote = vote
        self.criterion = criterion

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.two_d_array = False
        tags.transformer_tags.preserves_dtype = []
        return tags

    _sequence = FrameSequence

    def _check_records(self, X, y=None):
        records, _ = check_frames(X, y)
        for i, r in enumerate(records):
            _frame_payload(r, i)
        return records

    def _stream_state(self, *, batch=False):
        return _PCCStream(self, release=not batch)

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y=None):
        """Validate the frames (nothing is learned).

        Parameters
        ----------
        X : sequence of FrameRecord
            Frames with ``cluster_boxes``, ``appearance`` and ``track_ids``.
        y : ignored (per-frame boxes are validated if given)

        Returns
        -------
        self : PCCVerifier
        """
        records = self._check_records(X, y)
        self.n_frames_fit_ = len(records)
        return self

    def predict(self, X):
        """Label every cluster and trajectory; give each frame's detections.

        Parameters
        ----------
        X : sequence of FrameRecord

        Returns
        -------
        X_new : FrameSequence
            The frames in input order, evolved as the class docstring says.
        """
        return self.transform(X)

    def start_stream(self):
        """Verify frames online, one at a time (the streaming protocol).

        Returns
        -------
        state : object
            ``state.push(record)`` takes the next frame (frames of a tour in
            increasing order; a record of another tour ends every trajectory of the
            previous one) and returns the frames whose decisions are final, in input
            order, evolved as :meth:`predict` does; ``state.close()`` ends every
            trajectory and returns the frames still held.  A frame is final when
            every trajectory through it has ended (``payload["ended_tracks"]`` of
            :class:`TrajectoryLinker`): with the linker's ``max_track_length`` of
            ``L`` frames, a frame is released at most ``L - 1`` frames after it
            arrived, and at most ``L`` frames are held.  Held frames keep their
            payload arrays only: an in-memory image is released (reading ``.image``
            of the returned record then raises); a lazy source (an image file) is
            kept.  ``state.n_waiting`` is the number of frames held.

        Examples
        --------
        >>> import numpy as np
        >>> from tunnelsense import FrameRecord
        >>> from tunnelsense.tunnel import PCCVerifier
        >>> img = np.zeros((48, 64), np.uint8)
        >>> def frame(f, ended=()):
        ...     return FrameRecord("t", f, img, {"cluster_boxes": np.array([[40. - 3 * f, 30 - f, 4, 8]]),
        ...         "appearance": np.array([True]), "track_ids": np.array([1]),
        ...         "ended_tracks": np.array(ended, np.int64)})
        >>> state = PCCVerifier(min_length=3).fit([frame(1)]).start_stream()
        >>> [len(state.push(frame(f))) for f in (1, 2)]
        [0, 0]
        >>> out = state.push(frame(3, ended=[1]))  # trajectory 1 ends: three frames final
        >>> [(r.frame, r.payload["detections"].shape) for r in out]
        [(1, (1, 6)), (2, (1, 6)), (3, (1, 6))]
        """
        return super().start_stream()
