"""Laser runs in ROS bags: ``sensor_msgs/LaserScan`` in a ROS 1 ``.bag`` or a ROS 2 bag.

Real laser data is recorded as ROS bags.  They are read and written through
`rosbags <https://gitlab.com/ternaris/rosbags>`_, a pure-Python library that reads
ROS 1 bags and ROS 2 bags (sqlite3 and MCAP storage) without a ROS installation (the
optional ``rosbag`` extra).

A ``LaserScan`` message does not say how high its sensor is mounted: pass
``mount_height``, or write the bag with :func:`write_run_bag`, which adds it on the
topic ``/tunnelsense/mount_height`` (``std_msgs/Float64``).  Nor does it say how fast
the vehicle drives, which turns scan counts into lengths: pass ``speed``, or record a
``nav_msgs/Odometry`` or ``geometry_msgs/TwistStamped`` topic beside the scans (the
speed at each scan is interpolated in time from its messages).  Scans are numbered
from 0 in the order of their messages; their header stamps must not decrease (equal
stamps, from a clock coarser than the scan period, are read as they are) and must
span some time.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tunnelsense._records import LaserGeometry, Run, ScanRecord, empty_run_gt
from tunnelsense.exceptions import InputFormatError

__all__ = ["BagRun", "is_bag", "open_bag_run", "read_bag_run"]

_LASERSCAN = ("sensor_msgs/msg/LaserScan", "sensor_msgs/LaserScan")
_HEIGHT_TOPIC = "/tunnelsense/mount_height"
#: Longest time (s) the speed of the first or last odometry message is held before or
#: after it; a scan further from the odometry is an error, not a guessed speed.
SPEED_HOLD = 1.0
#: Message types that give the ego speed (ROS 2 name, ROS 1 name).
_ODOMETRY = ("nav_msgs/msg/Odometry", "nav_msgs/Odometry")
_TWIST = ("geometry_msgs/msg/TwistStamped", "geometry_msgs/TwistStamped")


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

    def __init__(self, path, topic, geometry, n_scans, name, speed=None):
        self.path, self.topic, self.geometry = path, topic, geometry
        self.n_scans, self.name = n_scans, name
        self.gt = empty_run_gt()
        self.info = {"source": str(path), "topic": topic}
        # speed: None, a constant (m/s), or (topic, stamps, speeds) of an odometry topic
        self._speed = speed
        if isinstance(speed, tuple):
            self.info["speed_topic"] = speed[0]
        elif speed is not None:
            self.info["speed"] = float(speed)

    def speed_at(self, stamp):
        """The ego speed (m/s) at ``stamp`` (s), or None when the bag gives none."""
        if not isinstance(self._speed, tuple):
            return self._speed
        topic, stamps, speeds = self._speed
        if not stamps[0] - SPEED_HOLD <= stamp <= stamps[-1] + SPEED_HOLD:
            raise InputFormatError(
                f"{self.path}: the scan at t={stamp:.3f} s lies outside the messages "
                f"of {topic} (t={stamps[0]:.3f} to {stamps[-1]:.3f} s), which give no "
                "speed there; pass the speed (--speed M/S)"
            )
        return float(np.interp(stamp, stamps, speeds))

    def __len__(self):
        return self.n_scans

    def __iter__(self):
        AnyReader, _, _ = _rosbags()
        g = self.geometry
        last = None
        with AnyReader([self.path]) as reader:
            connections = [c for c in reader.connections if c.topic == self.topic]
            _check_span(self.path, reader, connections)  # before any scan is given
            for k, (conn, _, raw) in enumerate(reader.messages(connections=connections)):
                msg = reader.deserialize(raw, conn.msgtype)
                stamp = _stamp(msg)
                ranges = np.asarray(msg.ranges)
                _check_message(self.path, k, msg, ranges, g, stamp, last)
                last = stamp
                limit = np.float32(g.range_max)
                ranges = np.where(ranges >= limit, np.inf, ranges).astype(np.float64)
                speed = self.speed_at(stamp)
                yield ScanRecord(self.name, k, ranges, float(stamp), g,
                                 {} if speed is None else {"speed": speed})


def _stamp(msg) -> float:
    return msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec


def _check_span(path, reader, connections):
    """Refuse a bag whose scans all have one stamp, reading its messages only until
    a stamp differs from the first (two messages in a bag of any other kind)."""
    first, n = None, 0
    for conn, _, raw in reader.messages(connections=connections):
        stamp = _stamp(reader.deserialize(raw, conn.msgtype))
        n += 1
        if first is None:
            first = stamp
        elif stamp != first:
            return
    if n > 1:
        raise InputFormatError(
            f"{path}: header stamps must span some time; all {n} scans are at "
            f"t={first!r}"
        )


def _check_message(path, k, msg, ranges, g, stamp, last):
    n_beams = round((msg.angle_max - msg.angle_min) / msg.angle_increment) + 1 if (
        msg.angle_increment) else -1
    if len(ranges) != n_beams or not np.isclose(msg.angle_min, g.angle_min) or (
            not np.isclose(msg.angle_increment, g.angle_increment)):
        raise InputFormatError(
            f"{path}: scan {k} has another beam layout ({len(ranges)} ranges from "
            f"{msg.angle_min:.4f} rad by {msg.angle_increment:.5f}) than the first scan"
        )
    if not np.isfinite(stamp):
        raise InputFormatError(f"{path}: header stamps must be finite; scan {k} is at "
                               f"t={stamp!r}")
    if last is not None and stamp < last:
        raise InputFormatError(
            f"{path}: header stamps must not decrease; scan {k} (t={stamp!r}) comes "
            f"before scan {k - 1} (t={last!r})"
        )


def open_bag_run(path, *, topic=None, mount_height=None, speed=None,
                 speed_topic=None) -> BagRun:
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
    speed : float, default=None
        The ego speed (m/s), the same for every scan.  ``None``: interpolated at each
        scan's stamp from the bag's ``nav_msgs/Odometry`` or
        ``geometry_msgs/TwistStamped`` topic (the length of the twist's linear
        velocity; held at most :data:`SPEED_HOLD` = 1 s before its first and after
        its last message, a scan further away is an error), or no speed when the
        bag has no such topic.
    speed_topic : str, default=None
        The odometry or twist topic to read; ``None``: the only one in the bag.

    Returns
    -------
    run : BagRun
        Iterable of :class:`~tunnelsense.ScanRecord`, each with the ego speed in its
        payload (``"speed"``) when the bag or ``speed`` gives one.  Its ``info``
        holds ``"speed"`` (a given speed) or ``"speed_topic"`` (the topic read).

    Raises
    ------
    InputFormatError
        No (or several) ``LaserScan`` topics and no ``topic``; no mount height;
        impossible geometry; a ``speed`` that is not a positive number; several
        odometry topics and no ``speed_topic``, or a ``speed_topic`` that is not
        one; a bag rosbags cannot read.
    """
    AnyReader, _, _ = _rosbags()
    path = Path(path)
    if not is_bag(path):
        raise FileNotFoundError(f"{path}: not a ROS 1 .bag file or ROS 2 bag folder")
    speed = _check_speed(speed)
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
            if speed is None:
                speed = _odometry_speeds(reader, path, speed_topic)
            elif speed_topic is not None:
                raise InputFormatError("give speed or speed_topic, not both")
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
    run = BagRun(path, topic, LaserGeometry(**values), n_scans, name, speed)
    run.speed_at(msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec)  # up front
    return run


def _check_speed(speed):
    if speed is None:
        return None
    try:
        value = float(speed)
    except (TypeError, ValueError):
        value = float("nan")
    if isinstance(speed, bool) or not (np.isfinite(value) and value > 0):
        raise InputFormatError(f"speed must be a positive number (m/s); got {speed!r}")
    return value


def _odometry_speeds(reader, path, speed_topic):
    """``(topic, stamps, speeds)`` of the bag's odometry or twist topic, or None."""
    conns = [c for c in reader.connections if c.msgtype in _ODOMETRY + _TWIST]
    topics = sorted({c.topic for c in conns})
    if speed_topic is None:
        if len(topics) > 1:
            raise InputFormatError(
                f"{path}: {len(topics)} odometry topics ({', '.join(topics)}); name "
                "one (--speed-topic) or give the speed (--speed)"
            )
        if not topics:
            return None
        speed_topic = topics[0]
    elif speed_topic not in topics:
        raise InputFormatError(
            f"{path}: no nav_msgs/Odometry or geometry_msgs/TwistStamped topic "
            f"{speed_topic!r}; it has {', '.join(topics) or 'none'}"
        )
    conns = [c for c in conns if c.topic == speed_topic]
    stamps, speeds = [], []
    for conn, _, raw in reader.messages(connections=conns):
        msg = reader.deserialize(raw, conn.msgtype)
        twist = msg.twist.twist if conn.msgtype in _ODOMETRY else msg.twist
        v = twist.linear
        stamps.append(msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec)
        speeds.append(float(np.sqrt(v.x * v.x + v.y * v.y + v.z * v.z)))
    stamps, speeds = np.asarray(stamps), np.asarray(speeds)
    if not len(stamps) or not (np.all(np.isfinite(stamps))
                               and np.all(np.isfinite(speeds))):
        raise InputFormatError(
            f"{path}: topic {speed_topic} holds no message with a finite stamp and "
            "velocity"
        )
    order = np.argsort(stamps, kind="stable")
    return speed_topic, stamps[order], speeds[order]


def _stored_height(reader, path) -> float:
    conns = [c for c in reader.connections if c.topic == _HEIGHT_TOPIC]
    # an empty ``connections`` means "every topic" to rosbags: ask only when there is one
    for conn, _, raw in reader.messages(connections=conns) if conns else ():
        return float(reader.deserialize(raw, conn.msgtype).data)
    raise InputFormatError(
        f"{path}: the bag does not say how high the laser is mounted; pass "
        "mount_height (command line: --mount-height METRES)"
    )


def read_bag_run(path, *, topic=None, mount_height=None, speed=None,
                 speed_topic=None) -> Run:
    """Read a ROS bag's ``LaserScan`` messages as a :class:`~tunnelsense.Run`."""
    from tunnelsense._records import ScanSequence

    stream = open_bag_run(path, topic=topic, mount_height=mount_height, speed=speed,
                          speed_topic=speed_topic)
    return Run(stream.name, ScanSequence(list(stream)), stream.gt, stream.info)
