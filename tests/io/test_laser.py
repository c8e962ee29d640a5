import io
import json
import zipfile

import numpy as np
import pandas as pd
import pytest

from tunnelsense import LaserGeometry, Run
from tunnelsense.exceptions import InputFormatError
from tunnelsense.io import describe, open_run_stream, read_run, read_run_gt, write_run
from tunnelsense.io._npz import write_npz


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


@pytest.mark.parametrize("info, speed", [
    ({"speed_kmh_mean": 36.0}, 10.0),
    ({"speed": 8.5, "speed_kmh": 99.0}, 8.5),
    ({"speed_mps": "7.25"}, 7.25),
    ({"speed": -3.0, "speed_kmh": 18.0}, 5.0),  # the first positive number
    ({"speed": "fast", "speed_kmh": float("nan")}, None),
    ({}, None),
])
def test_scans_carry_the_ego_speed_of_the_run_information(run, tmp_path, info,
                                                          speed):
    """read_run and open_run_stream give every scan the run's ego speed alike."""
    from tunnelsense.io import ego_speed

    write_run(Run(run.name, run.scans, run.gt, info), tmp_path)
    assert ego_speed(info) == (None if speed is None else pytest.approx(speed))
    for scans in (read_run(tmp_path).scans, list(open_run_stream(tmp_path))):
        got = [r.payload.get("speed") for r in scans]
        assert got == [None if speed is None else pytest.approx(speed)] * 12


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


# --------------------------------------------------------------------------------------
# Bad input is an InputFormatError naming the file, the same from every reader
# --------------------------------------------------------------------------------------
def _arrays(**fields):
    """The members of a valid scans.npz (5 scans of 4 beams), some replaced."""
    arrays = dict(
        ranges=np.full((5, 4), 3.0),
        stamps=np.arange(5) / 75.0,
        angle_min=np.float64(-1.4),
        angle_increment=np.float64(0.0087),
        range_min=np.float64(0.05),
        range_max=np.float64(8.191),
        mount_height=np.float64(2.0),
    )
    arrays.update(fields)
    return {k: v for k, v in arrays.items() if v is not None}


def _write_members(folder, arrays, raw=None):
    """Write ``arrays`` as scans.npz, then ``raw`` {name: bytes} as extra members."""
    folder.mkdir(exist_ok=True)
    write_npz(folder / "scans.npz", arrays)
    with zipfile.ZipFile(folder / "scans.npz", "a") as zf:
        for name, data in (raw or {}).items():
            zf.writestr(name, data)
    return folder


def _every_reader_refuses(folder, match, **kwargs):
    for read in (read_run, lambda f, **kw: list(open_run_stream(f, **kw)), describe):
        with pytest.raises(InputFormatError, match=match):
            read(folder, **kwargs)


def _npy_header(shape, descr="<f8", fortran_order=False):
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buf, {"shape": shape, "fortran_order": fortran_order, "descr": descr}
    )
    return buf.getvalue()


def test_raised_errors_are_input_format_errors(tmp_path):
    """The messages are unchanged; the class is the project's InputFormatError."""
    _save(tmp_path, ranges=None)
    with pytest.raises(InputFormatError, match=r"scans.npz: lacks field\(s\) ranges"):
        read_run(tmp_path)
    (tmp_path / "gt.csv").write_text("id,first_scan,last_scan,label\n1,zero,3,parked\n")
    with pytest.raises(InputFormatError, match="gt.csv, line 2: first_scan is 'zero'"):
        read_run_gt(tmp_path / "gt.csv")


def test_zero_scans_are_refused(tmp_path):
    folder = _write_members(
        tmp_path / "run", _arrays(ranges=np.zeros((0, 4)), stamps=np.zeros(0))
    )
    _every_reader_refuses(folder, r"scans.npz: ranges has 0 scans")


def test_fortran_ordered_ranges_are_read_alike(tmp_path):
    """np.savez keeps a transposed array column-major; every reader reads it."""
    ranges = np.asfortranarray(np.arange(20.0).reshape(5, 4) / 4 + 0.5)
    folder = _write_members(tmp_path / "run", _arrays(ranges=ranges))
    expected = np.ascontiguousarray(ranges)
    assert np.array_equal(read_run(folder).scans.ranges(), expected)
    streamed = [s.ranges for s in open_run_stream(folder, chunk_scans=2)]
    assert np.array_equal(np.stack(streamed), expected)
    assert describe(folder)["scans"] == 5


@pytest.mark.parametrize(
    ("missing", "member", "data", "match"),
    [
        ("ranges", "ranges.npy", b"hello world", "ranges"),
        ("ranges", "ranges", b"hello world", "ranges"),
        ("stamps", "stamps.npy", b"hello world", "stamps"),
        ("mount_height", "mount_height.npy", b"\x93NUMPY", "mount_height"),
    ],
)
def test_members_that_are_not_npy_arrays(tmp_path, missing, member, data, match):
    folder = _write_members(
        tmp_path / "run", _arrays(**{missing: None}), raw={member: data}
    )
    _every_reader_refuses(folder, rf"scans.npz: .*{match}")


@pytest.mark.parametrize(
    "shape", [(5, 10**15), (10**9, 10**9), (5, -4), (-5, 4)]
)
def test_member_header_claiming_an_impossible_shape(tmp_path, shape):
    """A few bytes claiming petabytes are refused, never allocated."""
    folder = _write_members(
        tmp_path / "run",
        _arrays(ranges=None),
        raw={"ranges.npy": _npy_header(shape) + bytes(160)},
    )
    _every_reader_refuses(folder, r"scans.npz: .*ranges")


def test_unknown_npy_version_is_refused_alike(tmp_path):
    data = bytearray(_npy_header((5, 4)) + bytes(160))
    data[6] = 9  # format version 9.0
    folder = _write_members(
        tmp_path / "run", _arrays(ranges=None), raw={"ranges.npy": bytes(data)}
    )
    _every_reader_refuses(folder, r"scans.npz: .*ranges.*version")


def test_narrow_floats_are_read_without_warnings(tmp_path):
    """float16 ranges beside a range_max float16 cannot hold: no overflow warning."""
    ranges = np.full((5, 4), 3.0, np.float16)
    ranges[0, 0] = np.inf
    folder = _write_members(
        tmp_path / "run", _arrays(ranges=ranges, range_max=np.float64(1e6))
    )
    back = read_run(folder).scans.ranges()
    assert back.dtype == np.float64 and back[0, 0] == np.inf and back[1, 1] == 3.0
    streamed = np.stack([s.ranges for s in open_run_stream(folder)])
    assert np.array_equal(streamed, back)


@pytest.mark.parametrize(
    ("field", "match"),
    [("stamps", "stamps contain NaN or infinity"),
     ("mount_height", "mount_height must be one finite number"),
     ("angle_max", "angle_max must be one finite number")],
)
def test_long_doubles_beyond_float64_are_refused(tmp_path, field, match):
    huge = np.longdouble(10) ** 4000
    if not np.isfinite(huge):
        pytest.skip("long double is float64 on this platform")
    value = np.array([0, 1, 2, 3, huge]) if field == "stamps" else huge
    folder = _write_members(tmp_path / "run", _arrays(**{field: np.asarray(value)}))
    _every_reader_refuses(folder, "scans.npz: " + match)


@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_angle_max_must_be_finite(tmp_path, value):
    folder = _write_members(tmp_path / "run", _arrays(angle_max=np.float64(value)))
    _every_reader_refuses(folder, "scans.npz: angle_max must be one finite number")


def test_info_json_as_utf8_bytes_is_read(tmp_path):
    info = np.array('{"site": "Gare de l\'Est – quai 3"}'.encode())
    folder = _write_members(tmp_path / "run", _arrays(info_json=info))
    assert read_run(folder).info == {"site": "Gare de l'Est – quai 3"}
    assert open_run_stream(folder).info == {"site": "Gare de l'Est – quai 3"}


@pytest.mark.parametrize(
    ("info", "match"),
    [
        (np.array(b'{"a": "caf\xe9"}'), "info_json is not UTF-8"),
        (np.array('{"a": ' + "9" * 5000 + "}"), "info_json is not valid JSON"),
        (np.array("[" * 100_000 + "]" * 100_000), "info_json is not valid JSON"),
        (np.array(["{}", "{}"]), "info_json must be one JSON string"),
        (np.array(3.0), "info_json must be one JSON string"),
    ],
)
def test_bad_info_json(tmp_path, info, match):
    folder = _write_members(tmp_path / "run", _arrays(info_json=info))
    _every_reader_refuses(folder, "scans.npz: " + match)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        # a first row longer than the header: pandas would make "7" an index and
        # read id=1, first_scan=0, last_scan=1 silently
        ("id,first_scan,last_scan,label\n7,1,0,1,parked\n",
         r"gt.csv, line 2: 5 fields, expected 4"),
        ("id,first_scan,last_scan,label\n1,0,1,parked\n2,3,4,passing,x\n",
         r"gt.csv, line 3: 5 fields, expected 4"),
        ("id,first_scan,last_scan,label,id\n1,0,1,parked,2\n",
         r"gt.csv, line 1: column id appears twice"),
    ],
)
def test_gt_csv_rows_do_not_shift(tmp_path, text, match):
    (tmp_path / "gt.csv").write_text(text)
    with pytest.raises(InputFormatError, match=match):
        read_run_gt(tmp_path / "gt.csv")


def test_gt_csv_extra_columns_are_kept_out(tmp_path):
    (tmp_path / "gt.csv").write_text(
        "id,first_scan,last_scan,label,note\n1,0,1,parked,van\n2,3,4,passing,\n"
    )
    gt = read_run_gt(tmp_path / "gt.csv")
    assert gt["id"].tolist() == [1, 2] and gt["label"].tolist() == ["parked", "passing"]
    assert list(gt.attrs["lines"]) == [2, 3]


def test_range_unit_mm_divides_every_range(tmp_path):
    """With range_unit="mm", integer and float ranges alike are divided by 1000."""
    ints = _write_members(
        tmp_path / "ints", _arrays(ranges=np.full((5, 4), 3000, np.uint16))
    )
    floats = _write_members(
        tmp_path / "floats", _arrays(ranges=np.full((5, 4), 3000.0, np.float32))
    )
    for folder in (ints, floats):
        run = read_run(folder, range_unit="mm")
        assert np.array_equal(run.scans.ranges(), np.full((5, 4), 3.0))
        assert run.geometry.range_max == 8.191  # metres, as ROS defines it
        streamed = [s.ranges for s in open_run_stream(folder, range_unit="mm")]
        assert np.array_equal(np.stack(streamed), run.scans.ranges())
        assert describe(folder, range_unit="mm")["scans"] == 5
    _every_reader_refuses(ints, r"ranges are integers \(uint16\).*range_unit='mm'")


@pytest.mark.parametrize("unit", ["cm", "M", None, 1])
def test_range_unit_must_be_known(tmp_path, unit):
    folder = _write_members(tmp_path / "run", _arrays())
    _every_reader_refuses(folder, r"range_unit must be one of 'm', 'mm'",
                          range_unit=unit)


@pytest.mark.parametrize("chunk_scans", [0, -3, 2.5, "4"])
def test_chunk_scans_must_be_a_positive_integer(tmp_path, chunk_scans):
    folder = _write_members(tmp_path / "run", _arrays())
    with pytest.raises(InputFormatError, match="chunk_scans must be an integer >= 1"):
        open_run_stream(folder, chunk_scans=chunk_scans)


@pytest.mark.parametrize(
    ("fields", "match"),
    [
        (dict(angle_increment=0.0), "angle_increment is 0.0, expected a non-zero"),
        (dict(angle_increment=np.inf), "angle_increment is inf, expected a finite"),
        (dict(range_min=-0.1), "range_min is -0.1, expected a range >= 0"),
        (dict(range_max=0.0), "range_max is 0.0, expected a range > 0"),
        (dict(range_min=9.0), r"range_min \(9.0\) must be below range_max \(8.191\)"),
        (dict(mount_height=0.0), "mount_height is 0.0, expected a height > 0"),
        (dict(angle_min=np.nan), "angle_min is nan, expected a finite"),
        (dict(angle_min="x"), "angle_min is 'x', expected a finite number"),
    ],
)
def test_laser_geometry_refuses_impossible_values(fields, match):
    values = dict(angle_min=-1.4, angle_increment=0.0087, range_min=0.05,
                  range_max=8.191, mount_height=2.0)
    with pytest.raises(ValueError, match=match):
        LaserGeometry(**{**values, **fields})


def test_gt_csv_trailing_empty_fields_are_harmless(tmp_path):
    (tmp_path / "gt.csv").write_text("id,first_scan,last_scan,label\n1,0,1,parked,,\n")
    gt = read_run_gt(tmp_path / "gt.csv")
    assert gt[["id", "first_scan", "last_scan"]].to_numpy().tolist() == [[1, 0, 1]]


def _clock(n, rate=75.0, tick=0.02):
    """Stamps of ``n`` scans at ``rate`` scans/s on a clock of ``tick`` seconds."""
    return np.floor(np.arange(n) / rate / tick) * tick


def test_equal_stamps_of_a_coarse_clock_are_read_as_written(tmp_path):
    # 75 scans/s on a 20 ms clock: steps of 0 and 20 ms (the detector and the
    # census read such stamps); whole and streamed alike
    stamps = _clock(12)
    assert (np.diff(stamps) == 0).any()
    _save(tmp_path, ranges=np.ones((12, 5)), stamps=stamps)
    assert [s.stamp for s in read_run(tmp_path).scans] == stamps.tolist()
    assert [s.stamp for s in open_run_stream(tmp_path, chunk_scans=5)] == stamps.tolist()


@pytest.mark.parametrize(
    "stamps, match",
    [(np.array([0.0, 0.02, 0.02, 0.0]),
      r"scans.npz: stamps must not decrease; scan 3 \(t=0.0\) comes before scan 2 "
      r"\(t=0.02\)"),
     (np.full(4, 1.5), r"scans.npz: stamps must span some time; all 4 scans are at "
                       r"t=1.5")])
def test_stamps_that_decrease_or_are_all_equal_are_refused(tmp_path, stamps, match):
    _save(tmp_path, ranges=np.ones((4, 5)), stamps=stamps)
    with pytest.raises(InputFormatError, match=match):
        read_run(tmp_path)
    with pytest.raises(InputFormatError, match=match):
        open_run_stream(tmp_path)


def test_one_scan_needs_no_time_span(tmp_path):
    _save(tmp_path, ranges=np.ones((1, 5)), stamps=np.array([3.0]))
    assert len(read_run(tmp_path).scans) == 1
