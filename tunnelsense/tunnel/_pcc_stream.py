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
    motion_fit_r,
    path_travel,
    pearson_r,
    straightness,
)

__all__ = [
    "PCCStream",
    "approach_fraction",
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
    __slots__ = ("ts", "xs", "ys", "hs", "app", "members")

    def __init__(self):
        self.ts, self.xs, self.ys, self.hs, self.app, self.members = [], [], [], [], [], []


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

    def _decide(self, traj):
        n = len(traj.xs)
        r = self.measure(traj.xs, traj.ys, traj.ts) if n > 1 else 0.0
        long_enough = n >= self.min_length
        if not long_enough and self.min_approach is not None:
            floor = min(MIN_TRAJECTORY_POINTS, self.min_length)
            long_enough = (n >= floor
                           and approach_fraction(traj.hs) >= self.min_approach)
        motion_ok = long_enough and abs(r) >= self.min_r
        if (long_enough and not motion_ok and self.min_scale_r is not None
                and approach_r(traj.ts, traj.hs) >= self.min_scale_r):
            motion_ok = True  # a steady approach, whatever the path's jitter
        if motion_ok and self.min_travel > 0:
            motion_ok = path_travel(traj.xs, traj.ys, traj.hs) >= self.min_travel
        if motion_ok and self.max_focus_offset is not None:
            offset = focus_offset(traj.xs, traj.ys, *self.size)
            motion_ok = offset <= self.max_focus_offset
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
            if self.max_focus_offset is not None:  # every frame of a tour: one size
                self.size = frame_size(record)
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
                    traj = self.open[tid] = _Trajectory()
                traj.ts.append(record.frame)
                traj.xs.append(cx[j])
                traj.ys.append(cy[j])
                traj.hs.append(hs[j])
                traj.app.append(a)
                traj.members.append((entry, j))
        self.waiting.append(entry)
        ended = ended_tracks_of(record)
        if ended is not None:
            for tid in ended:
                traj = self.open.pop(tid, None)
                if traj is not None:
                    self._decide(traj)
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
