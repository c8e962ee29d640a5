"""Fuzz the frame readers: only the project's errors, naming the file, escape.

A read either succeeds with data that keeps the format's invariants, or raises
:class:`~tunnelsense.exceptions.InputFormatError` (or ``FileNotFoundError``) whose
message names the file.  Warnings are errors in this suite, so a reader must not let
a NumPy or pandas warning out either.  Run ``pytest --hypothesis-profile=ci`` for more
examples.
"""

import shutil
import struct
import zlib

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tunnelsense._records import MOT_GT_COLUMNS
from tunnelsense.exceptions import InputFormatError
from tunnelsense.io import (
    MOT_RESULT_COLUMNS,
    open_tour,
    read_image,
    read_image_folder,
    read_mot_gt,
    read_mot_results,
    read_tour,
)

FUZZ = settings()  # examples from the Hypothesis profile (tests/conftest.py)


@pytest.fixture(scope="module")
def pngs():
    rng = np.random.default_rng(0)
    return {
        bits: cv2.imencode(".png", rng.integers(0, 2**bits, (12, 16)).astype(
            np.uint8 if bits == 8 else np.uint16))[1].tobytes()
        for bits in (8, 16)
    }


def _read_or_refuse(reader, path, named=None):
    """``reader(path)``, or None when it raised one of the allowed errors."""
    try:
        return reader(path)
    except Exception as exc:  # noqa: BLE001 - the test is which ones escape
        assert isinstance(exc, InputFormatError | FileNotFoundError), repr(exc)
        assert str(named or path) in str(exc), str(exc)
        return None


def _check_image(image, shape=None):
    if image is not None:
        assert image.ndim == 2 and image.dtype in (np.uint8, np.uint16)
        assert shape is None or image.shape == shape


# --------------------------------------------------------------------------------------
# Images
# --------------------------------------------------------------------------------------
@FUZZ
@given(data=st.binary(max_size=600))
def test_random_bytes_as_an_image(tmp_path, data):
    path = tmp_path / "f.png"
    path.write_bytes(data)
    _check_image(_read_or_refuse(read_image, path))


@FUZZ
@given(bits=st.sampled_from([8, 16]),
       flips=st.lists(st.tuples(st.floats(0, 1, exclude_max=True),
                                st.integers(1, 255)), max_size=3),
       cut=st.none() | st.floats(0, 1))
def test_edited_png(tmp_path, pngs, bits, flips, cut):
    data = bytearray(pngs[bits])
    for where, value in flips:
        data[int(where * len(data))] ^= value
    if cut is not None:
        data = data[: int(cut * len(data))]
    path = tmp_path / "f.png"
    path.write_bytes(bytes(data))
    _check_image(_read_or_refuse(read_image, path), (12, 16))


@FUZZ
@given(bits=st.sampled_from([8, 16]),
       width=st.integers(0, 2**32 - 1) | st.integers(0, 40),
       height=st.integers(0, 2**32 - 1) | st.integers(0, 40))
def test_png_header_sizes(tmp_path, pngs, bits, width, height):
    """Any size in IHDR, with a valid checksum: OpenCV's own limits are refusals too."""
    data = bytearray(pngs[bits])
    data[16:24] = struct.pack(">II", width, height)
    data[29:33] = struct.pack(">I", zlib.crc32(bytes(data[12:29])))
    path = tmp_path / "f.png"
    path.write_bytes(bytes(data))
    _check_image(_read_or_refuse(read_image, path))


# --------------------------------------------------------------------------------------
# MOTChallenge tables
# --------------------------------------------------------------------------------------
_FIELD = st.one_of(
    st.integers(-3, 3).map(str), st.integers(-(2**70), 2**70).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.text(max_size=4),
)
_VALID = ("1,1,10.5,20,5,9,1,1,1.0\n2,1,11,21,5,9,1,1,0.5\n"
          "2,3,40,20,6,10,0.8,2,1\n")


def _check_table(table, columns):
    if table is None:
        return
    assert list(table.columns) == list(columns)
    if len(table):
        assert (table["frame"] >= 1).all()
        assert (table[["bb_width", "bb_height"]] >= 0).all().all()
    for c in ("frame", "id"):
        assert table[c].dtype == np.int64
        assert (table[c].abs() < 2**53).all()
    assert np.isfinite(table.select_dtypes("number").to_numpy(np.float64)).all()
    assert len(table.attrs["lines"]) == len(table)


_READERS = {"gt": (read_mot_gt, MOT_GT_COLUMNS),
            "results": (read_mot_results, MOT_RESULT_COLUMNS)}


@FUZZ
@given(rows=st.lists(st.lists(_FIELD, min_size=7, max_size=11), max_size=5),
       raw=st.binary(max_size=80), use_raw=st.booleans(),
       kind=st.sampled_from(["gt", "results"]))
def test_mot_tables(tmp_path, rows, raw, use_raw, kind):
    path = tmp_path / "gt.txt"
    if use_raw:
        path.write_bytes(raw)
    else:
        path.write_text("\n".join(",".join(r) for r in rows) + "\n")
    reader, columns = _READERS[kind]
    _check_table(_read_or_refuse(reader, path), columns)


@FUZZ
@given(edits=st.lists(st.tuples(st.integers(0, 2), st.integers(0, 9), _FIELD),
                      min_size=1, max_size=3),
       junk=st.lists(st.tuples(st.integers(0, 90), st.binary(min_size=1, max_size=3)),
                     max_size=2),
       kind=st.sampled_from(["gt", "results"]))
def test_valid_tables_with_mutated_fields(tmp_path, edits, junk, kind):
    rows = [line.split(",") for line in _VALID.splitlines()]
    if kind == "results":
        rows = [r[:7] + ["-1", "-1", "-1"] for r in rows]
    for row, column, value in edits:
        rows[row][column % len(rows[row])] = value
    data = "".join(",".join(r) + "\n" for r in rows).encode("utf-8", "surrogatepass")
    for where, value in junk:
        data = data[:where] + value + data[where:]
    path = tmp_path / "gt.txt"
    path.write_bytes(data)
    reader, columns = _READERS[kind]
    _check_table(_read_or_refuse(reader, path), columns)


# --------------------------------------------------------------------------------------
# Sequence folders and image folders
# --------------------------------------------------------------------------------------
_KEYS = ["name", "imDir", "frameRate", "seqLength", "imWidth", "imHeight", "imExt"]
_GOOD = ["s", "img1", "30", "3", "16", "12", ".png"]


@pytest.fixture(scope="module")
def small_tour(tmp_path_factory, pngs):
    folder = tmp_path_factory.mktemp("seq") / "s"
    (folder / "img1").mkdir(parents=True)
    for i in (1, 2, 3):
        (folder / "img1" / f"{i:06d}.png").write_bytes(pngs[8])
    return folder


def _check_tour(tour):
    if tour is None:
        return
    assert [r.frame for r in tour.frames] == list(range(1, len(tour.frames) + 1))
    assert np.isfinite(tour.frame_rate) and tour.frame_rate > 0
    for r in tour.frames:
        _check_image(r.image, (12, 16))


@FUZZ
@given(values=st.fixed_dictionaries({k: st.one_of(st.just(v), st.text(max_size=6))
                                     for k, v in zip(_KEYS, _GOOD, strict=True)}),
       drop=st.sets(st.sampled_from(_KEYS), max_size=2),
       garbage=st.text(max_size=40) | st.binary(max_size=20),
       reader=st.sampled_from([read_tour, open_tour]))
def test_seqinfo(tmp_path, small_tour, values, drop, garbage, reader):
    folder = shutil.copytree(small_tour, tmp_path / "s", dirs_exist_ok=True)
    lines = ["[Sequence]", *(f"{k}={v}" for k, v in values.items() if k not in drop)]
    text = ("\n".join(lines) + "\n").encode("utf-8", "surrogatepass")
    if isinstance(garbage, str):
        garbage = garbage.encode("utf-8", "surrogatepass")
    (folder / "seqinfo.ini").write_bytes(text + garbage)
    _check_tour(_read_or_refuse(reader, folder))


_NAME = st.text(st.characters(blacklist_characters="/\x00", codec="utf-8"), max_size=8)


@FUZZ
@given(names=st.lists(st.tuples(_NAME, st.sampled_from([".png", ".PNG", ".tif", ""])),
                      max_size=4, unique=True),
       content=st.sampled_from([b"", b"junk", None]),
       in_sequence=st.booleans())
def test_frame_file_names(tmp_path, small_tour, pngs, names, content, in_sequence):
    """Files of any name beside the three frames of a sequence or an image folder."""
    folder = shutil.copytree(small_tour, tmp_path / "s", dirs_exist_ok=True)
    for stem, ext in names:
        try:
            (folder / "img1" / f"{stem}{ext}").write_bytes(
                pngs[8] if content is None else content)
        except OSError:  # a name the file system refuses ("", "." or "..")
            continue
    if in_sequence:
        (folder / "seqinfo.ini").write_text(
            "[Sequence]\n" + "".join(f"{k}={v}\n" for k, v in zip(_KEYS, _GOOD,
                                                                    strict=True)))
        tour = _read_or_refuse(read_tour, folder)
        if tour is not None:
            assert [r.frame for r in tour.frames] == [1, 2, 3]
        return
    tour = _read_or_refuse(read_image_folder, folder / "img1", folder)
    if tour is not None:
        frames = [r.frame for r in tour.frames]
        assert frames == sorted(set(frames)) and frames[0] >= 1
        for r in tour.frames:
            _check_image(_read_or_refuse(lambda rec: rec.image, r, folder), (12, 16))
