"""Laser runs in ROS bags give the same detections as the same scans in scans.npz."""

import numpy as np
import pytest

from tunnelsense import LaserGeometry, Run
from tunnelsense._cli import main
from tunnelsense.datasets import make_street_scans
from tunnelsense.exceptions import InputFormatError
from tunnelsense.io import open_run_stream, read_run, write_run

rosbag = pytest.importorskip("tunnelsense.io._rosbag")
pytest.importorskip("rosbags")  # the optional 'rosbag' extra


def _as_recorded(run):
    """The run as a LaserScan driver records it: float32 ranges and geometry, t >= 0,
    and nothing else (a bag holds no ego speed)."""
    g = run.geometry
    f32 = {k: float(np.float32(getattr(g, k))) for k in
           ("angle_min", "angle_increment", "range_min", "range_max")}
    geometry = LaserGeometry(**f32, mount_height=g.mount_height)
    ranges = run.scans.ranges().astype(np.float32).astype(np.float64)
    stamps = np.array([s.stamp for s in run.scans]) + 1.0
    return Run.from_arrays(run.name, ranges, stamps, geometry, run.gt)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("bags")
    run = _as_recorded(make_street_scans(1200, random_state=4, name="street"))
    npz = write_run(run, root / "npz")
    ros2 = rosbag.write_run_bag(run, root / "ros2", version="ros2")
    ros1 = rosbag.write_run_bag(run, root / "street.bag", version="ros1")
    model = root / "m.skops"
    assert main(["train", "street", str(npz), "--model", str(model)]) == 0
    return {"npz": npz, "ros2": ros2, "ros1": ros1, "model": model, "run": run}


@pytest.mark.parametrize("kind", ["ros2", "ros1"])
def test_detect_street_on_a_bag_equals_scans_npz(runs, kind, tmp_path):
    outs = {}
    for name in ("npz", kind):
        outs[name] = tmp_path / f"{name}.csv"
        extra = ["--mount-height", "2.0"] if name != "npz" else []
        assert main(["detect", "street", "--model", str(runs["model"]),
                     str(runs[name]), "--out", str(outs[name]), "--quiet",
                     *extra]) == 0
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
