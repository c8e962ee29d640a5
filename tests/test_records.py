import pickle

import numpy as np
import pandas as pd
import pytest
from sklearn.model_selection import GroupKFold
from sklearn.utils import _safe_indexing

from tunnelsense import (
    FrameRecord,
    FrameSequence,
    LaserGeometry,
    Run,
    ScanSequence,
    Tour,
    check_frames,
    check_scans,
    to_xy,
)
from tunnelsense.exceptions import InputFormatError


def _tour(name, n=4, shape=(6, 8)):
    images = np.arange(n * shape[0] * shape[1], dtype=np.uint8).reshape(n, *shape)
    gt = pd.DataFrame(
        {
            "frame": [1, 1, 3],
            "id": [1, 2, 1],
            "bb_left": [1.0, 2, 3],
            "bb_top": [1.0, 2, 3],
            "bb_width": [2.0, 2, 2],
            "bb_height": [3.0, 10, 3],
            "conf": 1.0,
            "class": [1, 2, 1],
            "visibility": 1.0,
        }
    )
    return Tour.from_array(name, images, gt)


def test_frame_record_evolve_keeps_identity_and_image():
    r = FrameRecord("t", 3, np.ones((2, 2), np.uint8), {"a": 1})
    r2 = r.evolve(b=2)
    assert r2.key == ("t", 3)
    assert r2.payload == {"a": 1, "b": 2}
    assert r.payload == {"a": 1}
    assert r2.image is r.image


def test_sequence_indexing_like_sklearn():
    X = _tour("a").frames + _tour("b").frames
    assert len(X) == 8
    assert isinstance(X[0], FrameRecord)
    sub = X[np.array([1, 5])]
    assert isinstance(sub, FrameSequence)
    assert [r.key for r in sub] == [("a", 2), ("b", 2)]
    assert [r.key for r in X[X.groups == "b"]] == [("b", i) for i in range(1, 5)]
    assert len(X[2:4]) == 2
    # what GridSearchCV does to a container without .shape: a plain list
    fold = _safe_indexing(X, np.array([0, 7]))
    assert [r.key for r in fold] == [("a", 1), ("b", 4)]
    with pytest.raises(IndexError, match="boolean index"):
        X[np.array([True, False])]
    with pytest.raises(IndexError, match="1-D array of ints"):
        X[np.array([0.5])]


def test_sequence_rejects_foreign_records():
    with pytest.raises(TypeError, match="element 1 is int"):
        FrameSequence([FrameRecord("t", 1, np.zeros((1, 1), np.uint8)), 3])


def test_pickle_round_trip_of_sequence():
    X = _tour("a").frames
    X2 = pickle.loads(pickle.dumps(X))
    assert [r.key for r in X2] == [r.key for r in X]
    assert np.array_equal(X2[2].image, X[2].image)


def test_to_xy_boxes_groups_and_group_kfold():
    X, y, groups = to_xy([_tour("a"), _tour("b", n=3)])
    assert len(X) == len(y) == len(groups) == 7
    assert y[0].shape == (1, 4) and y[1].shape == (0, 4) and y[2].shape == (1, 4)
    assert np.array_equal(y[0], [[1.0, 1.0, 2.0, 3.0]])
    for train, test in GroupKFold(n_splits=2).split(X, y, groups):
        assert set(groups[train]).isdisjoint(groups[test])
    tall = _tour("a").boxes(classes=(1, 2), min_height=5)
    assert [len(b) for b in tall] == [1, 0, 0, 0]


def test_to_xy_errors():
    with pytest.raises(ValueError, match="distinct names"):
        to_xy([_tour("a"), _tour("a")])
    with pytest.raises(ValueError, match="at least one"):
        to_xy([])


def test_check_frames_accepts_lists_and_validates_y():
    X = _tour("a").frames
    records, y = check_frames(list(X), [np.zeros((0, 4))] * 4)
    assert len(records) == 4 and y[0].shape == (0, 4)
    records, y = check_frames(X, [[]] * 4)
    assert y[3].shape == (0, 4)
    with pytest.raises(TypeError, match="X must be a sequence of FrameRecord"):
        check_frames(np.zeros((4, 6, 8)))
    with pytest.raises(TypeError, match="element 1 is str"):
        check_frames([X[0], "frame"])
    with pytest.raises(ValueError, match="y has 3 entries but X has 4 frames"):
        check_frames(X, [np.zeros((0, 4))] * 3)
    with pytest.raises(ValueError, match=r"y\[1\] must have shape \(k, 4\)"):
        check_frames(X, [np.zeros((0, 4)), np.zeros((2, 3)), [], []])
    with pytest.raises(ValueError, match=r"y\[0\] contains NaN"):
        check_frames(X, [[[np.nan, 0, 1, 1]], [], [], []])


def _run(name="r", n=5):
    g = LaserGeometry(-1.2, np.radians(0.5), 0.05, 8.191, 2.0)
    gt = pd.DataFrame(
        {
            "id": [7, 8],
            "first_scan": [1, 3],
            "last_scan": [2, 9],
            "label": ["parked", "passing"],
        }
    )
    return Run.from_arrays(name, np.full((n, 10), 3.0), np.arange(n) / 75.0, g, gt)


def test_run_targets_and_check_scans():
    run = _run()
    t = run.targets()
    assert [x.tolist() for x in t] == [[], [[7, 1]], [[7, 1]], [[8, 2]], [[8, 2]]]
    X, y, groups = to_xy([run, _run("s")])
    records, y = check_scans(X, y)
    assert len(records) == 10 and y[1].dtype == np.int64
    assert isinstance(X, ScanSequence)
    with pytest.raises(ValueError, match="stamps must have shape"):
        ScanSequence.from_arrays(np.zeros((3, 4)), np.zeros(2), run.geometry)
    with pytest.raises(TypeError, match="ScanRecord"):
        check_scans(_tour("a").frames)


def test_a_tour_s_frames_carry_its_frame_rate(tmp_path):
    from tunnelsense.io import open_tour, write_tour

    images = np.zeros((3, 8, 8), np.uint8)
    tour = Tour.from_array("a", images, frame_rate=9)
    assert [r.payload["frame_rate"] for r in tour.frames] == [9.0] * 3
    X, _, _ = to_xy([tour, Tour.from_array("b", images)])
    assert [r.payload["frame_rate"] for r in X] == [9.0] * 3 + [30.0] * 3
    assert [r.payload["frame_rate"] for r in X[[1, 4]]] == [9.0, 30.0]  # a split
    # read back from disk: the rate of seqinfo.ini
    write_tour(tour, tmp_path / "a")
    assert {r.payload["frame_rate"] for r in open_tour(tmp_path / "a").frames} == {9.0}
    # a frame array of a user's carries none
    assert "frame_rate" not in FrameSequence.from_array(images)[0].payload


def test_sample_in_time_keeps_every_kth_frame_of_each_tour_as_a_slower_recording():
    """A 30 fps tour with a gap (frames 8 and 9 lost) and a 15 fps tour, sampled at 6
    frames a second: every 5th and every 2nd frame by number, renumbered as a
    recording at 6 and 7.5 fps (the gap stays one), targets and tours aligned; the
    images are the same objects (nothing decoded)."""
    from tunnelsense._records._sampling import sample_in_time

    image = np.zeros((2, 2), np.uint8)
    a = [FrameRecord("a", f, image, {"frame_rate": 30.0})
         for f in range(3, 25) if f not in (8, 9)]
    b = [FrameRecord("b", f, image, {"frame_rate": 15.0}) for f in range(1, 6)]
    X = a + b
    y = [(r.tour, r.frame) for r in X]
    groups = [0] * len(a) + [1] * len(b)
    Xs, ys, gs = sample_in_time(X, y, groups, 6.0)
    assert ys == [("a", 3), ("a", 13), ("a", 18), ("a", 23), ("b", 1), ("b", 3),
                  ("b", 5)]
    assert [(r.tour, r.frame) for r in Xs] == [("a", 1), ("a", 3), ("a", 4), ("a", 5),
                                               ("b", 1), ("b", 2), ("b", 3)]
    assert [r.payload["frame_rate"] for r in Xs] == [6.0] * 4 + [7.5] * 3
    assert gs == [0, 0, 0, 0, 1, 1, 1]
    assert all(r.source is image for r in Xs)
    # a rate at or above the tour's keeps every frame as it is
    Xs, ys, _ = sample_in_time(b, list(range(5)), [0] * 5, 15.0)
    assert Xs == b and ys == list(range(5))
    assert sample_in_time(X, y, groups, None) == (X, y, groups)
    for bad in (0.0, -1.0, float("nan"), float("inf"), "6", True):
        with pytest.raises(ValueError, match="sample_rate must be"):
            sample_in_time(X, y, groups, bad)
    Xs, _, _ = sample_in_time(X, y, groups, np.float32(6.0))  # any real number
    assert [r.frame for r in Xs] == [1, 3, 4, 5, 1, 2, 3]
    # no frame rate: no time to sample in
    bare = [FrameRecord("c", f, image, {}) for f in range(1, 6)]
    with pytest.raises(InputFormatError, match="'c'.*no frame rate"):
        sample_in_time(bare, list(range(5)), [0] * 5, 6.0)
