"""Writing laser runs as ROS bags: the scans, the mount height and the ego speed."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tunnelsense._records import Run
from tunnelsense.io._rosbag import _HEIGHT_TOPIC, _ODOMETRY, _rosbags

__all__ = ["write_run_bag"]


def write_run_bag(run: Run, path, *, version="ros2", topic="/scan",
                  odometry_topic="/odom", store_mount_height=True) -> Path:
    """Write a laser run as a ROS bag of ``sensor_msgs/LaserScan`` (ranges float32).

    The bag reads back with :func:`read_run` and :func:`open_run_stream` (and the
    command line) as the same scans, mount height and ego speed.

    Parameters
    ----------
    run : Run
        One geometry for all scans.
    path : str or Path
        A new ROS 2 bag folder (``version="ros2"``, sqlite3 storage) or ROS 1 ``.bag``
        file (``version="ros1"``); an existing one is refused.
    version : {"ros2", "ros1"}, default="ros2"
    topic : str, default="/scan"
        The ``LaserScan`` topic.
    odometry_topic : str or None, default="/odom"
        Where to write the ego speed, one ``nav_msgs/Odometry`` message per scan
        (``twist.twist.linear.x``, m/s), when the run has one: the scans' payload
        ``"speed"``, else the speed of its ``info`` (see
        :func:`~tunnelsense.io.ego_speed`).  ``None``: no odometry.
    store_mount_height : bool, default=True
        Write the sensor's mount height on ``/tunnelsense/mount_height``
        (``std_msgs/Float64``); a bag without it needs ``mount_height`` to be read,
        as a bag from a ROS driver does.

    Returns
    -------
    path : Path

    Raises
    ------
    OutputExistsError
        ``path`` exists.
    ImportError
        The ``rosbag`` extra (rosbags) is not installed.

    Notes
    -----
    ROS times cannot be negative: a run whose stamps start before 0 is shifted by
    whole seconds (the differences between stamps stay as they were).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from tunnelsense.datasets import make_street_scans
    >>> from tunnelsense.io import read_run, write_run_bag
    >>> run = make_street_scans(300, random_state=0)
    >>> bag = write_run_bag(run, pathlib.Path(tempfile.mkdtemp()) / "run")
    >>> back = read_run(bag)
    >>> len(back.scans), back.geometry.mount_height == run.geometry.mount_height
    (300, True)
    >>> back.info["speed_topic"]
    '/odom'
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
    # REP 117: NaN is a failed measurement (a dropout), +inf no return within range;
    # both are kept as they are (the detector tells a dropout from a beam that passed)
    ranges = run.scans.ranges().astype(np.float32)
    n_beams = ranges.shape[1]
    stamps = np.array([r.stamp for r in run.scans], dtype=np.float64)
    # ROS times are not negative: shift a run that starts before 0 by whole seconds
    offset = float(np.ceil(-stamps.min())) if len(stamps) and stamps.min() < 0 else 0.0
    speeds = _run_speeds(run) if odometry_topic is not None else None

    def serialize(msg, msgtype):
        return (store.serialize_ros1(msg, msgtype) if version == "ros1"
                else store.serialize_cdr(msg, msgtype))

    def header(k, sec, nanosec, frame_id):
        stamp = T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)
        return (T["std_msgs/msg/Header"](seq=k, stamp=stamp, frame_id=frame_id)
                if version == "ros1" else
                T["std_msgs/msg/Header"](stamp=stamp, frame_id=frame_id))

    with writer:
        conn = writer.add_connection(topic, scan_type, typestore=store)
        first = int(round((stamps[0] + offset) * 1e9)) if len(stamps) else 0
        if store_mount_height:
            height = writer.add_connection(_HEIGHT_TOPIC, "std_msgs/msg/Float64",
                                           typestore=store)
            writer.write(height, first, serialize(
                T["std_msgs/msg/Float64"](g.mount_height), "std_msgs/msg/Float64"))
        if speeds is not None:
            odom = writer.add_connection(odometry_topic, _ODOMETRY[0], typestore=store)
        for k in range(len(stamps)):
            ns = int(round((stamps[k] + offset) * 1e9))
            sec, nanosec = divmod(ns, 1_000_000_000)
            if speeds is not None:
                writer.write(odom, ns, serialize(
                    _odometry_message(T, header(k, sec, nanosec, "odom"), speeds[k]),
                    _ODOMETRY[0]))
            header_k = header(k, sec, nanosec, "laser")
            msg = T[scan_type](
                header=header_k, angle_min=g.angle_min,
                angle_max=g.angle_min + g.angle_increment * (n_beams - 1),
                angle_increment=g.angle_increment, time_increment=0.0, scan_time=0.0,
                range_min=g.range_min, range_max=g.range_max, ranges=ranges[k],
                intensities=np.empty(0, np.float32),
            )
            writer.write(conn, ns, serialize(msg, scan_type))
    return path


def _run_speeds(run):
    """The ego speed (m/s) at each scan of ``run``, or None when it has none."""
    from tunnelsense.io._laser import ego_speed

    speeds = np.array([float(r.payload.get("speed", np.nan)) for r in run.scans])
    fallback = ego_speed(run.info)
    if fallback is not None:
        speeds = np.where(np.isfinite(speeds), speeds, fallback)
    return speeds if len(speeds) and np.all(np.isfinite(speeds)) else None


def _odometry_message(T, header, speed):
    """A ``nav_msgs/Odometry`` message driving forward at ``speed`` (m/s)."""
    vector, zeros = T["geometry_msgs/msg/Vector3"], np.zeros(36)
    pose = T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
        orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0))
    twist = T["geometry_msgs/msg/Twist"](linear=vector(x=float(speed), y=0.0, z=0.0),
                                         angular=vector(x=0.0, y=0.0, z=0.0))
    return T[_ODOMETRY[0]](
        header=header, child_frame_id="base_link",
        pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=zeros),
        twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=zeros))
