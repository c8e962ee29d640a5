"""Laser runs in ROS bags: ``sensor_msgs/LaserScan`` in a ROS 1 ``.bag`` or a ROS 2 bag.

Real laser data is recorded as ROS bags.  They are read and written through
`rosbags <https://gitlab.com/ternaris/rosbags>`_, a pure-Python library that reads
ROS 1 bags and ROS 2 bags (sqlite3 and MCAP storage) without a ROS installation (the
optional ``rosbag`` extra).

A ``LaserScan`` message does not say how high its sensor is mounted: pass
``mount_height``, or write the bag with :func:`write_run_bag`, which adds it on the
topic ``/tunnelsense/mount_height`` (``std_msgs/Float64``).  Scans are numbered from 0
in the order of their header stamps, which must increase strictly.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tunnelsense._records import LaserGeometry, Run, ScanRecord, empty_run_gt
from tunnelsense.exceptions import InputFormatError

__all__ = ["is_bag", "open_bag_run", "write_run_bag"]

_LASERSCAN = ("sensor_msgs/msg/LaserScan", "sensor_msgs/LaserScan")
_HEIGHT_TOPIC = "/tunnelsense/mount_height"


def is_bag(path) -> bool:
    """Whether ``path`` is a ROS 1 ``.bag`` file or a ROS 2 bag folder."""
    path = Path(path)
    if path.is_file():
        return path.suffix.lower() == ".bag"
    return path.is_dir() and (path / "metadata.yaml").is_file()


def _rosbags():
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise ImportError(
            "reading ROS bags needs the rosbags library: pip install "
            "'tunnelsense[rosbag]'"
        ) from None
    return AnyReader, Stores, get_typestore


class BagRun:
    """A laser run in a ROS bag, read scan by scan (bounded memory).

    Made by :func:`open_bag_run`; iterate over it for the
    :class:`~tunnelsense.ScanRecord` objects, in order.  It has the attributes of
    :class:`~tunnelsense.io.RunStream` (``name``, ``geometry``, ``gt``, ``info``,
    ``n_scans``).
    """

    def __init__(self, path, topic, geometry, n_scans, name):
        self.path, self.topic, self.geometry = path, topic, geometry
        self.n_scans, self.name = n_scans, name
        self.gt = empty_run_gt()
        self.info = {"source": str(path), "topic": topic}

    def __len__(self):
        return self.n_scans

    def __iter__(self):
        AnyReader, _, _ = _rosbags()
        g = self.geometry
        last = None
        with AnyReader([self.path]) as reader:
            connections = [c for c in reader.connections if c.topic == self.topic]
            for k, (conn, _, raw) in enumerate(reader.messages(connections=connections)):
                msg = reader.deserialize(raw, conn.msgtype)
                stamp = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
                ranges = np.asarray(msg.ranges)
                _check_message(self.path, k, msg, ranges, g, stamp, last)
                last = stamp
                limit = np.float32(g.range_max)
                ranges = np.where(ranges >= limit, np.inf, ranges).astype(np.float64)
                yield ScanRecord(self.name, k, ranges, float(stamp), g)


def _check_message(path, k, msg, ranges, g, stamp, last):
    n_beams = round((msg.angle_max - msg.angle_min) / msg.angle_increment) + 1 if (
        msg.angle_increment) else -1
    if len(ranges) != n_beams or not np.isclose(msg.angle_min, g.angle_min) or (
            not np.isclose(msg.angle_increment, g.angle_increment)):
        raise InputFormatError(
            f"{path}: scan {k} has another beam layout ({len(ranges)} ranges from "
            f"{msg.angle_min:.4f} rad by {msg.angle_increment:.5f}) than the first scan"
        )
    if not np.isfinite(stamp) or (last is not None and stamp <= last):
        raise InputFormatError(
            f"{path}: header stamps must increase strictly; scan {k} (t={stamp!r}) "
            f"does not come after scan {k - 1} (t={last!r})"
        )


def open_bag_run(path, *, topic=None, mount_height=None) -> BagRun:
    """Open the ``LaserScan`` messages of a ROS bag as a laser run.

    Parameters
    ----------
    path : str or Path
        A ROS 1 ``.bag`` file or a ROS 2 bag folder (``metadata.yaml``).
    topic : str, default=None
        The ``LaserScan`` topic; ``None``: the only one in the bag.
    mount_height : float, default=None
        Height of the sensor above the road (m); ``None``: from the bag's
        ``/tunnelsense/mount_height`` topic.

    Returns
    -------
    run : BagRun
        Iterable of :class:`~tunnelsense.ScanRecord`.

    Raises
    ------
    InputFormatError
        No (or several) ``LaserScan`` topics and no ``topic``; no mount height;
        impossible geometry; a bag rosbags cannot read.
    """
    AnyReader, _, _ = _rosbags()
    path = Path(path)
    if not is_bag(path):
        raise FileNotFoundError(f"{path}: not a ROS 1 .bag file or ROS 2 bag folder")
    try:
        with AnyReader([path]) as reader:
            scans = [c for c in reader.connections if c.msgtype in _LASERSCAN]
            topics = sorted({c.topic for c in scans})
            if topic is None:
                if len(topics) != 1:
                    raise InputFormatError(
                        f"{path}: {len(topics)} LaserScan topics ({', '.join(topics)}); "
                        "name one (--topic)"
                    )
                topic = topics[0]
            elif topic not in topics:
                raise InputFormatError(
                    f"{path}: no LaserScan topic {topic!r}; it has "
                    f"{', '.join(topics) or 'none'}"
                )
            conns = [c for c in scans if c.topic == topic]
            n_scans = sum(c.msgcount for c in conns)
            first = next(iter(reader.messages(connections=conns)), None)
            if first is None:
                raise InputFormatError(f"{path}: topic {topic} holds no scan")
            msg = reader.deserialize(first[2], first[0].msgtype)
            if mount_height is None:
                mount_height = _stored_height(reader, path)
    except InputFormatError:
        raise
    except Exception as exc:  # rosbags raises its own errors on damaged bags
        raise InputFormatError(f"{path}: cannot read the bag ({exc})") from None
    from tunnelsense._records import geometry_problem

    values = {"angle_min": float(msg.angle_min),
              "angle_increment": float(msg.angle_increment),
              "range_min": float(msg.range_min), "range_max": float(msg.range_max),
              "mount_height": float(mount_height)}
    problem = geometry_problem(values)
    if problem is not None:
        raise InputFormatError(f"{path}: {problem}")
    name = path.stem if path.is_file() else path.name
    return BagRun(path, topic, LaserGeometry(**values), n_scans, name)


def _stored_height(reader, path) -> float:
    conns = [c for c in reader.connections if c.topic == _HEIGHT_TOPIC]
    for conn, _, raw in reader.messages(connections=conns):
        return float(reader.deserialize(raw, conn.msgtype).data)
    raise InputFormatError(
        f"{path}: the bag does not say how high the laser is mounted; pass "
        "mount_height (command line: --mount-height METRES)"
    )


def read_bag_run(path, *, topic=None, mount_height=None) -> Run:
    """Read a ROS bag's ``LaserScan`` messages as a :class:`~tunnelsense.Run`."""
    stream = open_bag_run(path, topic=topic, mount_height=mount_height)
    scans = list(stream)
    ranges = np.array([s.ranges for s in scans]).reshape(len(scans), -1)
    stamps = np.array([s.stamp for s in scans])
    return Run.from_arrays(stream.name, ranges, stamps, stream.geometry,
                           info=stream.info)


def write_run_bag(run: Run, path, *, version="ros2", topic="/scan") -> Path:
    """Write a laser run as a ROS bag of ``sensor_msgs/LaserScan`` (ranges float32).

    Parameters
    ----------
    run : Run
        One geometry for all scans.
    path : str or Path
        A new ROS 2 bag folder (``version="ros2"``, sqlite3 storage) or ROS 1 ``.bag``
        file (``version="ros1"``); an existing one is refused.
    version : {"ros2", "ros1"}, default="ros2"
    topic : str, default="/scan"

    Notes
    -----
    ROS times cannot be negative: a run whose stamps start before 0 is shifted by
    whole seconds (the differences between stamps stay as they were).

    Returns
    -------
    path : Path
    """
    _, Stores, get_typestore = _rosbags()
    from tunnelsense.exceptions import OutputExistsError

    path = Path(path)
    if path.exists():
        raise OutputExistsError(f"{path}: exists; refusing to overwrite it")
    if version == "ros2":
        from rosbags.rosbag2 import Writer

        store = get_typestore(Stores.ROS2_HUMBLE)
        writer = Writer(path, version=8)
    elif version == "ros1":
        from rosbags.rosbag1 import Writer

        store = get_typestore(Stores.ROS1_NOETIC)
        writer = Writer(path)
    else:
        raise ValueError(f"version must be 'ros2' or 'ros1'; got {version!r}")
    T = store.types
    scan_type = "sensor_msgs/msg/LaserScan"
    g = run.geometry
    ranges = run.scans.ranges().astype(np.float32)
    ranges[~np.isfinite(ranges)] = np.float32(g.range_max)
    n_beams = ranges.shape[1]
    stamps = np.array([r.stamp for r in run.scans], dtype=np.float64)
    # ROS times are not negative: shift a run that starts before 0 by whole seconds
    offset = float(np.ceil(-stamps.min())) if len(stamps) and stamps.min() < 0 else 0.0
    with writer:
        conn = writer.add_connection(topic, scan_type, typestore=store)
        height = writer.add_connection(_HEIGHT_TOPIC, "std_msgs/msg/Float64",
                                       typestore=store)
        first = int(round((stamps[0] + offset) * 1e9)) if len(stamps) else 0
        writer.write(height, first,
                     store.serialize_ros1(T["std_msgs/msg/Float64"](g.mount_height),
                                          "std_msgs/msg/Float64")
                     if version == "ros1" else
                     store.serialize_cdr(T["std_msgs/msg/Float64"](g.mount_height),
                                         "std_msgs/msg/Float64"))
        for k in range(len(stamps)):
            ns = int(round((stamps[k] + offset) * 1e9))
            sec, nanosec = divmod(ns, 1_000_000_000)
            header = (T["std_msgs/msg/Header"](seq=k, stamp=T["builtin_interfaces/msg/Time"](
                sec=sec, nanosec=nanosec), frame_id="laser") if version == "ros1" else
                T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](
                    sec=sec, nanosec=nanosec), frame_id="laser"))
            msg = T[scan_type](
                header=header, angle_min=g.angle_min,
                angle_max=g.angle_min + g.angle_increment * (n_beams - 1),
                angle_increment=g.angle_increment, time_increment=0.0, scan_time=0.0,
                range_min=g.range_min, range_max=g.range_max, ranges=ranges[k],
                intensities=np.empty(0, np.float32),
            )
            data = (store.serialize_ros1(msg, scan_type) if version == "ros1"
                    else store.serialize_cdr(msg, scan_type))
            writer.write(conn, ns, data)
    return path
