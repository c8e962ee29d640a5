"""Motion verification (sections 3.6-3.7): the stream state.

The measures of a trajectory's path (:func:`pearson_r`, eq. 5, and the others) are
in :mod:`tunnelsense.tunnel._pcc_measures`.  :class:`PCCStream` is the state :class:`PCCVerifier` runs over
the frames of each tour: it gathers every open trajectory, decides one when it ends
and releases a frame when every trajectory through it is decided.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from tunnelsense._payload import (
    APPEARANCE,
    DETECTIONS,
    FRAME_SCALE,
    INDICATOR,
    MOTION_R,
    TRACK_IDS,
    TRAJECTORY_LENGTH,
    TRAJECTORY_POSITIVE,
    boxes_of,
    continued_tracks_of,
    cut_tracks_of,
    ended_tracks_of,
    per_cluster,
    scaled_count,
)
from tunnelsense._records import DecodedImage, FrameRecord, release_image
from tunnelsense._streaming import StreamState
from tunnelsense.tunnel._linking import (
    MIN_TRAJECTORY_POINTS,
    REFERENCE_FRAME_RATE,
    rate_ratio,
)
from tunnelsense.tunnel._pcc_measures import (  # noqa: F401 (re-exported)
    _MEASURES,
    approach_fraction,
    approach_r,
    curve_fit_r,
    focus_offset,
    grows,
    inward_offset,
    motion_fit_r,
    path_travel,
    pearson_r,
    straightness,
    thirds_shift,
)

__all__ = [
    "PCCStream",
    "approach_fraction",
    "carried_travel",
    "curve_fit_r",
    "focus_offset",
    "frame_payload",
    "frame_size",
    "motion_fit_r",
    "pearson_r",
    "straightness",
]


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

#: The tour before the first record: unlike any record's (whose tour may be None).
_NO_TOUR = object()


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
        boxes = self.boxes[keep]
        scale = self.tag.payload.get(FRAME_SCALE)
        if scale is not None and tuple(scale) != (1.0, 1.0):  # back to the frame's own pixels
            boxes = boxes / np.array([scale[0], scale[1], scale[0], scale[1]])
        det = np.column_stack(
            [
                boxes,
                self.tracks[keep].astype(np.float64),
                self.fraction[keep],
            ]
        )
        return {
            MOTION_R: self.r,
            TRAJECTORY_LENGTH: self.length,
            INDICATOR: self.indicator,
            TRAJECTORY_POSITIVE: keep,
            DETECTIONS: det.reshape(-1, 6),
        }


class _Trajectory:
    __slots__ = ("id", "ts", "xs", "ys", "hs", "app", "members", "prior")

    def __init__(self, track_id):
        self.ts, self.xs, self.ys, self.hs, self.app, self.members = [], [], [], [], [], []
        self.id = track_id
        self.prior = None  # the (ts, xs, ys, hs) of the pieces it continues


def carried_travel(prior_x, prior_y, x, y, h) -> float:
    """How far a trajectory's piece travels along the path it continues, in units of
    its own size.

    The displacement from the mean centre of the piece's first third to that of its
    last third, projected on the direction of the whole path (the earlier pieces'
    ``prior_x, prior_y`` then the piece's ``x, y``: from the mean centre of its first
    third to that of its last third), over the piece's median rectangle height.  A
    sign the camera keeps approaching keeps moving along its path; an object that
    stands still in the image after an earlier piece moved well travels by its
    jitter only (about 0), and one that turns back travels a negative amount.  0 for
    a piece of fewer than two points or a whole path without length.

    Examples
    --------
    >>> round(carried_travel([0, 2, 4], [0, 1, 2], [6, 8, 10], [3, 4, 5], [5, 5, 5]), 3)
    0.894
    >>> carried_travel([0, 2, 4], [0, 1, 2], [6, 6, 6], [3, 3, 3], [5, 5, 5])
    0.0
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if len(x) < 2:
        return 0.0
    dx = thirds_shift(np.concatenate([np.asarray(prior_x, dtype=np.float64), x]))
    dy = thirds_shift(np.concatenate([np.asarray(prior_y, dtype=np.float64), y]))
    norm = float(np.hypot(dx, dy))
    if norm <= 0:
        return 0.0
    px, py = thirds_shift(x), thirds_shift(y)
    along = (px * dx + py * dy) / norm
    return float(along / max(float(np.median(np.asarray(h, dtype=np.float64))), 1e-9))


class PCCStream(StreamState):
    """Stream state of :class:`PCCVerifier`: open trajectories and waiting frames.

    A frame is added with its tag (the record to evolve; a record of another tour
    first ends every trajectory of the previous one).  A trajectory is decided when
    it ends (``payload["ended_tracks"]`` of :class:`TrajectoryLinker`, the end of its
    tour, or :meth:`close`); a frame is final, and returned, when every trajectory
    through it is decided.  ``release=True`` keeps of a held frame's image only a lazy
    source (online, where frames would otherwise pile up in memory).
    """

    def __init__(self, verifier, *, release=True):
        self.measure = _MEASURES[verifier.criterion]
        self.min_r = float(verifier.min_r)
        self.length = int(verifier.min_length)
        self.min_length = self.length
        # models saved before the parameter existed count frames at 30 fps
        self.frame_rate = getattr(verifier, "frame_rate", REFERENCE_FRAME_RATE)
        self.min_travel = float(getattr(verifier, "min_travel", 0.0))
        approach = getattr(verifier, "min_approach", None)
        self.min_approach = None if approach is None else float(approach)
        # models saved before the parameter existed check the path alone
        scale = getattr(verifier, "min_scale_r", None)
        self.min_scale_r = None if scale is None else float(scale)
        # models saved before the parameter existed check no focus of expansion
        focus = getattr(verifier, "max_focus_offset", None)
        self.max_focus_offset = None if focus is None else float(focus)
        inward = getattr(verifier, "max_inward_offset", None)
        self.max_inward_offset = None if inward is None else float(inward)
        # models saved before the parameter existed check each piece on its own
        carry = getattr(verifier, "carry_travel", None)
        self.carry_travel = None if carry is None else float(carry)
        self.tails: dict = {}  # cut trajectory id -> (ts, xs, ys, hs, points kept)
        self.size = None  # (width, height) of the tour's frames, in the boxes' pixels
        self.vote = float(verifier.vote)
        self.release = release
        self.tour = _NO_TOUR  # a record's tour may be None
        self.open: dict = {}
        self.waiting: deque = deque()
        self._count = 0

    @property
    def n_waiting(self):
        """Frames held until the trajectories through them end."""
        return len(self.waiting)

    def _motion_ok(self, ts, xs, ys, hs):
        """``(r, motion_ok)`` of a path: the motion check of the class docstring."""
        n = len(xs)
        r = self.measure(xs, ys, ts) if n > 1 else 0.0
        long_enough = n >= self.min_length
        if not long_enough and self.min_approach is not None:
            floor = min(MIN_TRAJECTORY_POINTS, self.min_length)
            long_enough = (n >= floor
                           and approach_fraction(hs) >= self.min_approach)
        motion_ok = long_enough and abs(r) >= self.min_r
        if (long_enough and not motion_ok and self.min_scale_r is not None
                and approach_r(ts, hs) >= self.min_scale_r):
            motion_ok = True  # a steady approach, whatever the path's jitter
        if motion_ok and self.min_travel > 0:
            motion_ok = path_travel(xs, ys, hs) >= self.min_travel
        if motion_ok and self.max_focus_offset is not None:
            offset = focus_offset(xs, ys, *self.size)
            motion_ok = offset <= self.max_focus_offset
        if motion_ok and self.max_inward_offset is not None and not grows(hs):
            motion_ok = inward_offset(xs, ys, *self.size) <= self.max_inward_offset
        return r, motion_ok

    def _decide(self, traj, cut=False):
        n = len(traj.xs)
        r, motion_ok = self._motion_ok(traj.ts, traj.xs, traj.ys, traj.hs)
        prior = traj.prior
        if prior is not None:
            whole = [p + q for p, q in zip(prior[:4], (traj.ts, traj.xs, traj.ys, traj.hs),
                                           strict=True)]
            if (not motion_ok and carried_travel(prior[1], prior[2], traj.xs, traj.ys,
                                                 traj.hs) >= self.carry_travel):
                motion_ok = self._motion_ok(*whole)[1]
        if cut and self.carry_travel is not None:  # a later piece may continue it
            keep = n if prior is None else max(n, prior[4])
            path = (traj.ts, traj.xs, traj.ys, traj.hs) if prior is None else whole
            self.tails[traj.id] = (*(list(p[-keep:]) for p in path), keep)
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
        self.tails = {}
        self.tour = _NO_TOUR  # a record's tour may be None
        return self._release()

    def _push(self, record):
        boxes, appearance, tracks = frame_payload(record, self._count)
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
            self.min_length = scaled_count(
                self.length, rate_ratio(record, self.frame_rate), MIN_TRAJECTORY_POINTS
            )
            if self.max_focus_offset is not None or self.max_inward_offset is not None:
                self.size = frame_size(record)  # every frame of a tour: one size
        entry = _Frame(tag, boxes, tracks)
        if len(boxes):
            cx = (boxes[:, 0] + boxes[:, 2] / 2).tolist()
            cy = (boxes[:, 1] + boxes[:, 3] / 2).tolist()
            hs = boxes[:, 3].tolist()
            for j, (tid, a) in enumerate(
                zip(tracks.tolist(), appearance.tolist(), strict=True)
            ):
                traj = self.open.get(tid)
                if traj is None:
                    traj = self.open[tid] = _Trajectory(tid)
                traj.ts.append(record.frame)
                traj.xs.append(cx[j])
                traj.ys.append(cy[j])
                traj.hs.append(hs[j])
                traj.app.append(a)
                traj.members.append((entry, j))
        self.waiting.append(entry)
        ended = ended_tracks_of(record)
        if ended is not None:
            cut = set(cut_tracks_of(record))
            for tid in ended:
                traj = self.open.pop(tid, None)
                if traj is not None:
                    self._decide(traj, tid in cut)
        if self.carry_travel is not None:
            for tid, earlier in continued_tracks_of(record):
                tail = self.tails.pop(earlier, None)
                traj = self.open.get(tid)
                if tail is not None and traj is not None:
                    traj.prior = tail
        out.extend(self._release())
        return out


def frame_size(record):
    """``(width, height)`` of a record's image, in the pixels of its cluster boxes.

    The boxes are in the pixels of the image the stages read (the detector's
    canonical frame when it resampled the frame: a decoded array); an image in
    memory, or a file that knows its shape, is not decoded for it.
    """
    source = record.source
    if isinstance(source, DecodedImage):
        shape = source.array.shape
    else:
        shape = getattr(source, "shape", None)  # an array; an ImageFile
        if shape is None:
            shape = record.image.shape
    return float(shape[1]), float(shape[0])


def frame_payload(record, index):
    """The ``(boxes, appearance, track_ids)`` of a record, checked."""
    b = boxes_of(record, index, "PCCVerifier")
    m = len(b)
    app = per_cluster(record, index, APPEARANCE, m, "PCCVerifier")
    tracks = per_cluster(record, index, TRACK_IDS, m, "PCCVerifier")
    return b, app.astype(bool), tracks.astype(np.int64)
