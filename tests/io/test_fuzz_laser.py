"""Fuzz the laser-run readers: only the project's errors, naming the file, escape."""

import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from tunnelsense.exceptions import InputFormatError
from tunnelsense.io import describe, open_run_stream, read_run, read_run_gt, write_run
from tunnelsense.io._laser import _write_npz

FUZZ = settings(max_examples=int(os.environ.get("TUNNELSENSE_FUZZ_EXAMPLES", 60)),
                deadline=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture])


@pytest.fixture(scope="module")
def genuine(tmp_path_factory):
    from tunnelsense.datasets import make_street_scans

    folder = write_run(make_street_scans(120, random_state=0, name="g"),
                       tmp_path_factory.mktemp("g") / "g")
    return (folder / "scans.npz").read_bytes(), (folder / "gt.csv").read_bytes()


def _every_reader(folder):
    """Read the run every way; a successful read must be a sound run."""
    for read in (read_run, lambda f: list(open_run_stream(f, chunk_scans=7)),
                 describe):
        try:
            result = read(folder)
        except InputFormatError as exc:
            assert str(folder) in str(exc)
            continue
        except FileNotFoundError as exc:  # e.g. a scans.npz made a folder
            assert str(folder) in str(exc)
            continue
        if isinstance(result, list):
            stamps = np.array([s.stamp for s in result])
            assert np.all(np.isfinite(stamps)) and np.all(np.diff(stamps) > 0)
            assert all(s.ranges.dtype == np.float64 for s in result)
        elif hasattr(result, "scans"):
            ranges = result.scans.ranges() if len(result.scans) else None
            assert ranges is None or ranges.dtype == np.float64


@FUZZ
@given(data=st.binary(max_size=1024))
def test_random_bytes_as_scans_npz(tmp_path, data):
    folder = tmp_path / "run"
    folder.mkdir(exist_ok=True)
    (folder / "scans.npz").write_bytes(data)
    _every_reader(folder)


@FUZZ
@given(flips=st.lists(st.tuples(st.floats(0, 1, exclude_max=True),
                                st.integers(1, 255)), min_size=1, max_size=3),
       cut=st.none() | st.floats(0, 1))
def test_edited_scans_npz(tmp_path, genuine, flips, cut):
    data = bytearray(genuine[0])
    for where, value in flips:
        data[int(where * len(data))] ^= value
    if cut is not None:
        data = data[: int(cut * len(data))]
    folder = tmp_path / "run"
    folder.mkdir(exist_ok=True)
    (folder / "scans.npz").write_bytes(bytes(data))
    (folder / "gt.csv").write_bytes(genuine[1])
    _every_reader(folder)


_DTYPES = st.sampled_from(["f8", "f4", "i4", "u2", "i8", "?", "c16", "U3", "S2"])
_MEMBER = _DTYPES.flatmap(
    lambda dt: hnp.arrays(dt, hnp.array_shapes(min_dims=0, max_dims=3, max_side=4))
)
_FIELDS = ["ranges", "stamps", "angle_min", "angle_increment", "range_min",
           "range_max", "mount_height", "angle_max", "info_json"]


@FUZZ
@given(members=st.dictionaries(st.sampled_from(_FIELDS), _MEMBER, max_size=9),
       keep_valid=st.booleans())
def test_npz_members_of_any_dtype_and_shape(tmp_path, members, keep_valid):
    arrays = {
        "ranges": np.full((3, 4), 3.0), "stamps": np.arange(3) / 75.0,
        "angle_min": np.float64(-1.4), "angle_increment": np.float64(0.0087),
        "range_min": np.float64(0.05), "range_max": np.float64(8.191),
        "mount_height": np.float64(2.0),
    } if keep_valid else {}
    arrays.update(members)
    folder = tmp_path / "run"
    folder.mkdir(exist_ok=True)
    _write_npz(folder / "scans.npz", arrays)
    _every_reader(folder)


@FUZZ
@given(text=st.text(max_size=300) | st.binary(max_size=300), header=st.booleans())
def test_gt_csv(tmp_path, text, header):
    path = tmp_path / "gt.csv"
    head = "id,first_scan,last_scan,label\n" if header else ""
    if isinstance(text, bytes):
        path.write_bytes(head.encode() + text)
    else:
        path.write_text(head + text)
    try:
        gt = read_run_gt(path)
    except InputFormatError as exc:
        assert "gt.csv" in str(exc)
        return
    assert (gt["first_scan"] >= 0).all() and (gt["last_scan"] >= gt["first_scan"]).all()
    assert set(gt["label"]) <= {"parked", "passing"}
