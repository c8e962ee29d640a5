"""Laser runs on disk: ``scans.npz`` (ROS LaserScan field names) and ``gt.csv``.

A run folder holds::

    scans.npz   ranges (n_scans, n_beams) m, angle_min, angle_increment, range_min,
                range_max, stamps (n_scans,) s, mount_height m; optional angle_max,
                info_json (a JSON string of run information)
    gt.csv      id,first_scan,last_scan,label   (0-based, inclusive; parked | passing)

No return may be written as NaN, +inf or a range ``>= range_max``: drivers differ, and
all three are accepted.  Ranges are float metres; integer millimetres are read with
``range_unit="mm"``.  A run holds at least one scan of at least one beam, its stamps
increase strictly, and the members of ``scans.npz`` are ``.npy`` arrays without
Python objects (NumPy's ``np.savez`` writes such files).
"""

from __future__ import annotations

import csv
import io
import json
import math
import numbers
import struct
import zipfile
import zlib
from pathlib import Path

import numpy as np
import pandas as pd

from tunnelsense._records import (
    GEOMETRY_FIELDS,
    GEOMETRY_RULES,
    RUN_GT_COLUMNS,
    RUN_LABELS,
    LaserGeometry,
    Run,
    ScanSequence,
    empty_run_gt,
    geometry_problem,
)
from tunnelsense.exceptions import InputFormatError
from tunnelsense.io._mot import LineNumbers

__all__ = [
    "RunStream",
    "ego_speed",
    "open_run_stream",
    "read_objects",
    "read_run",
    "read_run_gt",
    "write_run",
    "write_run_gt",
]

_SCALARS = GEOMETRY_FIELDS

#: Units of ``ranges`` in a file: ROS says metres; some drivers write integer mm.
RANGE_UNITS = {"m": 1.0, "mm": 0.001}

#: Physically possible values of the geometry fields (shared with the bag reader).
_GEOMETRY_RULES = GEOMETRY_RULES

#: What reading a damaged zip or .npy member raises.
_NPZ_ERRORS = (zipfile.BadZipFile, zlib.error, ValueError, OSError, EOFError, KeyError,
               NotImplementedError, RuntimeError, OverflowError, TypeError,
               struct.error)

#: The .npy format versions NumPy reads, and their header readers.
_NPY_HEADERS = {
    (1, 0): np.lib.format.read_array_header_1_0,
    (2, 0): np.lib.format.read_array_header_2_0,
    (3, 0): np.lib.format.read_array_header_2_0,  # 2.0 with a UTF-8 header
}


def _corrupt(npz_path, problem) -> InputFormatError:
    return InputFormatError(f"{npz_path}: corrupt or not an .npz file ({problem})")


class _Member:
    """A ``.npy`` member of an npz, its header read and checked against its size."""

    def __init__(self, npz_path, zf, info):
        self.npz_path, self.name = npz_path, info.filename
        try:
            with zf.open(info) as f:
                version = np.lib.format.read_magic(f)
                if version not in _NPY_HEADERS:
                    raise ValueError(f".npy format version {version[0]}."
                                     f"{version[1]} is not supported")
                self.shape, self.fortran, self.dtype = _NPY_HEADERS[version](f)
                self.offset = f.tell()
        except _NPZ_ERRORS as exc:
            raise _corrupt(npz_path, f"{self.name}: {exc}") from None
        problem = self._problem(info.file_size - self.offset)
        if problem:
            raise _corrupt(npz_path, f"{self.name}: {problem}")

    def _read_into(self, zf, view) -> None:
        """Fill ``view`` with the member's data, in bounded reads, checking its CRC."""
        with zf.open(self.name) as f:
            f.read(self.offset)
            done = 0
            while done < len(view):
                chunk = f.read(min(len(view) - done, 1 << 22))
                if not chunk:
                    raise _corrupt(self.npz_path, f"{self.name}: ends early")
                view[done : done + len(chunk)] = chunk
                done += len(chunk)
            f.read()  # to the end of the member: checks its CRC

    def _problem(self, data_bytes) -> str | None:
        if self.dtype.hasobject:
            return "holds Python objects; pickled arrays are refused"
        if self.dtype.subdtype is not None or self.dtype.itemsize == 0:
            return f"unsupported dtype {self.dtype}"
        if any(n < 0 for n in self.shape):
            return f"negative dimension in shape {self.shape}"
        if self.nbytes != data_bytes:
            return (f"its header describes {self.dtype} of shape {self.shape} "
                    f"({self.nbytes} bytes), but it holds {data_bytes} bytes")
        return None

    @property
    def nbytes(self) -> int:
        """The size of the array the header describes, in bytes."""
        return math.prod(self.shape) * self.dtype.itemsize

    def read(self, zf) -> np.ndarray:
        """The whole array; reads at most the bytes the member really holds."""
        try:
            raw = np.empty(self.nbytes, dtype=np.uint8)
        except MemoryError:
            raise _corrupt(self.npz_path, f"{self.name}: {self.nbytes} bytes do not "
                           "fit in memory") from None
        try:
            self._read_into(zf, memoryview(raw))
        except InputFormatError:
            raise
        except _NPZ_ERRORS as exc:
            raise _corrupt(self.npz_path, f"{self.name}: {exc}") from None
        flat = np.frombuffer(raw, dtype=self.dtype, count=math.prod(self.shape))
        return flat.reshape(self.shape, order="F" if self.fortran else "C")


def _load_npz(path: Path, *, lazy_ranges=False) -> tuple[dict, list]:
    """The arrays of an npz by field name, and the names of its other members.

    ``ranges`` is a :class:`_LazyRanges` if ``lazy_ranges``.  Members whose names do
    not end in ``.npy`` are not read.
    """
    if not path.is_file():
        raise FileNotFoundError(f"{path}: scans file not found")
    try:
        with zipfile.ZipFile(path) as zf:
            infos = {i.filename: i for i in zf.infolist()}  # the last of a name wins
            data, others = {}, []
            for name, info in infos.items():
                if not name.endswith(".npy"):
                    others.append(name)
                    continue
                member = _Member(path, zf, info)
                if lazy_ranges and name == "ranges.npy":
                    data["ranges"] = _LazyRanges(member)
                else:
                    data[name[: -len(".npy")]] = member.read(zf)
    except InputFormatError:
        raise
    except _NPZ_ERRORS as exc:
        raise _corrupt(path, exc) from None
    return data, others


def _check_range_unit(range_unit) -> float:
    """The factor from ``range_unit`` to metres."""
    if not isinstance(range_unit, str) or range_unit not in RANGE_UNITS:
        raise InputFormatError(
            f"range_unit must be one of {', '.join(map(repr, RANGE_UNITS))}; "
            f"got {range_unit!r}"
        )
    return RANGE_UNITS[range_unit]


def _refuse_unit_for_bag(path, range_unit) -> None:
    if range_unit != "m":
        raise InputFormatError(
            f"{path}: range_unit={range_unit!r} applies to scans.npz; the ranges of "
            "sensor_msgs/LaserScan messages in a bag are metres"
        )


def read_run(path, *, range_unit="m", topic=None, mount_height=None) -> Run:
    """Read a laser run folder (``scans.npz`` + optional ``gt.csv``) as a :class:`~tunnelsense.Run`.

    Parameters
    ----------
    path : str or Path
        The run folder, or its ``scans.npz`` file; or a ROS 1 ``.bag`` file or ROS 2
        bag folder of ``sensor_msgs/LaserScan`` (the ``rosbag`` extra).
    range_unit : {"m", "mm"}, default="m"
        Unit of ``ranges`` in ``scans.npz``.  ROS ``LaserScan`` ranges are metres, as
        floats, and integer ranges are refused with ``"m"``.  Some drivers write
        integer millimetres: with ``"mm"`` every range, integer or float, is divided
        by 1000, while ``range_min`` and ``range_max`` are read as metres, as ROS
        defines them.  A bag's ranges are metres: ``"mm"`` is refused for a bag.
    topic : str, default=None
        A bag's ``LaserScan`` topic (``None``: the only one).
    mount_height : float, default=None
        For a bag: the sensor's height above the road (m), when the bag does not say.

    Returns
    -------
    run : Run
        Scans numbered from 0, ground truth (empty when there is no ``gt.csv``), and
        the run information stored in ``info_json``.

    Raises
    ------
    FileNotFoundError
        The folder or ``scans.npz`` is missing.
    InputFormatError
        ``range_unit`` is unknown; ``scans.npz`` is corrupt (the zip, a CRC, a
        member that is not a ``.npy`` array or holds pickled objects), lacks a
        field, has ranges that are not numbers of shape (n_scans, n_beams) with at
        least one scan and one beam, integer ranges read as metres, impossible
        geometry (``angle_increment`` 0, ``range_min < 0``,
        ``range_max <= range_min``, ``mount_height <= 0``, a field that is not one
        finite number), stamps that are not finite numbers increasing strictly, an
        ``angle_max`` that does not match the number of beams, or an ``info_json``
        that is not a UTF-8 JSON object; ``gt.csv`` is malformed.  The message
        names the file, and the field, member or line.
    """
    from tunnelsense.io._rosbag import is_bag

    scale = _check_range_unit(range_unit)
    if is_bag(path):
        from tunnelsense.io._rosbag import read_bag_run

        _refuse_unit_for_bag(path, range_unit)
        return read_bag_run(path, topic=topic, mount_height=mount_height)
    name, ranges, stamps, geometry, gt, info = _open_run(path, lazy=False,
                                                         range_unit=range_unit)
    ranges = _to_metres(ranges, geometry.range_max, scale)
    run = Run.from_arrays(name, ranges, stamps, geometry, gt, info=info)
    speed = ego_speed(info)
    if speed is None:
        return run
    return Run(run.name, ScanSequence([r.evolve(speed=speed) for r in run.scans]),
               run.gt, run.info)


#: Keys of the run information that give the ego speed, and their scale to m/s.
_SPEED_KEYS = (("speed", 1.0), ("speed_mps", 1.0), ("speed_kmh_mean", 1 / 3.6),
               ("speed_kmh", 1 / 3.6))


def ego_speed(info):
    """The ego speed (m/s) a run's information gives, or None.

    :func:`read_run` and :func:`open_run_stream` put it in the payload of every scan
    (``"speed"``), where :class:`~tunnelsense.street.ScanClusterer` reads it, so that
    a model fitted in Python on the runs read and one fitted by ``tunnelsense train
    street`` are the same.

    Parameters
    ----------
    info : dict or None
        Run information: the first positive number among ``speed`` and
        ``speed_mps`` (m/s), ``speed_kmh_mean`` and ``speed_kmh`` (km/h).

    Returns
    -------
    speed : float or None

    Examples
    --------
    >>> from tunnelsense.io import ego_speed
    >>> ego_speed({"scenario": "dense", "speed_kmh_mean": 36.0})
    10.0
    >>> ego_speed({}) is None
    True
    """
    for key, scale in _SPEED_KEYS:
        try:
            speed = float((info or {})[key]) * scale
        except (KeyError, TypeError, ValueError):
            continue
        if speed > 0 and math.isfinite(speed):
            return speed
    return None


def _as_float64(values) -> np.ndarray:
    """``values`` as float64; what float64 cannot hold becomes +-inf, silently."""
    with np.errstate(over="ignore"):
        return np.asarray(values).astype(np.float64)


def _to_metres(ranges, range_max, scale):
    """Ranges as C-ordered float64 metres, narrower floats' no-returns kept (+inf)."""
    with np.errstate(over="ignore", invalid="ignore"):
        if scale != 1.0:
            ranges = ranges.astype(np.float64) * scale
        elif ranges.dtype.kind == "f" and ranges.dtype != np.float64:
            # ROS ranges are float32: float32(8.191) widens to 8.19099998..., below
            # the float64 range_max. Mark no-returns in the file's own precision.
            limit = np.asarray(range_max).astype(ranges.dtype)
            ranges = np.where(ranges >= limit, np.inf, ranges)
        return np.ascontiguousarray(ranges, dtype=np.float64)


class _LazyRanges:
    """Shape and dtype of ``ranges.npy`` inside an npz, rows read on demand."""

    def __init__(self, member):
        self.member = member
        self.npz_path, self.shape, self.dtype = (
            member.npz_path, member.shape, member.dtype
        )

    def iter_chunks(self, rows):
        """Yield ``(first_scan, block)``; a damaged member raises InputFormatError.

        A column-major (Fortran-ordered) member is read whole first.
        """
        start = 0
        try:
            with zipfile.ZipFile(self.npz_path) as zf:
                blocks = (self._whole if self.member.fortran else self._rows)(zf, rows)
                for start, block in blocks:
                    yield start, block
        except InputFormatError:
            raise
        except _NPZ_ERRORS as exc:
            raise InputFormatError(
                f"{self.npz_path}: corrupt ranges.npy after scan {start} ({exc})"
            ) from None

    def _whole(self, zf, rows):
        ranges = self.member.read(zf)
        for start in range(0, len(ranges), rows):
            yield start, ranges[start : start + rows]

    def _rows(self, zf, rows):
        n_scans, n_beams = self.shape
        row_bytes = n_beams * self.dtype.itemsize
        with zf.open(self.member.name) as f:
            f.read(self.member.offset)
            for start in range(0, n_scans, rows):
                n = min(rows, n_scans - start)
                buf = f.read(n * row_bytes)
                if len(buf) != n * row_bytes:
                    raise InputFormatError(
                        f"{self.npz_path}: ranges end early (truncated file)"
                    )
                if start + n == n_scans:
                    f.read()  # to the end of the member: checks its CRC
                yield start, np.frombuffer(buf, self.dtype).reshape(n, n_beams)


def _open_run(path, *, lazy, range_unit="m"):
    _check_range_unit(range_unit)
    path = Path(path)
    if path.is_dir():
        folder, npz_path = path, path / "scans.npz"
    elif path.suffix.lower() == ".npz" and path.is_file():
        folder, npz_path = path.parent, path
    else:
        raise FileNotFoundError(f"{path}: run folder not found")
    data, others = _load_npz(npz_path, lazy_ranges=lazy)
    _check_fields(npz_path, data, others)
    ranges = data["ranges"]
    _check_ranges(npz_path, ranges, range_unit)
    stamps = _check_stamps(npz_path, data["stamps"], ranges.shape[0])
    geometry = _check_geometry(npz_path, data, ranges.shape[1])
    info = _read_info(npz_path, data)
    name = str(info.pop("name", folder.resolve().name))
    gt = _read_gt_of(folder, n_scans=ranges.shape[0])
    return name, ranges, stamps, geometry, gt, info


def _check_fields(npz_path, data, others) -> None:
    missing = [k for k in ("ranges", "stamps", *_SCALARS) if k not in data]
    if missing:
        holds = (
            f"; it holds no .npy member of those names (members: "
            f"{', '.join(others[:5])}{', ...' if len(others) > 5 else ''})"
            if others
            else ""
        )
        raise InputFormatError(
            f"{npz_path}: lacks field(s) {', '.join(missing)}{holds}"
        )


def _read_gt_of(folder, *, n_scans) -> pd.DataFrame:
    """The run's ``gt.csv`` (empty without one), its scans within the run."""
    gt_path = folder / "gt.csv"
    gt = read_run_gt(gt_path) if gt_path.exists() else empty_run_gt()
    beyond = np.flatnonzero(gt["last_scan"].to_numpy() >= n_scans)
    if beyond.size:
        i = beyond[0]
        raise InputFormatError(
            f"{gt_path}, line {gt.attrs['lines'][i]}: last_scan {gt['last_scan'].iloc[i]} "
            f"is beyond the run's {n_scans} scans (numbered from 0)"
        )
    return gt


def _check_ranges(npz_path, ranges, range_unit) -> None:
    if len(ranges.shape) != 2 or ranges.dtype.kind not in "fiu":
        raise InputFormatError(
            f"{npz_path}: ranges must be a numeric array of shape (n_scans, n_beams); "
            f"got {ranges.dtype} of shape {ranges.shape}"
        )
    if ranges.shape[0] == 0:
        raise InputFormatError(
            f"{npz_path}: ranges has 0 scans; a run holds at least one"
        )
    if ranges.shape[1] == 0:
        raise InputFormatError(f"{npz_path}: ranges has 0 beams per scan")
    if ranges.dtype.kind in "iu" and range_unit == "m":
        raise InputFormatError(
            f"{npz_path}: ranges are integers ({ranges.dtype}); ROS ranges are metres "
            "as floats. If they are millimetres, read them with range_unit='mm' "
            "(command line: --range-unit mm)"
        )


def _check_stamps(npz_path, stamps, n_scans) -> np.ndarray:
    """Stamps as float64 seconds, finite and strictly increasing."""
    if stamps.shape != (n_scans,):
        raise InputFormatError(
            f"{npz_path}: stamps must have shape ({n_scans},) to match ranges; "
            f"got {stamps.shape}"
        )
    if stamps.dtype.kind not in "fiu":
        raise InputFormatError(
            f"{npz_path}: stamps must be numbers (seconds); got {stamps.dtype}"
        )
    stamps = _as_float64(stamps)
    if not np.all(np.isfinite(stamps)):
        raise InputFormatError(f"{npz_path}: stamps contain NaN or infinity")
    bad = np.flatnonzero(np.diff(stamps) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise InputFormatError(
            f"{npz_path}: stamps must increase strictly; scan {i} (t={float(stamps[i])!r}) "
            f"does not come after scan {i - 1} (t={float(stamps[i - 1])!r})"
        )
    return stamps


def _one_finite_number(npz_path, data, k) -> float:
    value = data[k]
    number = _as_float64(value) if value.dtype.kind in "fiu" else None
    if number is None or number.size != 1 or not np.isfinite(number).all():
        shown = np.array2string(value, threshold=6) if value.size else repr(value)
        raise InputFormatError(
            f"{npz_path}: {k} must be one finite number; got {shown} "
            f"({value.dtype}, shape {value.shape})"
        )
    return float(number.reshape(()))


def _check_geometry(npz_path, data, n_beams) -> LaserGeometry:
    """The run's geometry; refuses impossible values and a wrong ``angle_max``."""
    scalars = {k: _one_finite_number(npz_path, data, k) for k in _SCALARS}
    problem = geometry_problem(scalars)
    if problem is not None:
        raise InputFormatError(f"{npz_path}: {problem}")
    if "angle_max" in data:
        _check_angle_max(npz_path, scalars, _one_finite_number(npz_path, data,
                                                               "angle_max"), n_beams)
    return LaserGeometry(**scalars)


def _check_angle_max(npz_path, scalars, angle_max, n_beams) -> None:
    start, step = scalars["angle_min"], scalars["angle_increment"]
    n_described = (angle_max - start) / step + 1  # Python floats: inf, no warning
    if not abs(n_described - n_beams) <= 0.25:
        shown = f"{n_described:.0f}" if abs(n_described) < 1e12 else f"{n_described:.3g}"
        raise InputFormatError(
            f"{npz_path}: angle_min, angle_max and angle_increment describe "
            f"{shown} beams, but ranges has {n_beams}"
        )


def _read_info(npz_path, data) -> dict:
    if "info_json" not in data:
        return {}
    value = data["info_json"]
    if value.dtype.kind not in "US" or value.size != 1:
        raise InputFormatError(
            f"{npz_path}: info_json must be one JSON string; got {value.dtype} of "
            f"shape {value.shape}"
        )
    text = _text_of(npz_path, value.reshape(()))
    try:
        info = json.loads(text)
    except (ValueError, RecursionError) as exc:  # JSONDecodeError, too many digits
        raise InputFormatError(
            f"{npz_path}: info_json is not valid JSON ({exc})"
        ) from None
    if not isinstance(info, dict):
        raise InputFormatError(
            f"{npz_path}: info_json must hold a JSON object; got {type(info).__name__}"
        )
    return info


def _text_of(npz_path, value) -> str:
    """A 0-d string array as text: bytes are UTF-8, code points valid Unicode."""
    if value.dtype.kind == "S":
        try:
            return value.item().decode("utf-8")
        except UnicodeDecodeError as exc:
            raise InputFormatError(
                f"{npz_path}: info_json is not UTF-8 text ({exc})"
            ) from None
    codes = np.frombuffer(value.tobytes(), dtype=value.dtype.str[0] + "u4")
    if np.any((codes > 0x10FFFF) | ((codes >= 0xD800) & (codes <= 0xDFFF))):
        raise InputFormatError(
            f"{npz_path}: info_json holds code points that are not Unicode characters"
        )
    return str(value.item())


class RunStream:
    """A laser run read scan by scan, with memory independent of its length.

    Made by :func:`open_run_stream`; iterate over it for the
    :class:`~tunnelsense.ScanRecord` objects, in order.

    Attributes
    ----------
    name : str
    geometry : LaserGeometry
    gt : DataFrame
    info : dict
    n_scans : int
    """

    def __init__(self, name, ranges, stamps, geometry, gt, info, chunk_scans,
                 scale=1.0):
        self.name, self.geometry, self.gt, self.info = name, geometry, gt, info
        self._ranges, self._stamps, self._chunk = ranges, stamps, chunk_scans
        self._scale = scale
        self.n_scans = int(ranges.shape[0])

    def __len__(self):
        return self.n_scans

    def __iter__(self):
        from tunnelsense._records import ScanRecord

        g = self.geometry
        speed = ego_speed(self.info)
        for start, block in self._ranges.iter_chunks(self._chunk):
            block = _to_metres(block, g.range_max, self._scale)
            for i in range(len(block)):
                s = start + i
                yield ScanRecord(self.name, s, block[i], float(self._stamps[s]), g,
                                 {} if speed is None else {"speed": speed})


def open_run_stream(path, *, chunk_scans=1024, range_unit="m", topic=None,
                    mount_height=None) -> RunStream:
    """Open a laser run for reading scan by scan (bounded memory).

    The same checks as :func:`read_run` are made up front, from the file's headers;
    the ranges are decompressed ``chunk_scans`` scans at a time while iterating.

    Parameters
    ----------
    path : str or Path
        The run folder, or its ``scans.npz`` file; or a ROS bag (see
        :func:`read_run`).
    chunk_scans : int, default=1024
        Scans decompressed at a time (at least 1).  A column-major
        (Fortran-ordered) ``ranges`` member is decompressed whole.
    range_unit : {"m", "mm"}, default="m"
        Unit of ``ranges`` in ``scans.npz``: with ``"mm"`` every range is divided
        by 1000 (see :func:`read_run`).
    topic, mount_height : see :func:`read_run`
        For a ROS bag (then the scans are read message by message).

    Returns
    -------
    stream : RunStream
        Iterable of :class:`~tunnelsense.ScanRecord`, with ``name``, ``geometry``,
        ``gt``, ``info`` and ``n_scans``.

    Raises
    ------
    FileNotFoundError
        The folder or ``scans.npz`` is missing.
    InputFormatError
        As :func:`read_run`, here or while iterating: damage found only when the
        ranges are decompressed (a bad CRC, a truncated member) is raised by the
        iteration, naming the file and the last scan read.  Also a ``chunk_scans``
        that is not an integer >= 1.

    Examples
    --------
    >>> import numpy as np, pathlib, tempfile
    >>> from tunnelsense import LaserGeometry, Run
    >>> from tunnelsense.io import open_run_stream, write_run
    >>> g = LaserGeometry(-1.4, 0.0087, 0.05, 8.191, 2.0)
    >>> run = Run.from_arrays("r", np.ones((5, 4)), np.arange(5) / 75, g)
    >>> folder = write_run(run, pathlib.Path(tempfile.mkdtemp()) / "r")
    >>> [s.scan for s in open_run_stream(folder, chunk_scans=2)]
    [0, 1, 2, 3, 4]
    """
    from tunnelsense.io._rosbag import is_bag

    scale = _check_range_unit(range_unit)
    if (
        isinstance(chunk_scans, bool | np.bool_)
        or not isinstance(chunk_scans, numbers.Integral)
        or chunk_scans < 1
    ):
        raise InputFormatError(
            f"chunk_scans must be an integer >= 1; got {chunk_scans!r}"
        )
    if is_bag(path):
        from tunnelsense.io._rosbag import open_bag_run

        _refuse_unit_for_bag(path, range_unit)
        return open_bag_run(path, topic=topic, mount_height=mount_height)
    name, ranges, stamps, geometry, gt, info = _open_run(path, lazy=True,
                                                         range_unit=range_unit)
    return RunStream(name, ranges, stamps, geometry, gt, info, int(chunk_scans),
                     scale)


def read_run_gt(path) -> pd.DataFrame:
    """Read a laser run's ``gt.csv`` (``id,first_scan,last_scan,label``).

    The first line is the header; further columns are allowed and left out; blank
    lines are skipped.  A row with more non-empty fields than the header is refused
    (never shifted).

    Parameters
    ----------
    path : str or Path
        The ground-truth file.

    Returns
    -------
    gt : DataFrame
        ``id``, ``first_scan``, ``last_scan`` as int64 and ``label`` as strings;
        ``gt.attrs["lines"]`` holds the file line of each row.

    Raises
    ------
    FileNotFoundError
        The file is missing.
    InputFormatError
        Text that is not UTF-8 CSV, a missing or repeated column, a row with more
        fields than the header, a scan number that is not an integer of at most 18
        digits, ``first_scan > last_scan`` or a label other than ``parked`` /
        ``passing`` (names the file and line).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: ground-truth file not found")
    lines, header, rows = _read_csv_rows(path)
    columns = _gt_columns(path, header)
    out = {
        c: np.array(
            [_scan_number(path, i, c, row[columns[c]]) for i, row in zip(lines, rows,
                                                                          strict=True)],
            dtype=np.int64,
        )
        for c in ("id", "first_scan", "last_scan")
    }
    labels = [row[columns["label"]].strip() for row in rows]
    for i, label in zip(lines, labels, strict=True):
        if label not in RUN_LABELS:
            raise InputFormatError(
                f"{path}, line {i}: unknown label {label!r}, expected one of "
                f"{', '.join(RUN_LABELS)}"
            )
    for i, a, b in zip(lines, out["first_scan"], out["last_scan"], strict=True):
        if a < 0 or b < a:
            raise InputFormatError(
                f"{path}, line {i}: first_scan={a}, last_scan={b}; expected "
                "0 <= first_scan <= last_scan"
            )
    table = pd.DataFrame({**out, "label": pd.Series(labels, dtype=str)})
    table.attrs["lines"] = LineNumbers(lines)
    return table


def _read_csv_rows(path) -> tuple[list, list, list]:
    """File lines (from 2) and fields of the non-blank rows, and the header's fields.

    Rows shorter than the header are padded with empty fields; fields beyond the
    header's are refused unless empty.
    """
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputFormatError(f"{path}: not UTF-8 text ({exc})") from None
    reader = csv.reader(io.StringIO(text, newline=""), strict=True)
    header, lines, rows = None, [], []
    try:
        while True:
            line = reader.line_num + 1
            row = next(reader, None)
            if row is None:
                break
            if header is None:
                header = [c.strip() for c in row]
            elif any(f.strip() for f in row):
                if any(f.strip() for f in row[len(header) :]):
                    raise InputFormatError(
                        f"{path}, line {line}: {len(row)} fields, expected "
                        f"{len(header)} as in the header"
                    )
                lines.append(line)
                rows.append((row + [""] * len(header))[: len(header)])
    except csv.Error as exc:
        raise InputFormatError(
            f"{path}, line {reader.line_num}: not readable as CSV ({exc})"
        ) from None
    return lines, header or [], rows


def _gt_columns(path, header) -> dict:
    """The position of each ground-truth column in the header."""
    missing = [c for c in RUN_GT_COLUMNS if c not in header]
    if missing:
        raise InputFormatError(
            f"{path}: lacks column(s) {', '.join(missing)} (expected header "
            f"{','.join(RUN_GT_COLUMNS)})"
        )
    for c in RUN_GT_COLUMNS:
        if header.count(c) > 1:
            raise InputFormatError(f"{path}, line 1: column {c} appears twice")
    return {c: header.index(c) for c in RUN_GT_COLUMNS}


def _scan_number(path, line, column, text) -> int:
    """An integer field of gt.csv, of at most 18 digits (int64 holds it)."""
    try:
        number = int(text.strip())
    except ValueError:  # not an integer, or thousands of digits
        number = None
    if number is None or not -(2**62) < number < 2**62:
        raise InputFormatError(
            f"{path}, line {line}: {column} is {text!r}, expected an integer"
            + ("" if number is None else " of at most 18 digits")
        )
    return number


def read_objects(path) -> pd.DataFrame:
    """Read an object table written by ``tunnelsense detect street``.

    Parameters
    ----------
    path : str or Path
        A CSV file with at least the columns ``first_scan``, ``last_scan`` and
        ``label`` (``detect street`` writes ``id,first_scan,last_scan,label,...``).

    Returns
    -------
    objects : DataFrame

    Raises
    ------
    FileNotFoundError
        The file is missing.
    ValueError
        It is not a CSV table or lacks a column; the message names the file.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: objects file not found")
    try:
        objects = pd.read_csv(path)
    except (pd.errors.ParserError, UnicodeDecodeError, pd.errors.EmptyDataError) as exc:
        raise ValueError(f"{path}: not a CSV object table ({exc})") from None
    missing = [c for c in ("first_scan", "last_scan", "label") if c not in objects]
    if missing:
        raise ValueError(f"{path}: lacks column(s) {', '.join(missing)}: expected "
                         "id,first_scan,last_scan,label,mean_depth")
    return objects


def write_run_gt(gt: pd.DataFrame, path) -> None:
    """Write a laser run's ground truth as ``gt.csv``.

    Parameters
    ----------
    gt : DataFrame
        With the columns ``id,first_scan,last_scan,label``.
    path : str or Path
        The file to write (its folder is created).
    """
    missing = [c for c in RUN_GT_COLUMNS if c not in gt.columns]
    if missing:
        raise ValueError(f"cannot write {path}: the table lacks columns {missing}")
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    gt[list(RUN_GT_COLUMNS)].to_csv(path, index=False, lineterminator="\n")


def _write_npz(path: Path, arrays: dict) -> None:
    """Like ``np.savez_compressed`` but byte-identical for identical arrays.

    NumPy stamps each member with the current time; a fixed timestamp makes the same
    run give the same file.
    """
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for key, value in arrays.items():
            info = zipfile.ZipInfo(f"{key}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            with zf.open(info, "w", force_zip64=True) as f:
                np.lib.format.write_array(f, np.asanyarray(value), allow_pickle=False)


def write_run(run: Run, path) -> Path:
    """Write a laser run as a folder with ``scans.npz`` and ``gt.csv``.

    Parameters
    ----------
    run : Run
        Its scans must be numbered 0..n-1 in order and share one geometry.
    path : str or Path
        The folder to write (created).

    Returns
    -------
    path : Path
    """
    path = Path(path)
    numbers = [r.scan for r in run.scans]
    if numbers != list(range(len(numbers))):
        raise ValueError("run.scans must be numbered 0..n-1 in order to be written")
    geometry = run.geometry
    if any(r.geometry != geometry for r in run.scans):
        raise ValueError(f"the scans of run {run.name!r} do not share one geometry")
    ranges = run.scans.ranges()
    path.mkdir(parents=True, exist_ok=True)
    arrays = {
        "ranges": ranges,
        "stamps": np.array([r.stamp for r in run.scans], dtype=np.float64),
        **{k: np.float64(getattr(geometry, k)) for k in _SCALARS},
        "angle_max": np.float64(
            geometry.angle_min + geometry.angle_increment * (ranges.shape[1] - 1)
        ),
        "info_json": np.array(
            json.dumps({"name": run.name, **run.info}, sort_keys=True)
        ),
    }
    _write_npz(path / "scans.npz", arrays)
    write_run_gt(run.gt, path / "gt.csv")
    return path
