import json
import zipfile

import numpy as np
import pandas as pd
import pytest

from tunnelsense import LaserGeometry, Run
from tunnelsense.io import read_run, read_run_gt, write_run


@pytest.fixture
def run(global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    ranges = rng.uniform(0.5, 9.0, (12, 40))
    ranges[0, 3] = np.nan
    ranges[1, 4] = np.inf
    ranges[2, 5] = 8.191
    g = LaserGeometry(np.radians(-80), np.radians(0.5), 0.05, 8.191, 2.1)
    gt = pd.DataFrame(
        {
            "id": [1, 2],
            "first_scan": [0, 4],
            "last_scan": [3, 11],
            "label": ["parked", "passing"],
        }
    )
    return Run.from_arrays(
        "run-x",
        ranges,
        np.arange(12) / 75.0,
        g,
        gt,
        info={"scenario": "sparse", "seed": 3},
    )


def test_round_trip_is_identical(run, tmp_path):
    write_run(run, tmp_path / "r")
    back = read_run(tmp_path / "r")
    assert back.name == "run-x" and back.info == {"scenario": "sparse", "seed": 3}
    assert back.geometry == run.geometry
    assert np.array_equal(back.scans.ranges(), run.scans.ranges(), equal_nan=True)
    assert [r.stamp for r in back.scans] == [r.stamp for r in run.scans]
    pd.testing.assert_frame_equal(back.gt, run.gt)
    write_run(back, tmp_path / "again")
    for name in ("scans.npz", "gt.csv"):
        assert (tmp_path / "again" / name).read_bytes() == (
            tmp_path / "r" / name
        ).read_bytes()
    assert len(read_run(tmp_path / "r" / "scans.npz")) == 12


def test_run_written_by_another_program(tmp_path):
    """Plain np.savez with LaserScan names, no info, no angle_max."""
    np.savez(
        tmp_path / "scans.npz",
        ranges=np.full((3, 5), 2.0, np.float32),
        angle_min=-1.0,
        angle_increment=0.01,
        range_min=0.0,
        range_max=8.0,
        stamps=np.array([0.0, 0.1, 0.2]),
        mount_height=1.9,
    )
    (tmp_path / "gt.csv").write_text("id,first_scan,last_scan,label\n3, 0, 2, parked\n")
    run = read_run(tmp_path)
    assert run.name == tmp_path.name and len(run) == 3
    assert run.scans[0].ranges.dtype == np.float64
    assert run.gt["label"].tolist() == ["parked"] and run.targets()[2].tolist() == [
        [3, 1]
    ]


def _save(path, **fields):
    base = dict(
        ranges=np.ones((3, 5)),
        angle_min=-1.0,
        angle_increment=0.01,
        range_min=0.0,
        range_max=8.0,
        stamps=np.arange(3.0),
        mount_height=2.0,
    )
    base.update(fields)
    np.savez(path / "scans.npz", **{k: v for k, v in base.items() if v is not None})


def test_missing_folder_and_npz(tmp_path):
    with pytest.raises(FileNotFoundError, match="run folder not found"):
        read_run(tmp_path / "nope")
    with pytest.raises(FileNotFoundError, match="scans.npz: scans file not found"):
        read_run(tmp_path)


def test_npz_without_ranges(tmp_path):
    _save(tmp_path, ranges=None)
    with pytest.raises(ValueError, match=r"scans.npz: lacks field\(s\) ranges"):
        read_run(tmp_path)


@pytest.mark.parametrize("ranges", [np.ones(5), np.ones((2, 3, 4)), np.array([["a"]])])
def test_ranges_of_wrong_shape(tmp_path, ranges):
    _save(tmp_path, ranges=ranges, stamps=np.arange(len(ranges), dtype=float))
    with pytest.raises(
        ValueError,
        match=r"scans.npz: ranges must be a numeric array of "
        r"shape \(n_scans, n_beams\)",
    ):
        read_run(tmp_path)


def test_stamps_and_angle_count_mismatch(tmp_path):
    _save(tmp_path, stamps=np.arange(4.0))
    with pytest.raises(ValueError, match=r"stamps must have shape \(3,\)"):
        read_run(tmp_path)
    _save(tmp_path, angle_max=-1.0 + 0.01 * 9)
    with pytest.raises(ValueError, match="describe 10 beams, but ranges has 5"):
        read_run(tmp_path)


def test_corrupt_and_truncated_npz(run, tmp_path):
    write_run(run, tmp_path)
    data = (tmp_path / "scans.npz").read_bytes()
    (tmp_path / "scans.npz").write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match="scans.npz: corrupt or not an .npz file"):
        read_run(tmp_path)
    (tmp_path / "scans.npz").write_bytes(b"hello")
    with pytest.raises(ValueError, match="scans.npz: corrupt or not an .npz file"):
        read_run(tmp_path)


def test_pickled_object_array_is_refused(tmp_path):
    with (
        zipfile.ZipFile(tmp_path / "scans.npz", "w") as zf,
        zf.open("ranges.npy", "w") as f,
    ):
        np.lib.format.write_array(
            f, np.array([{"a": 1}], dtype=object), allow_pickle=True
        )
    with pytest.raises(ValueError, match="scans.npz: corrupt or not an .npz file"):
        read_run(tmp_path)


@pytest.mark.parametrize(
    "text, message",
    [
        (
            "id,first_scan,last_scan,label\n1,0,3,parked\n2,4,5,bicycle\n",
            r"gt.csv, line 3: unknown label 'bicycle', expected one of parked, passing",
        ),
        ("id,first_scan,label\n1,0,parked\n", r"gt.csv: lacks column\(s\) last_scan"),
        (
            "id,first_scan,last_scan,label\n1,zero,3,parked\n",
            r"gt.csv, line 2: first_scan is 'zero', expected an integer",
        ),
        (
            "id,first_scan,last_scan,label\n1,5,3,parked\n",
            r"gt.csv, line 2: first_scan=5, last_scan=3",
        ),
    ],
)
def test_bad_gt_csv(tmp_path, text, message):
    (tmp_path / "gt.csv").write_text(text)
    with pytest.raises(ValueError, match=message):
        read_run_gt(tmp_path / "gt.csv")


def test_info_json_is_plain_json(run, tmp_path):
    write_run(run, tmp_path)
    with np.load(tmp_path / "scans.npz", allow_pickle=False) as npz:
        assert json.loads(str(npz["info_json"]))["scenario"] == "sparse"
        assert npz["ranges"].shape == (12, 40)


def test_float32_ranges_keep_their_no_returns(run, tmp_path):
    """ROS ranges are float32: float32(8.191) must still mean no return."""
    write_run(run, tmp_path)
    with np.load(tmp_path / "scans.npz") as npz:
        fields = {k: npz[k] for k in npz.files}
    fields["ranges"] = fields["ranges"].astype(np.float32)
    np.savez(tmp_path / "scans.npz", **fields)
    back = read_run(tmp_path).scans.ranges()
    assert back[2, 5] == np.inf  # was 8.191 exactly
    assert np.isnan(back[0, 3]) and back[1, 4] == np.inf
    g = run.geometry
    no_return = ~np.isfinite(back) | (back >= g.range_max)
    original = run.scans.ranges()
    assert np.array_equal(no_return, ~np.isfinite(original) | (original >= g.range_max))


def test_gt_beyond_the_run_names_the_line(run, tmp_path):
    write_run(run, tmp_path)
    (tmp_path / "gt.csv").write_text(
        "id,first_scan,last_scan,label\n1,0,3,parked\n\n2,4,99,passing\n"
    )
    with pytest.raises(
        ValueError, match=r"gt.csv, line 4: last_scan 99 is beyond the run's 12 scans"
    ):
        read_run(tmp_path)


def test_gt_csv_line_numbers_count_blank_lines(tmp_path):
    (tmp_path / "gt.csv").write_text(
        "\ufeffid,first_scan,last_scan,label\n\n1,0,3,parked\n\n2,4,5,bicycle\n"
    )
    with pytest.raises(ValueError, match=r"gt.csv, line 5: unknown label 'bicycle'"):
        read_run_gt(tmp_path / "gt.csv")


@pytest.mark.parametrize(
    "fields, message",
    [
        ({"info_json": np.array("[1, 2]")}, "info_json must hold a JSON object"),
        ({"range_max": np.array("8.191")}, "range_max must be one finite number"),
        ({"stamps": np.array([0.0, np.nan, 2.0])}, "stamps contain NaN"),
    ],
)
def test_malformed_fields_name_the_file(tmp_path, fields, message):
    _save(tmp_path, **fields)
    with pytest.raises(ValueError, match=f"scans.npz: {message}"):
        read_run(tmp_path)


def test_stream_equals_read_run_with_bounded_chunks(run, tmp_path):
    from tunnelsense.io import open_run_stream

    write_run(run, tmp_path)
    stream = open_run_stream(tmp_path, chunk_scans=5)
    assert (stream.name, len(stream), stream.geometry) == ("run-x", 12, run.geometry)
    pd.testing.assert_frame_equal(stream.gt, run.gt)
    scans = list(stream)
    assert [s.scan for s in scans] == list(range(12))
    assert np.array_equal(
        np.stack([s.ranges for s in scans]), run.scans.ranges(), equal_nan=True
    )
    assert [s.stamp for s in scans] == [s.stamp for s in run.scans]


def test_stream_keeps_float32_no_returns_and_reports_truncation(run, tmp_path):
    from tunnelsense.io import open_run_stream

    write_run(run, tmp_path)
    with np.load(tmp_path / "scans.npz") as npz:
        fields = {k: npz[k] for k in npz.files}
    fields["ranges"] = fields["ranges"].astype(np.float32)
    np.savez(tmp_path / "scans.npz", **fields)
    scans = list(open_run_stream(tmp_path, chunk_scans=4))
    assert scans[2].ranges[5] == np.inf and scans[0].ranges.dtype == np.float64
    with pytest.raises(ValueError, match=r"scans.npz: lacks field\(s\) ranges"):
        _save(tmp_path, ranges=None)
        open_run_stream(tmp_path)
