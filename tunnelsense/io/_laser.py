"""Laser runs on disk: ``scans.npz`` (ROS LaserScan field names) and ``gt.csv``.

A run folder holds::

    scans.npz   ranges (n_scans, n_beams) m, angle_min, angle_increment, range_min,
                range_max, stamps (n_scans,) s, mount_height m; optional angle_max,
                info_json (a JSON string of run information)
    gt.csv      id,first_scan,last_scan,label   (0-based, inclusive; parked | passing)

No return may be written as NaN, +inf or a range ``>= range_max``: drivers differ, and
all three are accepted.  Ranges are float metres; integer millimetres are read with
``range_unit="mm"``.  A run holds at least one scan of at least one beam, its stamps
never decrease (equal stamps, from a clock coarser than the scan period, are read as
they are) and span some time, and the members of ``scans.npz`` are ``.npy`` arrays without
Python objects (NumPy's ``np.savez`` writes such files).
"""

from __future__ import annotations

import json
import math
import numbers
from pathlib import Path

import numpy as np
import pandas as pd

from tunnelsense._records import (
    Run,
    ScanSequence,
    empty_run_gt,
)
from tunnelsense.exceptions import InputFormatError
from tunnelsense.io._laser_fields import (
    SCALARS,
    check_fields,
    check_geometry,
    check_ranges,
    check_stamps,
    read_info,
    to_metres,
)
from tunnelsense.io._laser_gt import read_objects, read_run_gt, write_run_gt
from tunnelsense.io._npz import load_npz, write_npz

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

#: Units of ``ranges`` in a file: ROS says metres; some drivers write integer mm.
RANGE_UNITS = {"m": 1.0, "mm": 0.001}


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


def read_run(path, *, range_unit="m", topic=None, mount_height=None, speed=None,
             speed_topic=None) -> Run:
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
    speed : float, default=None
        The ego speed (m/s) of every scan, in place of the run's own: the speed of
        ``info_json`` (see :func:`ego_speed`), or a bag's odometry topic.
    speed_topic : str, default=None
        A bag's ``nav_msgs/Odometry`` or ``geometry_msgs/TwistStamped`` topic
        (``None``: the only one, if any), whose messages give the speed at each
        scan (interpolated in time).

    Returns
    -------
    run : Run
        Scans numbered from 0, ground truth (empty when there is no ``gt.csv``), and
        the run information stored in ``info_json``.  Each scan carries the ego
        speed in its payload (``"speed"``) when the run gives one.

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
        finite number), stamps that are not finite numbers, decrease, or are all
        equal (two scans or more), an
        ``angle_max`` that does not match the number of beams, or an ``info_json``
        that is not a UTF-8 JSON object; ``gt.csv`` is malformed.  The message
        names the file, and the field, member or line.
    """
    from tunnelsense.io._rosbag import is_bag

    scale = _check_range_unit(range_unit)
    if is_bag(path):
        from tunnelsense.io._rosbag import read_bag_run

        _refuse_unit_for_bag(path, range_unit)
        return read_bag_run(path, topic=topic, mount_height=mount_height, speed=speed,
                            speed_topic=speed_topic)
    name, ranges, stamps, geometry, gt, info = _open_run(
        path, lazy=False, range_unit=range_unit, speed=speed, speed_topic=speed_topic)
    ranges = to_metres(ranges, geometry.range_max, scale)
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


def _open_run(path, *, lazy, range_unit="m", speed=None, speed_topic=None,
              ground_truth=True):
    _check_range_unit(range_unit)
    if speed_topic is not None:
        raise InputFormatError(f"{path}: speed_topic applies to a ROS bag; a run "
                               "folder gives its speed in info_json (or pass speed)")
    if speed is not None:
        from tunnelsense.io._rosbag import _check_speed

        speed = _check_speed(speed)
    path = Path(path)
    if path.is_dir():
        folder, npz_path = path, path / "scans.npz"
    elif path.suffix.lower() == ".npz" and path.is_file():
        folder, npz_path = path.parent, path
    else:
        raise FileNotFoundError(f"{path}: run folder not found")
    data, others = load_npz(npz_path, lazy_ranges=lazy)
    check_fields(npz_path, data, others)
    ranges = data["ranges"]
    check_ranges(npz_path, ranges, range_unit)
    stamps = check_stamps(npz_path, data["stamps"], ranges.shape[0])
    geometry = check_geometry(npz_path, data, ranges.shape[1])
    info = read_info(npz_path, data)
    if speed is not None:
        info["speed"] = speed  # ego_speed reads "speed" first
    name = str(info.pop("name", folder.resolve().name))
    gt = _read_gt_of(folder, n_scans=ranges.shape[0]) if ground_truth else None
    return name, ranges, stamps, geometry, gt, info


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


class RunStream:
    """A laser run read scan by scan, with memory independent of its length.

    Made by :func:`open_run_stream`; iterate over it for the
    :class:`~tunnelsense.ScanRecord` objects, in order.

    Attributes
    ----------
    name : str
    geometry : LaserGeometry
    gt : DataFrame or None
        None when opened with ``ground_truth=False``.
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
            block = to_metres(block, g.range_max, self._scale)
            for i in range(len(block)):
                s = start + i
                yield ScanRecord(self.name, s, block[i], float(self._stamps[s]), g,
                                 {} if speed is None else {"speed": speed})


def open_run_stream(path, *, chunk_scans=1024, range_unit="m", topic=None,
                    mount_height=None, speed=None, speed_topic=None,
                    ground_truth=True) -> RunStream:
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
    topic, mount_height, speed_topic : see :func:`read_run`
        For a ROS bag (then the scans are read message by message).
    speed : float, default=None
        The ego speed (m/s) of every scan (see :func:`read_run`).
    ground_truth : bool, default=True
        Read and check the run's ``gt.csv``.  False (detection, which never uses
        it): ``gt`` is None, and the file is not read.

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
        return open_bag_run(path, topic=topic, mount_height=mount_height, speed=speed,
                            speed_topic=speed_topic)
    name, ranges, stamps, geometry, gt, info = _open_run(
        path, lazy=True, range_unit=range_unit, speed=speed, speed_topic=speed_topic,
        ground_truth=ground_truth)
    return RunStream(name, ranges, stamps, geometry, gt, info, int(chunk_scans),
                     scale)


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
        **{k: np.float64(getattr(geometry, k)) for k in SCALARS},
        "angle_max": np.float64(
            geometry.angle_min + geometry.angle_increment * (ranges.shape[1] - 1)
        ),
        "info_json": np.array(
            json.dumps({"name": run.name, **run.info}, sort_keys=True)
        ),
    }
    write_npz(path / "scans.npz", arrays)
    write_run_gt(run.gt, path / "gt.csv")
    return path
