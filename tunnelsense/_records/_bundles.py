"""Bundles of records, ground truth and metadata: tours and runs, and ``to_xy``."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from tunnelsense._payload import FRAME_RATE
from tunnelsense._records._frames import MOT_GT_COLUMNS, FrameRecord
from tunnelsense._records._scans import (
    RUN_GT_COLUMNS,
    RUN_LABELS,
    LaserGeometry,
)
from tunnelsense._records._sequences import FrameSequence, ScanSequence

__all__ = ["Run", "Tour", "empty_mot_gt", "empty_run_gt", "to_xy"]


def _empty_gt(columns, dtypes):
    return pd.DataFrame(
        {c: pd.Series(dtype=d) for c, d in zip(columns, dtypes, strict=True)}
    )


def empty_mot_gt() -> pd.DataFrame:
    """An empty ground-truth table with the MOTChallenge columns and dtypes."""
    return _empty_gt(
        MOT_GT_COLUMNS, ["int64", "int64"] + ["float64"] * 5 + ["int64", "float64"]
    )


def empty_run_gt() -> pd.DataFrame:
    """An empty laser-run ground-truth table (``id,first_scan,last_scan,label``)."""
    return _empty_gt(RUN_GT_COLUMNS, ["int64", "int64", "int64", str])


@dataclass(frozen=True, eq=False)
class Tour:
    """A far-infrared tour: its frames, ground truth and sequence information.

    Parameters
    ----------
    name : str
        Sequence name (``seqinfo.ini`` ``name``).
    frames : FrameSequence
        The frames, numbered from 1.
    gt : DataFrame
        Ground truth with the columns :data:`MOT_GT_COLUMNS` (possibly empty).
    frame_rate : float, default=30.0
        Frames per second.  Every frame of the tour carries it
        (``payload["frame_rate"]``), so the stages that count frames
        (:class:`~tunnelsense.tunnel.TrajectoryLinker`,
        :class:`~tunnelsense.tunnel.PCCVerifier`) follow the tour's frame rate
        wherever its frames go (:func:`to_xy`, a split of a grid search, a stream).
    info : dict, default={}
        Further sequence information (camera parameters, scenario, ...); written to
        ``seqinfo.ini`` under ``[Sequence]`` and read back as strings.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import Tour
    >>> tour = Tour.from_array("a", np.zeros((2, 4, 4), np.uint8), frame_rate=9)
    >>> tour.frames[1].payload["frame_rate"]
    9.0
    """

    name: str
    frames: FrameSequence
    gt: pd.DataFrame = field(default_factory=empty_mot_gt)
    frame_rate: float = 30.0
    info: dict = field(default_factory=dict)

    def __post_init__(self):
        object.__setattr__(
            self, "frames", with_frame_rate(self.frames, self.frame_rate)
        )

    def __len__(self):
        return len(self.frames)

    @classmethod
    def from_array(cls, name, images, gt=None, *, frame_rate=30.0, info=None):
        """A tour held in memory, from an array ``(n_frames, height, width)``."""
        frames = FrameSequence.from_array(images, tour=name)
        return cls(
            str(name),
            frames,
            empty_mot_gt() if gt is None else gt,
            float(frame_rate),
            dict(info or {}),
        )

    @property
    def image_shape(self) -> tuple[int, int]:
        """``(height, width)`` of the frames (decodes the first frame if lazy)."""
        if not len(self.frames):
            raise ValueError(f"tour {self.name!r} has no frames")
        source = self.frames[0].source
        shape = getattr(source, "shape", None)
        if shape is None or len(shape) != 2:
            shape = self.frames[0].image.shape[:2]
        return tuple(int(s) for s in shape[:2])

    def boxes(self, classes=(1,), *, min_height=0.0) -> list[np.ndarray]:
        """Per frame, the ``(k, 4)`` boxes ``(left, top, width, height)`` of ``classes``.

        Parameters
        ----------
        classes : sequence of int, default=(1,)
            Ground-truth class ids to keep (1 = indicator).
        min_height : float, default=0.0
            Keep only boxes at least this tall (px).
        """
        return _boxes_per_frame(
            self.gt, [r.frame for r in self.frames], classes, min_height
        )

    def xy(self):
        """``(X, y, groups)`` of this tour alone; see :func:`to_xy`."""
        return to_xy([self])


def with_frame_rate(frames, frame_rate):
    """The frames, each carrying ``payload["frame_rate"]`` (records already carrying
    this rate, and anything that is not a frame record, are kept as they are).

    A rate that is not a positive finite number leaves the frames unchanged.
    """
    try:
        rate = float(frame_rate)
    except (TypeError, ValueError):
        return frames
    if not (np.isfinite(rate) and rate > 0):
        return frames
    if not any(isinstance(r, FrameRecord) and r.payload.get(FRAME_RATE) != rate
               for r in frames):
        return frames
    stamped = [
        r.evolve(**{FRAME_RATE: rate})
        if isinstance(r, FrameRecord) and r.payload.get(FRAME_RATE) != rate else r
        for r in frames
    ]
    return FrameSequence(stamped) if isinstance(frames, FrameSequence) else stamped


def _boxes_per_frame(gt, frame_numbers, classes, min_height=0.0):
    # plain arrays: a pandas groupby copies the frame's attrs (a reader's line
    # numbers) once per group
    cols = ["bb_left", "bb_top", "bb_width", "bb_height"]
    keep = (np.isin(gt["class"].to_numpy(), list(classes))
            & (gt["bb_height"].to_numpy() >= min_height))
    frames = gt["frame"].to_numpy()[keep].astype(np.int64)
    boxes = gt[cols].to_numpy(dtype=np.float64)[keep]
    order = np.argsort(frames, kind="stable")
    frames, boxes = frames[order], boxes[order]
    starts = np.flatnonzero(np.r_[True, frames[1:] != frames[:-1]])[: len(frames)]
    ends = np.r_[starts[1:], len(frames)][: len(starts)]
    by_frame = {int(frames[a]): boxes[a:b] for a, b in zip(starts, ends, strict=True)}
    empty = np.empty((0, 4), dtype=np.float64)
    return [by_frame.get(int(f), empty) for f in frame_numbers]


@dataclass(frozen=True, eq=False)
class Run:
    """A laser run: its scans, ground truth and sensor geometry.

    Parameters
    ----------
    name : str
        Name of the run (its folder name when read from disk).
    scans : ScanSequence
        The scans, numbered from 0.
    gt : DataFrame
        Ground truth with the columns :data:`RUN_GT_COLUMNS` (possibly empty).
    info : dict, default={}
        Further run information (scenario, speed, ...).
    """

    name: str
    scans: ScanSequence
    gt: pd.DataFrame = field(default_factory=empty_run_gt)
    info: dict = field(default_factory=dict)

    def __len__(self):
        return len(self.scans)

    @classmethod
    def from_arrays(cls, name, ranges, stamps, geometry, gt=None, *, info=None):
        """A run from ``ranges`` (n_scans, n_beams), ``stamps`` and its geometry."""
        scans = ScanSequence.from_arrays(ranges, stamps, geometry, run=name)
        return cls(
            str(name), scans, empty_run_gt() if gt is None else gt, dict(info or {})
        )

    @property
    def geometry(self) -> LaserGeometry:
        """The sensor geometry of the run's scans (that of its first scan)."""
        if not len(self.scans):
            raise ValueError(f"run {self.name!r} has no scans")
        return self.scans[0].geometry

    def targets(self) -> list[np.ndarray]:
        """Per scan, the ``(k, 2)`` int array ``(id, label code)`` of objects in view.

        Label codes are :data:`RUN_LABELS` (1 = parked, 2 = passing).
        """
        n = len(self.scans)
        per_scan = [[] for _ in range(n)]
        for oid, first, last, label in self.gt[list(RUN_GT_COLUMNS)].itertuples(
            index=False
        ):
            code = RUN_LABELS[label]
            for s in range(max(int(first), 0), min(int(last), n - 1) + 1):
                per_scan[s].append((int(oid), code))
        return [np.array(t, dtype=np.int64).reshape(-1, 2) for t in per_scan]

    def xy(self):
        """``(X, y, groups)`` of this run alone; see :func:`to_xy`."""
        return to_xy([self])


def to_xy(datasets: Iterable[Tour | Run] | Tour | Run, *, classes=(1,)):
    """Concatenate tours (or runs) into ``(X, y, groups)`` for a grid search.

    Parameters
    ----------
    datasets : Tour, Run, or iterable of them
        Tours (or runs; all of one kind).
    classes : sequence of int, default=(1,)
        For tours, the ground-truth classes whose boxes go into ``y`` (1 = indicator).

    Returns
    -------
    X : FrameSequence or ScanSequence
        All records, tour after tour.
    y : list of ndarray
        Per frame, the ``(k, 4)`` boxes ``(left, top, width, height)``; per scan, the
        ``(k, 2)`` array ``(id, label code)`` (see :meth:`Run.targets`).
    groups : ndarray of object
        The tour (run) name of every record, for ``GroupKFold``.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.model_selection import GroupKFold
    >>> from tunnelsense import Tour, to_xy
    >>> tours = [Tour.from_array(n, np.zeros((3, 8, 8), np.uint8)) for n in "ab"]
    >>> X, y, groups = to_xy(tours)
    >>> len(X), len(y), sorted(set(groups))
    (6, 6, ['a', 'b'])
    >>> [len(test) for _, test in GroupKFold(2).split(X, y, groups)]
    [3, 3]
    """
    if isinstance(datasets, Tour | Run):
        datasets = [datasets]
    datasets = list(datasets)
    if not datasets:
        raise ValueError("datasets is empty: expected at least one Tour or Run")
    kinds = {type(d) for d in datasets}
    if len(kinds) != 1 or not kinds <= {Tour, Run}:
        raise TypeError(
            "datasets must be all Tour or all Run objects; got "
            + ", ".join(sorted(k.__name__ for k in kinds))
        )
    names = [d.name for d in datasets]
    if len(set(names)) != len(names):
        raise ValueError(f"datasets must have distinct names; got {names}")
    if Tour in kinds:
        X = FrameSequence.concat(d.frames for d in datasets)
        y = [b for d in datasets for b in d.boxes(classes)]
    else:
        X = ScanSequence.concat(d.scans for d in datasets)
        y = [t for d in datasets for t in d.targets()]
    return X, y, X.groups
