"""Laser runs in ROS bags give the same detections as the same scans in scans.npz."""

import numpy as np
import pandas as pd
import pytest

from tunnelsense import LaserGeometry, Run
from tunnelsense._cli import main
from tunnelsense.datasets import make_street_scans
from tunnelsense.exceptions import InputFormatError
from tunnelsense.io import open_run_stream, read_run, write_run, write_run_bag

pytest.importorskip("rosbags")  # the optional 'rosbag' extra

SPEED = 10.0  # m/s: the ego speed of the recorded run (36 km/h, not the 40 assumed)


def _as_recorded(run):
    """The run as a LaserScan driver records it: float32 ranges and geometry, t >= 0,
    and an ego speed (which a bag holds on an odometry topic)."""
    g = run.geometry
    f32 = {k: float(np.float32(getattr(g, k))) for k in
           ("angle_min", "angle_increment", "range_min", "range_max")}
    geometry = LaserGeometry(**f32, mount_height=g.mount_height)
    ranges = run.scans.ranges().astype(np.float32).astype(np.float64)
    stamps = np.array([s.stamp for s in run.scans]) + 1.0
    return Run.from_arrays(run.name, ranges, stamps, geometry, run.gt,
                           info={"speed": SPEED})


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("bags")
    run = _as_recorded(make_street_scans(1200, random_state=4, name="street"))
    npz = write_run(run, root / "npz")
    ros2 = write_run_bag(run, root / "ros2", version="ros2")
    ros1 = write_run_bag(run, root / "street.bag", version="ros1")
    # as a ROS driver records: no stored mount height, no odometry
    bare = write_run_bag(run, root / "bare.bag", version="ros1", odometry_topic=None,
                         store_mount_height=False)
    model = root / "m.skops"
    assert main(["train", "street", str(npz), "--model", str(model)]) == 0
    return {"npz": npz, "ros2": ros2, "ros1": ros1, "bare": bare, "model": model,
            "run": run}


def _detect(runs, name, out, *extra):
    return main(["detect", "street", "--model", str(runs["model"]), str(runs[name]),
                 "--out", str(out), "--quiet", *extra])


@pytest.mark.parametrize("kind", ["ros2", "ros1"])
def test_detect_street_on_a_bag_equals_scans_npz(runs, kind, tmp_path):
    outs = {}
    for name in ("npz", kind):
        outs[name] = tmp_path / f"{name}.csv"
        assert _detect(runs, name, outs[name]) == 0
    rows = outs["npz"].read_text().splitlines()
    assert len(rows) > 5
    assert outs[kind].read_text().splitlines() == rows


@pytest.mark.parametrize("kind", ["ros2", "ros1"])
def test_bag_round_trip_and_streaming(runs, kind):
    run = runs["run"]
    back = read_run(runs[kind])  # the bag says its mount height
    assert back.geometry == run.geometry
    def no_return_as_inf(r):
        return np.where(np.isnan(r) | (r >= np.float32(run.geometry.range_max)), np.inf, r)

    assert np.array_equal(no_return_as_inf(back.scans.ranges()),
                          no_return_as_inf(run.scans.ranges()))
    stamps = [s.stamp for s in open_run_stream(runs[kind])]
    assert np.allclose(stamps, [s.stamp for s in run.scans], atol=1e-9)
    # the ego speed comes back from the odometry topic, on every scan
    assert back.info["speed_topic"] == "/odom"
    assert {s.payload["speed"] for s in back.scans} == {SPEED}
    assert {s.payload["speed"] for s in open_run_stream(runs[kind])} == {SPEED}


def test_a_bag_without_mount_height_asks_for_it(runs, tmp_path, capsys):
    with pytest.raises(InputFormatError, match="--mount-height"):
        read_run(runs["bare"])
    out = tmp_path / "o.csv"
    assert _detect(runs, "bare", out) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--mount-height METRES" in err
    assert "bare.bag" in err and "internal error" not in err
    assert not out.exists()
    # info too asks for it, and takes it
    assert main(["info", str(runs["bare"])]) == 1
    assert "--mount-height METRES" in capsys.readouterr().err
    assert main(["info", str(runs["bare"]), "--mount-height", "1.5"]) == 0
    assert "mount height 1.5 m" in capsys.readouterr().out


def test_a_bag_without_speed_asks_for_it_and_speed_sets_lengths(runs, tmp_path,
                                                                 capsys):
    out = tmp_path / "o.csv"
    assert _detect(runs, "bare", out, "--mount-height", "2.0") == 1
    err = capsys.readouterr().err
    assert "gives no ego speed" in err and "--speed M/S" in err
    assert not out.exists()
    # --speed gives what the odometry topic gave: the same objects as scans.npz
    assert _detect(runs, "bare", out, "--mount-height", "2.0", "--speed",
                   str(SPEED), "--all-objects") == 0
    assert _detect(runs, "npz", tmp_path / "ref.csv", "--all-objects") == 0
    assert out.read_text() == (tmp_path / "ref.csv").read_text()
    # and lengths follow the speed: an object seen over the same scans at twice the
    # speed is twice as long
    assert _detect(runs, "bare", tmp_path / "fast.csv", "--mount-height", "2.0",
                   "--speed", str(2 * SPEED), "--all-objects") == 0
    same = pd.read_csv(out).merge(pd.read_csv(tmp_path / "fast.csv"),
                                  on=["first_scan", "last_scan"])
    assert len(same) >= 5
    assert np.median(same["length_y"] / same["length_x"]) == pytest.approx(2.0,
                                                                            rel=0.05)


def test_speed_arguments_are_checked(runs):
    with pytest.raises(InputFormatError, match="speed must be a positive number"):
        open_run_stream(runs["ros2"], speed=-3.0)
    with pytest.raises(InputFormatError, match="no nav_msgs/Odometry .* '/gps'.*/odom"):
        open_run_stream(runs["ros2"], speed_topic="/gps")
    with pytest.raises(InputFormatError, match="speed_topic applies to a ROS bag"):
        read_run(runs["npz"], speed_topic="/odom")
    # a given speed replaces the odometry's, in bags and run folders alike
    assert {s.payload["speed"] for s in open_run_stream(runs["ros1"], speed=3.0)} == {3.0}
    assert {s.payload["speed"] for s in read_run(runs["npz"], speed=3.0).scans} == {3.0}


def test_bag_errors_are_clear(runs, tmp_path):
    with pytest.raises(InputFormatError, match="no LaserScan topic '/lidar'"):
        open_run_stream(runs["ros2"], topic="/lidar")
    with pytest.raises(InputFormatError, match=r"mount_height is -1.0"):
        open_run_stream(runs["ros1"], mount_height=-1.0)
    broken = tmp_path / "broken.bag"
    broken.write_bytes(runs["ros1"].read_bytes()[:2000])
    with pytest.raises(InputFormatError, match="broken.bag"):
        list(open_run_stream(broken))


def test_a_bag_folder_is_never_written_into(runs, capsys):
    data = sorted(runs["ros2"].iterdir())
    before = {p: p.read_bytes() for p in data}
    for target in data:
        assert main(["detect", "street", "--model", str(runs["model"]),
                     str(runs["ros2"]), "--out", str(target), "--force",
                     "--quiet"]) == 1
        assert "input of this command" in capsys.readouterr().err
    assert {p: p.read_bytes() for p in data} == before


def test_the_user_guide_page_runs_as_shown(tmp_path, monkeypatch, capsys):
    """docs/rosbags.md: every block runs, and prints what the page shows."""
    import contextlib
    import io
    import re
    import shlex
    from pathlib import Path

    page = Path(__file__).parents[2] / "docs" / "rosbags.md"
    if not page.exists():
        pytest.skip("the docs are not in this copy")
    blocks = re.findall(r"```(\w+)\n(.*?)```", page.read_text(), re.S)
    monkeypatch.chdir(tmp_path)
    shown = None
    for lang, code in blocks:
        if lang == "text":
            assert shown is not None, code
            lines = shown.splitlines()
            for expected in code.strip().splitlines():
                assert expected in lines, (expected, shown)
            continue
        if lang == "bash" and code.startswith("pip install"):
            continue
        if lang == "python":
            out = io.StringIO()
            with contextlib.redirect_stdout(out):
                exec(compile(code, str(page), "exec"), {})
            shown = out.getvalue()
        else:
            assert lang == "bash", lang
            for line in code.strip().splitlines():
                words = shlex.split(line)
                assert words[0] == "tunnelsense", line
                status = main(words[1:])
                captured = capsys.readouterr()
                shown = captured.out + captured.err
                assert status == (1 if "error:" in shown else 0), shown
    assert (tmp_path / "objects.csv").exists()


def _bag_with_twists(path, twist_topics, offset=0.0, n_twists=17):
    """A ROS 1 bag of 40 scans at 10 Hz and ``geometry_msgs/TwistStamped`` at 4 Hz
    on each topic, the vehicle speeding up from 5 to 9 m/s (velocity along x and y)."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    T = store.types

    def header(k, t):
        sec, nanosec = divmod(int(round(t * 1e9)), 1_000_000_000)
        return T["std_msgs/msg/Header"](seq=k, stamp=T["builtin_interfaces/msg/Time"](
            sec=sec, nanosec=nanosec), frame_id="x")

    with Writer(path) as writer:
        scans = writer.add_connection("/scan", "sensor_msgs/msg/LaserScan",
                                      typestore=store)
        twists = [writer.add_connection(t, "geometry_msgs/msg/TwistStamped",
                                        typestore=store) for t in twist_topics]
        for k in range(40):
            t = 1.0 + 0.1 * k
            msg = T["sensor_msgs/msg/LaserScan"](
                header=header(k, t), angle_min=-1.0, angle_max=-1.0 + 0.1 * 9,
                angle_increment=0.1, time_increment=0.0, scan_time=0.0,
                range_min=0.1, range_max=8.0, ranges=np.full(10, 3.0, np.float32),
                intensities=np.empty(0, np.float32))
            writer.write(scans, int(t * 1e9), store.serialize_ros1(
                msg, "sensor_msgs/msg/LaserScan"))
        for j, conn in enumerate(twists):
            for k in range(n_twists):
                t = 1.0 + 0.25 * k + offset
                speed = 5.0 + (t - offset - 1.0) + j  # the second topic: 1 m/s faster
                v = T["geometry_msgs/msg/Vector3"]
                msg = T["geometry_msgs/msg/TwistStamped"](
                    header=header(k, t), twist=T["geometry_msgs/msg/Twist"](
                        linear=v(x=0.6 * speed, y=0.8 * speed, z=0.0),
                        angular=v(x=0.0, y=0.0, z=0.0)))
                writer.write(conn, int(t * 1e9), store.serialize_ros1(
                    msg, "geometry_msgs/msg/TwistStamped"))
    return path


def test_the_speed_of_a_twist_topic_is_interpolated_at_each_scan(tmp_path):
    bag = _bag_with_twists(tmp_path / "twist.bag", ["/twist"])
    scans = list(open_run_stream(bag, mount_height=1.8))
    stamps = np.array([s.stamp for s in scans])
    speeds = np.array([s.payload["speed"] for s in scans])
    assert np.allclose(speeds, 5.0 + (stamps - 1.0), atol=1e-9)  # linear in time
    run = read_run(bag, mount_height=1.8)
    assert run.info["speed_topic"] == "/twist"
    assert [s.payload["speed"] for s in run.scans] == list(speeds)

    two = _bag_with_twists(tmp_path / "two.bag", ["/a", "/b"])
    with pytest.raises(InputFormatError, match=r"2 odometry topics \(/a, /b\).*"
                                               r"--speed-topic"):
        open_run_stream(two, mount_height=1.8)
    fast = [s.payload["speed"] for s in open_run_stream(two, mount_height=1.8,
                                                        speed_topic="/b")]
    assert np.allclose(fast, speeds + 1.0)


def test_odometry_that_does_not_cover_the_scans_is_refused(tmp_path):
    # odometry stamped by another clock, 100 s later: no speed is guessed
    late = _bag_with_twists(tmp_path / "late.bag", ["/twist"], offset=100.0)
    with pytest.raises(InputFormatError, match=r"outside the messages of /twist .*"
                                               r"--speed M/S"):
        open_run_stream(late, mount_height=1.8)
    # the scans (1.0 to 4.9 s) overhang odometry from 1.5 s by 0.5 s: held
    early = _bag_with_twists(tmp_path / "early.bag", ["/twist"], offset=0.5)
    speeds = [s.payload["speed"] for s in open_run_stream(early, mount_height=1.8)]
    assert speeds[0] == pytest.approx(5.0) and speeds[-1] == pytest.approx(8.4)
    # ends 1.9 s before the last scans: refused while reading, naming the scan
    short = _bag_with_twists(tmp_path / "short.bag", ["/twist"], n_twists=9)
    with pytest.raises(InputFormatError, match=r"scan at t=4\.\d+ s lies outside"):
        list(open_run_stream(short, mount_height=1.8))


@pytest.mark.parametrize("version", ["ros1", "ros2"])
def test_equal_header_stamps_are_read_and_all_equal_refused(tmp_path, version):
    # 75 scans/s on a 20 ms clock: header stamps step by 0 and 20 ms, read as
    # written, in the order of the messages; a bag whose scans are all at one time
    # is refused, naming it; a bag whose stamps decrease is refused, naming the scan
    run = make_street_scans(40, random_state=4, name="clock")
    stamps = 1.0 + np.floor(np.arange(40) / 75.0 / 0.02) * 0.02
    ranges = run.scans.ranges()

    def bag(name, t):
        coarse = Run.from_arrays("clock", ranges, t, run.geometry, run.gt,
                                 info={"speed": SPEED})
        suffix = ".bag" if version == "ros1" else ""
        return write_run_bag(coarse, tmp_path / f"{name}{suffix}", version=version)

    read = list(open_run_stream(bag("coarse", stamps)))
    assert [s.stamp for s in read] == pytest.approx(stamps.tolist(), abs=1e-9)
    got = np.stack([s.ranges for s in read])  # float32 in the bag, in scan order
    seen = np.isfinite(got)
    assert seen.mean() > 0.5
    assert np.allclose(got[seen], ranges[seen], atol=1e-5)
    same = iter(open_run_stream(bag("same", np.full(40, 2.0))))
    with pytest.raises(InputFormatError, match="same.*header stamps must span some "
                                               r"time; all 40 scans are at t=2.0"):
        next(same)  # before any scan is given: a detector has made nothing of them
