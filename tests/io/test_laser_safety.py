"""Laser runs: every bad input is a clear error naming the file, never a wrong answer."""

import json
import zipfile

import numpy as np
import pytest

from tunnelsense import LaserGeometry, Run
from tunnelsense._cli import main
from tunnelsense.datasets import make_street_scans
from tunnelsense.exceptions import InputFormatError
from tunnelsense.io import describe, open_run_stream, read_run, write_run
from tunnelsense.io._npz import write_npz

GEOMETRY = LaserGeometry(-1.4, 0.0087, 0.05, 8.191, 2.0)


@pytest.fixture
def arrays():
    """The members of a valid scans.npz (5 scans of 4 beams)."""
    return {
        "ranges": np.full((5, 4), 3.0),
        "stamps": np.arange(5) / 75.0,
        "angle_min": np.float64(-1.4),
        "angle_increment": np.float64(0.0087),
        "range_min": np.float64(0.05),
        "range_max": np.float64(8.191),
        "mount_height": np.float64(2.0),
    }


def _write(folder, arrays):
    folder.mkdir(exist_ok=True)
    write_npz(folder / "scans.npz", arrays)
    return folder


def _both_readers_refuse(folder, match):
    with pytest.raises(InputFormatError, match=match):
        read_run(folder)
    with pytest.raises(InputFormatError, match=match):
        list(open_run_stream(folder))
    with pytest.raises(InputFormatError, match=match):
        describe(folder)


def test_integer_ranges_need_the_unit(tmp_path, arrays):
    arrays["ranges"] = np.full((5, 4), 3000, dtype=np.int32)  # millimetres
    folder = _write(tmp_path / "run", arrays)
    _both_readers_refuse(folder, r"scans.npz: ranges are integers .* range_unit='mm'")
    run = read_run(folder, range_unit="mm")
    assert np.allclose(run.scans.ranges(), 3.0)
    streamed = np.array([s.ranges for s in open_run_stream(folder, range_unit="mm")])
    assert np.array_equal(streamed, run.scans.ranges())


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("angle_increment", 0.0, "angle_increment is 0.0, expected a non-zero angle"),
        ("range_max", -1.0, "range_max is -1.0, expected a range > 0"),
        ("range_min", 9.0, r"range_min \(9.0\) must be below range_max"),
        ("range_min", -0.1, "range_min is -0.1, expected a range >= 0"),
        ("mount_height", 0.0, "mount_height is 0.0, expected a height > 0"),
        ("mount_height", -2.0, "mount_height is -2.0"),
        ("mount_height", np.nan, "mount_height must be one finite number"),
        ("angle_min", np.array("x"), "angle_min must be one finite number"),
    ],
)
def test_impossible_geometry_is_refused(tmp_path, arrays, field, value, match):
    arrays[field] = np.asarray(value)
    folder = _write(tmp_path / "run", arrays)
    _both_readers_refuse(folder, "scans.npz: " + match)


@pytest.mark.parametrize(
    ("stamps", "match"),
    [
        # equal stamps (a coarse clock) are read; all equal, no time to measure
        ([0.1, 0.1, 0.1, 0.1, 0.1], r"stamps must span some time; all 5 scans"),
        ([0.0, 0.2, 0.1, 0.3, 0.4], r"scan 2 \(t=0.1\) comes before scan 1"),
        ([0.0, np.nan, 0.2, 0.3, 0.4], "stamps contain NaN"),
        (["0", "1", "2", "3", "4"], r"stamps must be numbers \(seconds\); got <U1"),
    ],
)
def test_bad_stamps_are_refused_by_every_reader(tmp_path, arrays, stamps, match,
                                                capsys):
    arrays["stamps"] = np.asarray(stamps)
    folder = _write(tmp_path / "run", arrays)
    _both_readers_refuse(folder, match)
    assert main(["info", str(folder)]) == 1  # info and detect agree
    assert "stamps" in capsys.readouterr().err


def test_huge_integers_in_gt_csv(tmp_path, arrays):
    folder = _write(tmp_path / "run", arrays)
    (folder / "gt.csv").write_text(
        "id,first_scan,last_scan,label\n1,0,99999999999999999999999,parked\n"
    )
    _both_readers_refuse(folder, r"gt.csv, line 2: last_scan is .* at most 18 digits")


def _corrupt_crc(path):
    """Flip a byte inside the compressed ranges member, keeping the zip valid."""
    data = bytearray(path.read_bytes())
    with zipfile.ZipFile(path) as zf:
        info = zf.getinfo("ranges.npy")
    start = info.header_offset + 30 + len(info.filename) + len(info.extra)
    data[start + info.compress_size // 2] ^= 0xFF
    path.write_bytes(bytes(data))


def test_bad_crc_inside_the_npz_is_a_clear_error(tmp_path):
    run = make_street_scans(400, random_state=0, name="crc")
    folder = write_run(run, tmp_path / "run")
    _corrupt_crc(folder / "scans.npz")
    with pytest.raises(InputFormatError, match="scans.npz: corrupt"):
        read_run(folder)
    with pytest.raises(InputFormatError, match="scans.npz: corrupt"):
        list(open_run_stream(folder, chunk_scans=64))


def test_corrupt_run_mid_stream_keeps_what_was_written(tmp_path, capsys):
    run = make_street_scans(1500, random_state=0, name="mid")
    folder = write_run(run, tmp_path / "run")
    model = tmp_path / "m.skops"
    assert main(["train", "street", str(folder), "--model", str(model)]) == 0
    _corrupt_crc(folder / "scans.npz")
    out = tmp_path / "objects.csv"
    code = main(["detect", "street", "--model", str(model), str(folder), "--out",
                 str(out), "--quiet"])
    assert code == 1
    err = capsys.readouterr().err
    assert "scans.npz: corrupt" in err and "internal error" not in err
    assert out.read_text().startswith("id,first_scan")  # what was done is kept


def test_range_unit_on_the_command_line(tmp_path, capsys):
    run = make_street_scans(600, random_state=1, name="mm")
    folder = write_run(run, tmp_path / "m")
    model = tmp_path / "model.skops"
    assert main(["train", "street", str(folder), "--model", str(model)]) == 0
    metres = tmp_path / "metres.csv"
    assert main(["detect", "street", "--model", str(model), str(folder), "--out",
                 str(metres), "--quiet"]) == 0
    # the same run written by a driver in integer millimetres
    mm = tmp_path / "mm"
    mm.mkdir()
    with np.load(folder / "scans.npz") as npz:
        arrays = {k: npz[k] for k in npz.files}
    r = arrays["ranges"]
    arrays["ranges"] = np.where(np.isfinite(r), np.round(r * 1000), 65535).astype(
        np.uint16)
    write_npz(mm / "scans.npz", arrays)
    (mm / "gt.csv").write_bytes((folder / "gt.csv").read_bytes())
    out = tmp_path / "mm.csv"
    assert main(["detect", "street", "--model", str(model), str(mm), "--out",
                 str(out), "--quiet"]) == 1
    assert "--range-unit mm" in capsys.readouterr().err
    assert main(["detect", "street", "--model", str(model), str(mm), "--out",
                 str(out), "--quiet", "--range-unit", "mm"]) == 0
    a, b = metres.read_text().splitlines(), out.read_text().splitlines()
    assert [line.split(",")[:4] for line in a] == [line.split(",")[:4] for line in b]


def test_write_run_output_is_valid(tmp_path):
    run = Run.from_arrays("r", np.ones((3, 4)), np.arange(3) / 75, GEOMETRY)
    folder = write_run(run, tmp_path / "r")
    info = json.loads(str(np.load(folder / "scans.npz")["info_json"]))
    assert info["name"] == "r"
