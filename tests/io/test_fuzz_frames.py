"""Fuzz the frame readers: only the project's errors, naming the file, escape."""

import os
import shutil

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tunnelsense.exceptions import InputFormatError
from tunnelsense.io import read_image, read_mot_gt, read_mot_results, read_tour

FUZZ = settings(max_examples=int(os.environ.get("TUNNELSENSE_FUZZ_EXAMPLES", 60)),
                deadline=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture])


@pytest.fixture(scope="module")
def pngs():
    rng = np.random.default_rng(0)
    return {
        bits: cv2.imencode(".png", rng.integers(0, 2**bits, (12, 16)).astype(
            np.uint8 if bits == 8 else np.uint16))[1].tobytes()
        for bits in (8, 16)
    }


def _check_refusal(exc, path):
    assert isinstance(exc, InputFormatError | FileNotFoundError), repr(exc)
    assert str(path) in str(exc)


@FUZZ
@given(data=st.binary(max_size=600))
def test_random_bytes_as_an_image(tmp_path, data):
    path = tmp_path / "f.png"
    path.write_bytes(data)
    try:
        image = read_image(path)
    except Exception as exc:  # noqa: BLE001 - the test is which ones escape
        _check_refusal(exc, path)
        return
    assert image.ndim == 2 and image.dtype in (np.uint8, np.uint16)


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
    try:
        image = read_image(path)
    except Exception as exc:  # noqa: BLE001
        _check_refusal(exc, path)
        return
    assert image.shape == (12, 16) and image.dtype in (np.uint8, np.uint16)


_FIELD = st.one_of(
    st.integers(-3, 3).map(str), st.integers(-(2**70), 2**70).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.text(max_size=4),
)


@FUZZ
@given(rows=st.lists(st.lists(_FIELD, min_size=7, max_size=11), max_size=5),
       raw=st.binary(max_size=80), use_raw=st.booleans(),
       reader=st.sampled_from([read_mot_gt, read_mot_results]))
def test_mot_tables(tmp_path, rows, raw, use_raw, reader):
    path = tmp_path / "gt.txt"
    if use_raw:
        path.write_bytes(raw)
    else:
        path.write_text("\n".join(",".join(r) for r in rows) + "\n")
    try:
        table = reader(path)
    except Exception as exc:  # noqa: BLE001
        _check_refusal(exc, path)
        return
    assert (table["frame"] >= 1).all() if len(table) else True
    numbers = table.select_dtypes("number").to_numpy(np.float64)
    assert np.isfinite(numbers).all()


_KEYS = ["name", "imDir", "frameRate", "seqLength", "imWidth", "imHeight", "imExt"]


@pytest.fixture(scope="module")
def small_tour(tmp_path_factory, pngs):
    folder = tmp_path_factory.mktemp("seq") / "s"
    (folder / "img1").mkdir(parents=True)
    for i in (1, 2, 3):
        (folder / "img1" / f"{i:06d}.png").write_bytes(pngs[8])
    return folder


@FUZZ
@given(values=st.fixed_dictionaries({k: st.one_of(st.just(v), st.text(max_size=6))
                                     for k, v in zip(_KEYS, ["s", "img1", "30", "3",
                                                             "16", "12", ".png"],
                                                     strict=True)}),
       drop=st.sets(st.sampled_from(_KEYS), max_size=2),
       garbage=st.text(max_size=40))
def test_seqinfo(tmp_path, small_tour, values, drop, garbage):
    folder = shutil.copytree(small_tour, tmp_path / "s", dirs_exist_ok=True)
    lines = ["[Sequence]", *(f"{k}={v}" for k, v in values.items() if k not in drop)]
    (folder / "seqinfo.ini").write_text("\n".join(lines) + "\n" + garbage)
    try:
        tour = read_tour(folder)
    except Exception as exc:  # noqa: BLE001
        _check_refusal(exc, folder)
        return
    assert [r.frame for r in tour.frames] == list(range(1, len(tour.frames) + 1))
    assert tour.frame_rate > 0
