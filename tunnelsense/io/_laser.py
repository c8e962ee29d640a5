"""Laser runs on disk: ``scans.npz`` (ROS LaserScan field names) and ``gt.csv``.

A run folder holds::

    scans.npz   ranges (n_scans, n_beams) m, angle_min, angle_increment, range_min,
                range_max, stamps (n_scans,) s, mount_height m; optional angle_max,
                info_json (a JSON string of run information)
    gt.csv      id,first_scan,last_scan,label   (0-based, inclusive; parked | passing)

No return may be written as NaN, +inf or a range ``>= range_max``: drivers differ, and
all three are accepted.
"""

from __future__ import annotations

import json
import zipfile
import zlib
from pathlib import Path

import numpy as np
import pandas as pd

from tunnelsense._records import (
    RUN_GT_COLUMNS,
    RUN_LABELS,
    LaserGeometry,
    Run,
    empty_run_gt,
)
from tunnelsense.exceptions import InputFormatError
from tunnelsense.io._mot import LineNumbers

__all__ = [
    "RunStream",
    "open_run_stream",
    "read_run",
    "read_run_gt",
    "write_run",
    "write_run_gt",
]

_SCALARS = ("angle_min", "angle_increment", "range_min", "range_max", "mount_height")


def _load_npz(path: Path, *, lazy_ranges=False) -> dict:
    if not path.is_file():
        raise FileNotFoundError(f"{path}: scans file not found")
    try:
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as npz:
            data = {k: npz[k] for k in npz.files if not (lazy_ranges and k == "ranges")}
        if lazy_ranges:
            with zipfile.ZipFile(path) as zf:
                if "ranges.npy" in zf.namelist():
                    with zf.open("ranges.npy") as f:
                        version = np.lib.format.read_magic(f)
                        read_header = (
                            np.lib.format.read_array_header_1_0
                            if version == (1, 0)
                            else np.lib.format.read_array_header_2_0
                        )
                        shape, fortran, dtype = read_header(f)
                        offset = f.tell()
                    if fortran or dtype.hasobject:
                        raise ValueError(
                            "ranges.npy is Fortran-ordered or holds objects"
                        )
                    data["ranges"] = _LazyRanges(path, shape, dtype, offset)
        return data
    except _NPZ_ERRORS as exc:
        raise InputFormatError(f"{path}: corrupt or not an .npz file ({exc})") from None


#: What reading a damaged zip or .npy member raises.
_NPZ_ERRORS = (zipfile.BadZipFile, zlib.error, ValueError, OSError, EOFError, KeyError,
               NotImplementedError, RuntimeError, OverflowError, TypeError)

#: Units of ``ranges`` in a file: ROS says metres; some drivers write integer mm.
RANGE_UNITS = {"m": 1.0, "mm": 0.001}


def read_run(path, *, range_unit="m", topic=None, mount_height=None) -> Run:
    """Read a laser run folder (``scans.npz`` + optional ``gt.csv``) as a :class:`~tunnelsense.Run`.

    Parameters
    ----------
    path : str or Path
        The run folder, or its ``scans.npz`` file; or a ROS 1 ``.bag`` file or ROS 2
        bag folder of ``sensor_msgs/LaserScan`` (the ``rosbag`` extra).
    topic : str, default=None
        A bag's ``LaserScan`` topic (``None``: the only one).
    mount_height : float, default=None
        For a bag: the sensor's height above the road (m), when the bag does not say.
    range_unit : {"m", "mm"}, default="m"
        Unit of ``ranges`` in the file.  ROS ``LaserScan`` ranges are metres
        (floats); some drivers write integer millimetres, which are refused unless
        ``range_unit="mm"`` (then ``ranges`` are divided by 1000; ``range_min`` and
        ``range_max`` stay metres, as ROS defines them).

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
        ``scans.npz`` is corrupt, lacks a field, has ranges of the wrong shape or
        integer ranges read as metres, impossible geometry (``angle_increment`` 0,
        ``range_max <= range_min``, ``mount_height <= 0``), stamps that are not
        numbers or do not increase, or an ``angle_max`` that does not match the
        number of beams; ``gt.csv`` is malformed (the message names the file and
        line).
    """
    from tunnelsense.io._rosbag import is_bag, read_bag_run

    if is_bag(path):
        return read_bag_run(path, topic=topic, mount_height=mount_height)
    name, ranges, stamps, geometry, gt, info = _open_run(path, lazy=False,
                                                         range_unit=range_unit)
    ranges = _to_metres(ranges, geometry.range_max, RANGE_UNITS[range_unit])
    return Run.from_arrays(name, ranges, stamps, geometry, gt, info=info)


def _to_metres(ranges, range_max, scale):
    """Ranges as float64 metres, no-returns of narrower floats kept as such (+inf)."""
    if scale != 1.0:
        return ranges.astype(np.float64) * scale
    if ranges.dtype.kind == "f" and ranges.dtype != np.float64:
        # ROS ranges are float32: float32(8.191) widens to 8.19099998..., below the
        # float64 range_max. Mark no-returns in the file's own precision first.
        limit = np.asarray(range_max, dtype=ranges.dtype)
        ranges = np.where(ranges >= limit, np.inf, ranges)
    return ranges.astype(np.float64, copy=False)


class _LazyRanges:
    """Shape and dtype of ``ranges.npy`` inside an npz, rows read on demand."""

    def __init__(self, npz_path, shape, dtype, offset):
        self.npz_path, self.shape, self.dtype, self.offset = (
            npz_path,
            shape,
            dtype,
            offset,
        )

    def iter_chunks(self, rows):
        """Yield ``(first_scan, block)``; a damaged member raises InputFormatError."""
        n_scans, n_beams = self.shape
        row_bytes = n_beams * self.dtype.itemsize
        start = 0
        try:
            with zipfile.ZipFile(self.npz_path) as zf, zf.open("ranges.npy") as f:
                f.read(self.offset)
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
        except _NPZ_ERRORS as exc:
            if isinstance(exc, InputFormatError):
                raise
            raise InputFormatError(
                f"{self.npz_path}: corrupt ranges.npy after scan {start} ({exc})"
            ) from None


def _open_run(path, *, lazy, range_unit="m"):
    if range_unit not in RANGE_UNITS:
        raise ValueError(
            f"range_unit must be one of {', '.join(RANGE_UNITS)}; got {range_unit!r}"
        )
    path = Path(path)
    if path.is_dir():
        folder, npz_path = path, path / "scans.npz"
    elif path.suffix.lower() == ".npz" and path.is_file():
        folder, npz_path = path.parent, path
    else:
        raise FileNotFoundError(f"{path}: run folder not found")
    data = _load_npz(npz_path, lazy_ranges=lazy)
    missing = [k for k in ("ranges", "stamps", *_SCALARS) if k not in data]
    if missing:
        raise InputFormatError(f"{npz_path}: lacks field(s) {', '.join(missing)}")
    ranges = data["ranges"]
    _check_ranges(npz_path, ranges, range_unit)
    stamps = _check_stamps(npz_path, data["stamps"], ranges.shape[0])
    scalars = _check_geometry(npz_path, data, ranges.shape[1])
    info = _read_info(npz_path, data)
    name = str(info.pop("name", folder.resolve().name))
    gt_path = folder / "gt.csv"
    gt = read_run_gt(gt_path) if gt_path.exists() else empty_run_gt()
    beyond = np.flatnonzero(gt["last_scan"].to_numpy() >= ranges.shape[0])
    if beyond.size:
        i = beyond[0]
        raise InputFormatError(
            f"{gt_path}, line {gt.attrs['lines'][i]}: last_scan {gt['last_scan'].iloc[i]} "
            f"is beyond the run's {ranges.shape[0]} scans (numbered from 0)"
        )
    geometry = LaserGeometry(**scalars)
    return name, ranges, stamps, geometry, gt, info


def _check_ranges(npz_path, ranges, range_unit) -> None:
    if len(ranges.shape) != 2 or ranges.dtype.kind not in "fiu":
        raise InputFormatError(
            f"{npz_path}: ranges must be a numeric array of shape (n_scans, n_beams); "
            f"got {ranges.dtype} of shape {ranges.shape}"
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
    stamps = stamps.astype(np.float64)
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


#: Physically possible values of the geometry fields: (test, what is expected).
_GEOMETRY_RULES = {
    "angle_increment": (lambda v: v != 0, "a non-zero angle (rad)"),
    "range_min": (lambda v: v >= 0, "a range >= 0 (m)"),
    "range_max": (lambda v: v > 0, "a range > 0 (m)"),
    "mount_height": (lambda v: v > 0, "a height > 0 (m) above the road"),
}


def _check_geometry(npz_path, data, n_beams) -> dict:
    scalars = {}
    for k in _SCALARS:
        value = data[k]
        if (
            value.size != 1
            or value.dtype.kind not in "fiu"
            or not np.isfinite(value.astype(np.float64)).all()
        ):
            raise InputFormatError(
                f"{npz_path}: {k} must be one finite number; got {value!r}"
            )
        scalars[k] = float(value.reshape(()))
        test, expected = _GEOMETRY_RULES.get(k, (None, None))
        if test is not None and not test(scalars[k]):
            raise InputFormatError(
                f"{npz_path}: {k} is {scalars[k]!r}, expected {expected}"
            )
    if scalars["range_min"] >= scalars["range_max"]:
        raise InputFormatError(
            f"{npz_path}: range_min ({scalars['range_min']!r}) must be below range_max "
            f"({scalars['range_max']!r})"
        )
    if "angle_max" in data:
        value = np.asarray(data["angle_max"])
        if value.size != 1 or value.dtype.kind not in "fiu":
            raise InputFormatError(
                f"{npz_path}: angle_max must be one number; got {value!r}"
            )
        angle_max = float(value.reshape(()))
        expected = scalars["angle_min"] + scalars["angle_increment"] * (n_beams - 1)
        if not np.isclose(
            angle_max, expected, atol=abs(scalars["angle_increment"]) / 4
        ):
            n_expected = (angle_max - scalars["angle_min"]) / scalars[
                "angle_increment"
            ] + 1
            raise InputFormatError(
                f"{npz_path}: angle_min, angle_max and angle_increment describe "
                f"{n_expected:.0f} beams, but ranges has {n_beams}"
            )
    return scalars


def _read_info(npz_path, data) -> dict:
    if "info_json" not in data:
        return {}
    value = data["info_json"]
    if value.dtype.kind not in "US" or value.size != 1:
        raise InputFormatError(
            f"{npz_path}: info_json must be one JSON string; got {value.dtype}"
        )
    try:
        info = json.loads(str(value.reshape(())))
    except (json.JSONDecodeError, RecursionError) as exc:
        raise InputFormatError(
            f"{npz_path}: info_json is not valid JSON ({exc})"
        ) from None
    if not isinstance(info, dict):
        raise InputFormatError(
            f"{npz_path}: info_json must hold a JSON object; got {type(info).__name__}"
        )
    return info


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
        for start, block in self._ranges.iter_chunks(self._chunk):
            block = _to_metres(block, g.range_max, self._scale)
            for i in range(len(block)):
                s = start + i
                yield ScanRecord(self.name, s, block[i], float(self._stamps[s]), g)


def open_run_stream(path, *, chunk_scans=1024, range_unit="m", topic=None,
                    mount_height=None) -> RunStream:
    """Open a laser run for reading scan by scan (bounded memory).

    The same checks as :func:`read_run` are made up front, from the file's headers;
    the ranges are decompressed ``chunk_scans`` scans at a time while iterating.

    Parameters
    ----------
    path : str or Path
        The run folder, or its ``scans.npz`` file.
    chunk_scans : int, default=1024
        Scans decompressed at a time.
    range_unit : {"m", "mm"}, default="m"
        Unit of ``ranges`` in the file (see :func:`read_run`).
    topic, mount_height : see :func:`read_run`
        For a ROS bag (then the scans are read message by message).

    Returns
    -------
    stream : RunStream
        Iterable of :class:`~tunnelsense.ScanRecord`, with ``name``, ``geometry``,
        ``gt``, ``info`` and ``n_scans``.

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
    from tunnelsense.io._rosbag import is_bag, open_bag_run

    if is_bag(path):
        return open_bag_run(path, topic=topic, mount_height=mount_height)
    name, ranges, stamps, geometry, gt, info = _open_run(path, lazy=True,
                                                         range_unit=range_unit)
    return RunStream(name, ranges, stamps, geometry, gt, info, int(chunk_scans),
                     RANGE_UNITS[range_unit])


def read_run_gt(path) -> pd.DataFrame:
    """Read a laser run's ``gt.csv`` (``id,first_scan,last_scan,label``).

    Parameters
    ----------
    path : str or Path
        The ground-truth file.

    Returns
    -------
    gt : DataFrame
        ``id``, ``first_scan``, ``last_scan`` as int64 and ``label`` as strings.

    Raises
    ------
    InputFormatError
        A missing column, a non-integer scan number, ``first_scan > last_scan`` or a
        label other than ``parked`` / ``passing`` (names the file and line).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: ground-truth file not found")
    try:
        gt = pd.read_csv(
            path,
            dtype=str,
            keep_default_na=False,
            skip_blank_lines=False,
            encoding="utf-8-sig",
        )
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise InputFormatError(f"{path}: not a readable CSV file ({exc})") from None
    gt.columns = [c.strip() for c in gt.columns]
    # file line of each row (header is line 1); then drop blank lines
    lines = np.arange(2, len(gt) + 2)
    blank = (gt.apply(lambda col: col.str.strip()) == "").all(axis=1).to_numpy()
    gt, lines = gt[~blank].reset_index(drop=True), lines[~blank]
    missing = [c for c in RUN_GT_COLUMNS if c not in gt.columns]
    if missing:
        raise InputFormatError(
            f"{path}: lacks column(s) {', '.join(missing)} (expected header "
            f"{','.join(RUN_GT_COLUMNS)})"
        )
    out = {}
    for c in ("id", "first_scan", "last_scan"):
        values = []
        for i, v in zip(lines, gt[c], strict=True):
            try:
                number = int(v.strip())
            except ValueError:
                number = None
            if number is None or not -(2**62) < number < 2**62:
                raise InputFormatError(
                    f"{path}, line {i}: {c} is {v!r}, expected an integer"
                    + ("" if number is None else " of at most 18 digits")
                )
            values.append(number)
        out[c] = np.array(values, dtype=np.int64)
    labels = [v.strip() for v in gt["label"]]
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
    table.attrs["lines"] = LineNumbers(int(i) for i in lines)
    return table


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
