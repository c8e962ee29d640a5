"""Fuzz the laser-run readers: only the project's errors, naming the file, escape.

``read_run``, ``open_run_stream`` (iterated to the end) and ``describe`` must agree:
all three read a run alike, or all three refuse it with an InputFormatError.  Run
``pytest --hypothesis-profile=ci`` for a longer search.
"""

import io
import zipfile

import numpy as np
import pytest
from hypothesis import event, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from tunnelsense.exceptions import InputFormatError
from tunnelsense.io import describe, open_run_stream, read_run, read_run_gt, write_run
from tunnelsense.io._npz import write_npz

FUZZ = settings()  # examples from the Hypothesis profile (tests/conftest.py)

VALID = {
    "ranges": np.full((3, 4), 3.0), "stamps": np.arange(3) / 75.0,
    "angle_min": np.float64(-1.4), "angle_increment": np.float64(0.0087),
    "range_min": np.float64(0.05), "range_max": np.float64(8.191),
    "mount_height": np.float64(2.0),
}
FIELDS = [*VALID, "angle_max", "info_json"]


@pytest.fixture(scope="module")
def genuine(tmp_path_factory):
    """The bytes of scans.npz and gt.csv of a simulated run of 120 scans."""
    from tunnelsense.datasets import make_street_scans

    folder = write_run(make_street_scans(120, random_state=0, name="g"),
                       tmp_path_factory.mktemp("g") / "g")
    return (folder / "scans.npz").read_bytes(), (folder / "gt.csv").read_bytes()


def _folder(tmp_path, scans=None, gt=None):
    """A fresh run folder holding the given bytes as scans.npz and gt.csv."""
    folder = tmp_path / "run"
    folder.mkdir(exist_ok=True)
    for name, data in (("scans.npz", scans), ("gt.csv", gt)):
        (folder / name).unlink(missing_ok=True)
        if data is not None:
            (folder / name).write_bytes(data)
    return folder


def _attempt(read, folder):
    """``read(folder)``, or the refusal, which must be ours and name the file."""
    try:
        return read(folder)
    except (InputFormatError, FileNotFoundError) as exc:
        assert str(folder) in str(exc), str(exc)
        return exc


def _every_reader(folder):
    """Read the run every way; they agree, and a successful read is a sound run."""
    run = _attempt(read_run, folder)
    scans = _attempt(lambda f: list(open_run_stream(f, chunk_scans=7)), folder)
    facts = _attempt(describe, folder)
    refused = [isinstance(r, Exception) for r in (run, scans, facts)]
    assert refused in ([True] * 3, [False] * 3), (run, scans, facts)
    event("refused" if refused[0] else "read")
    if refused[0]:
        return
    ranges = run.scans.ranges()
    stamps = np.array([s.stamp for s in run.scans])
    assert ranges.dtype == np.float64 and ranges.shape == (len(run), ranges.shape[1])
    assert len(run) >= 1 and ranges.shape[1] >= 1
    assert np.all(np.isfinite(stamps)) and np.all(np.diff(stamps) > 0)
    assert np.array_equal(np.stack([s.ranges for s in scans]), ranges, equal_nan=True)
    assert [s.stamp for s in scans] == stamps.tolist()
    assert (facts["scans"], facts["beams"]) == ranges.shape


def _members_zip(members):
    """A zip holding the given {name: bytes} members."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for name, data in members.items():
            zf.writestr(name, data)
    return buf.getvalue()


@FUZZ
@given(data=st.binary(max_size=1024))
def test_random_bytes_as_scans_npz(tmp_path, data):
    _every_reader(_folder(tmp_path, data))


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
    _every_reader(_folder(tmp_path, bytes(data), genuine[1]))


_DTYPES = st.sampled_from(["f8", "f4", "f2", "g", ">f8", "i4", "u2", "i8", "u8", "i1",
                           "?", "c16", "U3", "S2", "M8[s]", "m8[ms]"])
_MEMBER = _DTYPES.flatmap(
    lambda dt: hnp.arrays(
        dt, hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=4)
    )
)


_CLOSE_TO_VALID = st.one_of(
    _MEMBER.map(lambda a: a.astype(np.float64) if a.dtype.kind in "fiu" else a),
    hnp.arrays("f8", 3, elements=st.floats(0, 1, width=32)).map(np.sort),  # stamps
    hnp.arrays("f4", (3, 4)),  # ranges
    hnp.arrays("u2", (3, 4)),
)


@FUZZ
@given(members=st.dictionaries(st.sampled_from(FIELDS), _MEMBER | _CLOSE_TO_VALID,
                               max_size=9),
       keep_valid=st.booleans(), fortran=st.booleans())
def test_npz_members_of_any_dtype_and_shape(tmp_path, members, keep_valid, fortran):
    """Any members; with keep_valid, a valid run with a few of them replaced."""
    if keep_valid:
        members = dict(list(members.items())[:2])
    arrays = {**(VALID if keep_valid else {}), **members}
    if fortran:
        arrays = {k: np.asfortranarray(v) for k, v in arrays.items()}
    folder = _folder(tmp_path)
    write_npz(folder / "scans.npz", arrays)
    _every_reader(folder)


def _npy_header(shape, descr, fortran):
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buf, {"shape": shape, "fortran_order": fortran, "descr": descr}
    )
    return buf.getvalue()


_DIM = st.integers(-2, 6) | st.sampled_from([10**9, 2**62, 10**30])
_HEADER = st.builds(
    _npy_header,
    shape=st.lists(_DIM, max_size=3).map(tuple),
    descr=st.sampled_from(["<f8", "<i4", "|O", "<U2", "|S0", "|V8", "('<f8', (2,))"]),
    fortran=st.booleans(),
)
_RAW_MEMBER = _HEADER.flatmap(
    lambda head: st.binary(max_size=200).map(lambda body: head + body)
) | st.binary(max_size=64)


@FUZZ
@given(raw=st.dictionaries(st.sampled_from(FIELDS).flatmap(
           lambda k: st.sampled_from([k + ".npy", k])), _RAW_MEMBER, max_size=3))
def test_npz_members_of_any_bytes(tmp_path, raw):
    """Members that are not .npy, truncated, or with headers claiming anything."""
    members = {}
    for k, v in VALID.items():
        buf = io.BytesIO()
        np.lib.format.write_array(buf, v)
        members[k + ".npy"] = buf.getvalue()
    members.update(raw)
    _every_reader(_folder(tmp_path, _members_zip(members)))


_FIELD = st.one_of(
    st.integers(-5, 200).map(str),
    st.sampled_from(["parked", "passing", " parked ", "", "x", "1e3", "99" * 12,
                     '"3"', "\u0663"]),
    st.text(max_size=6),
)
_ROW = st.lists(_FIELD, min_size=0, max_size=6).map(",".join) | st.builds(
    "{},{},{},{}".format, st.integers(0, 9), st.integers(-1, 3), st.integers(-1, 4),
    st.sampled_from(["parked", "passing", "bus"]),
)


@FUZZ
@given(text=st.text(max_size=300) | st.binary(max_size=300)
       | st.lists(_ROW, max_size=8).map("\n".join),
       header=st.booleans())
def test_gt_csv(tmp_path, text, header):
    path = tmp_path / "gt.csv"
    head = b"id,first_scan,last_scan,label\n" if header else b""
    path.write_bytes(head + (text if isinstance(text, bytes) else text.encode()))
    try:
        gt = read_run_gt(path)
    except InputFormatError as exc:
        assert str(path) in str(exc), str(exc)
        return
    assert list(gt.columns) == ["id", "first_scan", "last_scan", "label"]
    assert all(gt[c].dtype == np.int64 for c in ("id", "first_scan", "last_scan"))
    assert (gt["first_scan"] >= 0).all() and (gt["last_scan"] >= gt["first_scan"]).all()
    assert set(gt["label"]) <= {"parked", "passing"}
    assert len(gt.attrs["lines"]) == len(gt)


@FUZZ
@given(rows=st.lists(_ROW, max_size=6).map("\n".join))
def test_gt_csv_beside_a_valid_run(tmp_path, rows):
    scans = io.BytesIO()
    np.savez(scans, **VALID)
    gt = ("id,first_scan,last_scan,label\n" + rows).encode()
    _every_reader(_folder(tmp_path, scans.getvalue(), gt))
