"""The data contract: sample records, their containers, and their validation.

A *sample* is one frame of far-infrared video or one scan of a laser range finder
(``../shared/DESIGN.md`` section 1).  Every stage of a tunnelsense pipeline maps a
sequence of N records to a sequence of N records with the same identities and a new
payload, which is what keeps ``Pipeline``, ``clone``, ``GridSearchCV``, ``GroupKFold``
and joblib working unchanged.

This module owns:

* the record types :class:`FrameRecord` and :class:`ScanRecord`;
* the containers :class:`FrameSequence` and :class:`ScanSequence` (one or several tours
  or runs; ``len``, integer, slice and index-array indexing, concatenation);
* the bundles :class:`Tour` and :class:`Run` (records + ground truth + metadata);
* :func:`check_frames`, :func:`check_scans`, :func:`to_xy`.

Frame numbers are 1-based, as in MOTChallenge's ``gt.txt``; scan numbers are 0-based, as
in ``gt.csv``.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

__all__ = [
    "DecodedImage",
    "FrameRecord",
    "ImageFile",
    "VideoFrame",
    "FrameSequence",
    "LaserGeometry",
    "MOT_GT_COLUMNS",
    "OBJECT_CLASSES",
    "Run",
    "RUN_GT_COLUMNS",
    "RUN_LABELS",
    "ScanRecord",
    "ScanSequence",
    "Tour",
    "check_frames",
    "check_scans",
    "to_xy",
]

#: Column names of a MOTChallenge ground-truth file (``gt/gt.txt``).
MOT_GT_COLUMNS = (
    "frame",
    "id",
    "bb_left",
    "bb_top",
    "bb_width",
    "bb_height",
    "conf",
    "class",
    "visibility",
)

#: Class ids of the ground truth of FIR tours.
OBJECT_CLASSES = {1: "indicator", 2: "lamp", 3: "vehicle", 4: "shadow"}

#: Column names of a laser run's ground truth (``gt.csv``).
RUN_GT_COLUMNS = ("id", "first_scan", "last_scan", "label")

#: Object labels of laser runs, and the integer codes used in per-scan targets.
RUN_LABELS = {"parked": 1, "passing": 2}


# --------------------------------------------------------------------------------------
# Lazy image sources
# --------------------------------------------------------------------------------------
class ImageFile:
    """A frame stored as an image file, decoded with OpenCV on every access.

    Parameters
    ----------
    path : str or Path
        The image file (PNG, TIFF, ...).
    shape : tuple of int or None, default=None
        The ``(height, width)`` the tour declares; a decoded frame of another size
        raises ``ValueError`` naming the file.
    """

    __slots__ = ("path", "shape")

    def __init__(self, path, shape=None):
        self.path = str(path)
        self.shape = None if shape is None else tuple(int(s) for s in shape)

    def __getstate__(self):
        return (self.path, self.shape)

    def __setstate__(self, state):
        self.path, self.shape = state

    def __repr__(self):
        return f"ImageFile({self.path!r})"

    def load(self) -> np.ndarray:
        from tunnelsense.io._images import read_image

        image = read_image(self.path)
        if self.shape is not None and image.shape != self.shape:
            raise ValueError(
                f"{self.path}: frame is {image.shape[1]}x{image.shape[0]} px, "
                f"expected {self.shape[1]}x{self.shape[0]} px like the rest of its tour"
            )
        return image


class VideoFrame:
    """A frame of a video file, decoded with OpenCV on access (seek, then read)."""

    __slots__ = ("path", "index")

    def __init__(self, path, index):
        self.path = str(path)
        self.index = int(index)

    def __getstate__(self):
        return (self.path, self.index)

    def __setstate__(self, state):
        self.path, self.index = state

    def __repr__(self):
        return f"VideoFrame({self.path!r}, {self.index})"

    def load(self) -> np.ndarray:
        from tunnelsense.io._images import read_video_frame

        return read_video_frame(self.path, self.index)


def _origin(source):
    return source


class DecodedImage:
    """A lazy image source decoded once, for the length of one pipeline pass.

    The first stage that reads a frame (:class:`~tunnelsense.IntensityKeypointSampler`)
    wraps the frame's lazy source (an :class:`ImageFile`, a :class:`VideoFrame`) in
    one, with the decoded array; the later stages of the same pass read that array
    instead of decoding the file again.  A stage that holds frames for later (the
    online trajectory verifier) keeps :attr:`origin` instead, so memory does not grow
    with the frames held.  It pickles as its origin: no pixels travel to other
    processes.

    Parameters
    ----------
    origin : lazy source
        The object with a ``load()`` method the array was decoded from.
    array : ndarray
        The decoded image.
    """

    __slots__ = ("origin", "array")

    def __init__(self, origin, array):
        self.origin = origin
        self.array = array

    def load(self) -> np.ndarray:
        return self.array

    def __reduce__(self):
        return (_origin, (self.origin,))

    def __repr__(self):
        return f"DecodedImage({self.origin!r})"


def decode_once(record):
    """The record with its image decoded: a lazy source becomes a :class:`DecodedImage`.

    A record whose image is in memory (an array, or already decoded) is returned as
    it is.
    """
    source = record.source
    if isinstance(source, np.ndarray | DecodedImage):
        return record
    return FrameRecord(
        record.tour, record.frame, DecodedImage(source, source.load()), record.payload
    )


def release_image(source):
    """What a stage holding a frame for later keeps of its image source.

    An in-memory array is dropped (``None``); a decoded lazy source gives back its
    origin, which can decode the image again; a lazy source is kept.
    """
    if isinstance(source, np.ndarray):
        return None
    if isinstance(source, DecodedImage):
        return source.origin
    return source


# --------------------------------------------------------------------------------------
# Records
# --------------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True, eq=False)
class FrameRecord:
    """One frame of far-infrared video: its identity and a payload.

    Stages never change a record; they return a new one with the same identity
    (:meth:`evolve`).

    Parameters
    ----------
    tour : str
        Name of the tour (MOTChallenge sequence) the frame belongs to.
    frame : int
        1-based frame number within the tour.
    source : ndarray or lazy source
        The image as a 2-D ``uint8`` or ``uint16`` array, or an object with a
        ``load()`` method returning it (:class:`ImageFile`, :class:`VideoFrame`), so
        that a tour of 100,000 frames need not sit in memory.
    payload : dict, default={}
        What the stages computed so far, by name (for example ``"keypoints"``).

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import FrameRecord
    >>> r = FrameRecord("tour-a", 1, np.zeros((4, 6), np.uint8))
    >>> r.image.shape
    (4, 6)
    >>> r.evolve(keypoints=np.empty((0, 3))).payload["keypoints"].shape
    (0, 3)
    """

    tour: str
    frame: int
    source: Any
    payload: dict = field(default_factory=dict)

    @property
    def image(self) -> np.ndarray:
        """The frame's image (decoded from disk when the source is lazy)."""
        source = self.source
        return source if isinstance(source, np.ndarray) else source.load()

    @property
    def key(self) -> tuple[str, int]:
        """The record's identity ``(tour, frame)``."""
        return (self.tour, self.frame)

    def evolve(self, **payload) -> FrameRecord:
        """Return a record with the same identity and image, payload updated."""
        return FrameRecord(
            self.tour, self.frame, self.source, {**self.payload, **payload}
        )

    def __repr__(self):
        keys = ", ".join(self.payload) or "-"
        return f"FrameRecord(tour={self.tour!r}, frame={self.frame}, payload=[{keys}])"


#: The fields of :class:`LaserGeometry`, in order.
GEOMETRY_FIELDS = ("angle_min", "angle_increment", "range_min", "range_max",
                   "mount_height")

#: Physically possible values of the geometry fields: (test, what is expected).
GEOMETRY_RULES = {
    "angle_increment": (lambda v: v != 0, "a non-zero angle (rad)"),
    "range_min": (lambda v: v >= 0, "a range >= 0 (m)"),
    "range_max": (lambda v: v > 0, "a range > 0 (m)"),
    "mount_height": (lambda v: v > 0, "a height > 0 (m) above the road"),
}


def geometry_problem(values: Mapping) -> str | None:
    """What makes a laser geometry impossible, or None.

    Parameters
    ----------
    values : mapping
        The :data:`GEOMETRY_FIELDS` and their values.

    Returns
    -------
    problem : str or None
        For instance ``"angle_increment is 0.0, expected a non-zero angle (rad)"``.
    """
    floats = {}
    for k in GEOMETRY_FIELDS:
        v = floats[k] = _finite_float(values[k])
        if v is None:
            return f"{k} is {values[k]!r}, expected a finite number"
        test, expected = GEOMETRY_RULES.get(k, (None, None))
        if test is not None and not test(v):
            return f"{k} is {v!r}, expected {expected}"
    if floats["range_min"] >= floats["range_max"]:
        return (
            f"range_min ({floats['range_min']!r}) must be below range_max "
            f"({floats['range_max']!r})"
        )
    return None


def _finite_float(value) -> float | None:
    """``value`` as a finite float, or None if it is not a finite real number."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        return None
    try:
        value = float(value)
    except OverflowError:
        return None
    return value if math.isfinite(value) else None


@dataclass(frozen=True, slots=True)
class LaserGeometry:
    """How the beams of a vertically scanning laser range finder are laid out.

    Field names and units follow ROS ``sensor_msgs/LaserScan`` (radians, metres).

    Parameters
    ----------
    angle_min : float
        Angle of the first beam (rad), measured from the horizontal, positive up.
    angle_increment : float
        Angle between consecutive beams (rad).
    range_min, range_max : float
        Valid range interval (m).  A range ``>= range_max``, NaN or +inf is no return.
    mount_height : float
        Height of the sensor above the road (m).

    Raises
    ------
    ValueError
        A field that is not a finite number, ``angle_increment == 0``,
        ``range_min < 0``, ``range_max <= range_min`` or ``mount_height <= 0``.
    """

    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    mount_height: float

    def __post_init__(self):
        problem = geometry_problem({k: getattr(self, k) for k in GEOMETRY_FIELDS})
        if problem is not None:
            raise ValueError(f"impossible LaserGeometry: {problem}")

    def angles(self, n_beams: int) -> np.ndarray:
        """The beam angles (rad) of a scan of ``n_beams`` beams."""
        return self.angle_min + self.angle_increment * np.arange(n_beams)


@dataclass(frozen=True, slots=True, eq=False)
class ScanRecord:
    """One scan of a laser range finder: identity, ranges, geometry and payload.

    Parameters
    ----------
    run : str
        Name of the run the scan belongs to.
    scan : int
        0-based scan number within the run.
    ranges : ndarray of shape (n_beams,)
        Ranges in metres; NaN, +inf or ``>= geometry.range_max`` mean no return.
    stamp : float
        Time of the scan (s).
    geometry : LaserGeometry
        Beam layout and mounting height.
    payload : dict, default={}
        What the stages computed so far, by name.
    """

    run: str
    scan: int
    ranges: np.ndarray
    stamp: float
    geometry: LaserGeometry
    payload: dict = field(default_factory=dict)

    @property
    def key(self) -> tuple[str, int]:
        """The record's identity ``(run, scan)``."""
        return (self.run, self.scan)

    def evolve(self, **payload) -> ScanRecord:
        """Return a record with the same identity and ranges, payload updated."""
        return ScanRecord(
            self.run,
            self.scan,
            self.ranges,
            self.stamp,
            self.geometry,
            {**self.payload, **payload},
        )

    def __repr__(self):
        keys = ", ".join(self.payload) or "-"
        return (
            f"ScanRecord(run={self.run!r}, scan={self.scan}, "
            f"beams={len(self.ranges)}, payload=[{keys}])"
        )


# --------------------------------------------------------------------------------------
# Containers
# --------------------------------------------------------------------------------------
class _RecordSequence(Sequence):
    """A sequence of records that scikit-learn can split.

    ``len``, integer indexing (a record), slice / integer-array / boolean-array
    indexing (a sequence of the same type), ``+`` and :meth:`concat`.  It has no
    ``shape`` on purpose: scikit-learn's ``_safe_indexing`` then hands each CV fold a
    plain list of records, which every stage accepts.
    """

    _record_type: type = object
    _group_attr = ""

    __slots__ = ("_records",)

    def __init__(self, records: Iterable = ()):
        records = tuple(records)
        for i, r in enumerate(records):
            if not isinstance(r, self._record_type):
                raise TypeError(
                    f"{type(self).__name__} holds {self._record_type.__name__} "
                    f"objects; element {i} is {type(r).__name__}"
                )
        self._records = records

    def __getstate__(self):
        return self._records

    def __setstate__(self, state):
        self._records = state

    def __len__(self):
        return len(self._records)

    def __iter__(self):
        return iter(self._records)

    def __getitem__(self, index):
        if isinstance(index, numbers.Integral):
            return self._records[index]
        if isinstance(index, slice):
            return type(self)(self._records[index])
        index = np.asarray(index)
        if index.dtype == bool:
            if index.shape != (len(self),):
                raise IndexError(
                    f"boolean index of shape {index.shape} for {len(self)} records"
                )
            index = np.flatnonzero(index)
        elif index.ndim != 1 or not np.issubdtype(index.dtype, np.integer):
            if index.size == 0:
                index = index.astype(np.intp).ravel()
            else:
                raise IndexError(
                    "records are indexed by an int, a slice, or a 1-D array of ints "
                    f"or bools; got an array of dtype {index.dtype} and shape "
                    f"{index.shape}"
                )
        records = self._records
        return type(self)(records[i] for i in index.tolist())

    def __add__(self, other):
        if not isinstance(other, _RecordSequence | list | tuple):
            return NotImplemented
        return type(self)((*self._records, *other))

    @classmethod
    def concat(cls, sequences: Iterable[Iterable]):
        """Concatenate several sequences of records (for example several tours)."""
        return cls(r for seq in sequences for r in seq)

    @property
    def groups(self) -> np.ndarray:
        """The tour (run) name of every record, for ``GroupKFold``."""
        return np.array(
            [getattr(r, self._group_attr) for r in self._records], dtype=object
        )

    def __repr__(self):
        names = dict.fromkeys(getattr(r, self._group_attr) for r in self._records)
        shown = ", ".join(repr(n) for n in list(names)[:3])
        more = f", ... ({len(names)} in all)" if len(names) > 3 else ""
        return f"{type(self).__name__}({len(self)} records of [{shown}{more}])"


class FrameSequence(_RecordSequence):
    """Frames of one or several tours, loaded lazily (see :class:`FrameRecord`).

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import FrameSequence
    >>> a = FrameSequence.from_array(np.zeros((3, 4, 6), np.uint8), tour="a")
    >>> b = FrameSequence.from_array(np.zeros((2, 4, 6), np.uint8), tour="b")
    >>> X = a + b
    >>> len(X), X[[0, 4]].groups.tolist()
    (5, ['a', 'b'])
    """

    _record_type = FrameRecord
    _group_attr = "tour"
    __slots__ = ()

    @classmethod
    def from_array(cls, images, *, tour: str = "tour", first_frame: int = 1):
        """Frames of one tour from an array of shape ``(n_frames, height, width)``."""
        images = np.asarray(images)
        if images.ndim != 3:
            raise ValueError(
                "images must be an array of shape (n_frames, height, width); "
                f"got shape {images.shape}"
            )
        return cls(
            FrameRecord(str(tour), first_frame + i, images[i])
            for i in range(len(images))
        )


class ScanSequence(_RecordSequence):
    """Scans of one or several laser runs (see :class:`ScanRecord`)."""

    _record_type = ScanRecord
    _group_attr = "run"
    __slots__ = ()

    @classmethod
    def from_arrays(cls, ranges, stamps, geometry: LaserGeometry, *, run: str = "run"):
        """Scans of one run from ``ranges`` (n_scans, n_beams) and ``stamps``."""
        ranges = np.asarray(ranges, dtype=np.float64)
        stamps = np.asarray(stamps, dtype=np.float64)
        if ranges.ndim != 2:
            raise ValueError(
                f"ranges must have shape (n_scans, n_beams); got shape {ranges.shape}"
            )
        if stamps.shape != (len(ranges),):
            raise ValueError(
                f"stamps must have shape ({len(ranges)},) to match ranges; "
                f"got shape {stamps.shape}"
            )
        return cls(
            ScanRecord(str(run), i, ranges[i], float(stamps[i]), geometry)
            for i in range(len(ranges))
        )

    def ranges(self) -> np.ndarray:
        """The ranges of all scans stacked, shape ``(n_scans, n_beams)``."""
        if not self._records:
            return np.empty((0, 0))
        return np.stack([r.ranges for r in self._records])


# --------------------------------------------------------------------------------------
# Bundles: records + ground truth + metadata
# --------------------------------------------------------------------------------------
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
        Frames per second.
    info : dict, default={}
        Further sequence information (camera parameters, scenario, ...); written to
        ``seqinfo.ini`` under ``[Sequence]`` and read back as strings.
    """

    name: str
    frames: FrameSequence
    gt: pd.DataFrame = field(default_factory=empty_mot_gt)
    frame_rate: float = 30.0
    info: dict = field(default_factory=dict)

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


# --------------------------------------------------------------------------------------
# Validation
# --------------------------------------------------------------------------------------
def _as_records(X, record_type, container, name):
    if isinstance(X, container):
        return list(X)
    if isinstance(X, np.ndarray | str | bytes | Mapping):
        raise TypeError(
            f"{name} must be a sequence of {record_type.__name__} "
            f"(for example a {container.__name__}); got {type(X).__name__}"
            + (f" of shape {X.shape}" if isinstance(X, np.ndarray) else "")
        )
    try:
        records = list(X)
    except TypeError:
        raise TypeError(
            f"{name} must be a sequence of {record_type.__name__}; "
            f"got {type(X).__name__}"
        ) from None
    for i, r in enumerate(records):
        if not isinstance(r, record_type):
            raise TypeError(
                f"{name} must be a sequence of {record_type.__name__}; "
                f"element {i} is {type(r).__name__}"
            )
    return records


def _check_y(y, n, width, name_of_kind, dtype):
    if y is None:
        return None
    if isinstance(y, np.ndarray) and y.dtype != object and y.ndim != 3:
        raise ValueError(
            f"y must hold one array per {name_of_kind}; got an array of shape {y.shape}"
        )
    try:
        y = list(y)
    except TypeError:
        raise TypeError(
            f"y must be a sequence with one array per {name_of_kind}; "
            f"got {type(y).__name__}"
        ) from None
    if len(y) != n:
        raise ValueError(
            f"y has {len(y)} entries but X has {n} {name_of_kind}s: "
            f"expected one per {name_of_kind}"
        )
    out = []
    for i, yi in enumerate(y):
        try:
            a = np.asarray(yi, dtype=dtype)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"y[{i}] is not numeric: {exc}") from None
        if a.size == 0:
            a = a.reshape(0, width)
        if a.ndim != 2 or a.shape[1] != width:
            raise ValueError(
                f"y[{i}] must have shape (k, {width}); got shape {a.shape}"
            )
        if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
            raise ValueError(f"y[{i}] contains NaN or infinity")
        out.append(a)
    return out


def check_frames(X, y=None):
    """Validate frame records (and per-frame boxes) for a frame stage.

    Parameters
    ----------
    X : sequence of FrameRecord
        A :class:`FrameSequence` or any sequence of :class:`FrameRecord` (for example
        the plain list scikit-learn makes for a CV fold).
    y : sequence of array-like of shape (k_i, 4), default=None
        Per frame, the indicator boxes ``(left, top, width, height)``.

    Returns
    -------
    records : list of FrameRecord
    y : list of ndarray of shape (k_i, 4), float64, or None

    Raises
    ------
    TypeError
        ``X`` is not a sequence of :class:`FrameRecord`.
    ValueError
        ``y`` does not hold one ``(k, 4)`` finite numeric array per frame.
    """
    records = _as_records(X, FrameRecord, FrameSequence, "X")
    return records, _check_y(y, len(records), 4, "frame", np.float64)


def check_scans(X, y=None):
    """Validate scan records (and per-scan targets) for a scan stage.

    Parameters
    ----------
    X : sequence of ScanRecord
        A :class:`ScanSequence` or any sequence of :class:`ScanRecord`.
    y : sequence of array-like of shape (k_i, 2), default=None
        Per scan, ``(object id, label code)`` of the objects in view.

    Returns
    -------
    records : list of ScanRecord
    y : list of ndarray of shape (k_i, 2), int64, or None
    """
    records = _as_records(X, ScanRecord, ScanSequence, "X")
    for i, r in enumerate(records):
        if r.ranges.ndim != 1:
            raise ValueError(
                f"X[{i}] ({r.run!r}, scan {r.scan}): ranges must be 1-D; "
                f"got shape {r.ranges.shape}"
            )
    return records, _check_y(y, len(records), 2, "scan", np.int64)
