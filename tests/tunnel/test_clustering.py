import pickle

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.cluster.hierarchy import fcluster, single
from scipy.spatial.distance import pdist
from sklearn.utils.estimator_checks import parametrize_with_checks

from tunnelsense import FrameRecord, FrameSequence
from tunnelsense.tunnel import MSTClusterer, cluster_boxes, mst_partition, region_boxes
from tunnelsense.tunnel._mst import (
    DENSE_MAX_POINTS,
    MSTClustererCore,
    _delaunay_partition,
    _pair_bound,
    _pair_partition,
)
from tunnelsense.utils import record_stage_checks, sklearn_api_checks


def canonical(labels):
    """Relabel a partition by first occurrence."""
    _, first, inverse = np.unique(labels, return_index=True, return_inverse=True)
    rank = np.empty(len(first), dtype=np.intp)
    rank[np.argsort(first)] = np.arange(len(first))
    return rank[inverse.reshape(-1)]


def scipy_partition(points, cut):
    if len(points) == 1:
        return np.zeros(1, dtype=np.intp)
    # single(pdist(points)) is single(points) without SciPy's guess whether a square
    # observation matrix is a distance matrix
    return canonical(fcluster(single(pdist(points)), cut, criterion="distance"))


@parametrize_with_checks([MSTClusterer(), MSTClusterer(cut=0.5), MSTClustererCore()])
def test_sklearn_compatible(estimator, check):
    check(estimator)


# ------------------------------------------------------------------ property tests
coords = st.floats(-200, 200, allow_nan=False, allow_infinity=False)


@given(
    points=st.lists(st.tuples(coords, coords), min_size=1, max_size=60),
    cut=st.floats(0.5, 80),
)
def test_random_points_match_scipy(points, cut):
    P = np.array(points, dtype=np.float64)
    assert np.array_equal(mst_partition(P, cut), scipy_partition(P, cut))


@given(
    centres=st.lists(st.tuples(coords, coords), min_size=1, max_size=6),
    n_per=st.integers(1, 25),
    spread=st.floats(0.5, 40),
    seed=st.integers(0, 2**32 - 1),
    cut=st.sampled_from([10.0, 40.0]),
)
def test_clustered_points_match_scipy(centres, n_per, spread, seed, cut):
    rng = np.random.default_rng(seed)
    P = np.concatenate([rng.normal(c, spread, (n_per, 2)) for c in centres])
    rng.shuffle(P)
    assert np.array_equal(mst_partition(P, cut), scipy_partition(P, cut))


@given(
    points=st.lists(
        st.tuples(st.integers(0, 100), st.integers(0, 100)), min_size=1, max_size=40
    ),
    repeats=st.lists(st.integers(0, 39), max_size=40),
    cut=st.sampled_from([0.0, 6.0, 7.0, 40.0]),
)
def test_duplicated_points_match_scipy(points, repeats, cut):
    P = np.array(points, dtype=np.float64)
    P = np.concatenate([P, P[[r % len(P) for r in repeats]]])
    labels = mst_partition(P, cut)
    assert np.array_equal(labels, scipy_partition(P, cut))
    # identical positions share a cluster
    _, inverse = np.unique(P, axis=0, return_inverse=True)
    for g in np.unique(inverse):
        assert len(set(labels[inverse.reshape(-1) == g])) == 1


@given(
    seed=st.integers(0, 2**32 - 1),
    kind=st.sampled_from(["uniform", "grid", "collinear", "duplicated", "clustered"]),
    n=st.integers(DENSE_MAX_POINTS + 1, 1500),
)
def test_large_sets_match_scipy(seed, kind, n):
    """Above the dense threshold: KD-tree pairs and Delaunay edges both exact."""
    rng = np.random.default_rng(seed)
    if kind == "uniform":
        P = rng.uniform(0, 40 * np.sqrt(n), (n, 2))
    elif kind == "grid":  # many co-circular points: Delaunay ties
        g = np.stack(np.meshgrid(np.arange(60) * 6, np.arange(60) * 7), -1).reshape(-1, 2)
        P = g[rng.choice(len(g), n, replace=False)].astype(float)
    elif kind == "collinear":  # Delaunay fails: KD-tree fallback
        t = rng.uniform(0, 30 * n, n)
        P = np.column_stack([t, 0.5 * t + 3])
    elif kind == "duplicated":
        P = rng.integers(0, 30 * int(np.sqrt(n)), (n // 3, 2)).astype(float)
        P = P[rng.integers(0, len(P), n)]
    else:
        c = rng.uniform(0, 2000, (8, 2))
        P = c[rng.integers(0, 8, n)] + rng.normal(0, 25, (n, 2))
    for cut in (6.0, 40.0):
        expected = scipy_partition(P, cut)
        assert np.array_equal(mst_partition(P, cut), expected)
        assert np.array_equal(canonical(_delaunay_partition(P, cut)), expected)
        assert np.array_equal(canonical(_pair_partition(P, cut)), expected)


def test_dense_sets_take_the_delaunay_path(global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    blob = np.round(rng.normal(0, 8, (2500, 2)))  # dense, many duplicates
    P = np.concatenate([blob, rng.uniform(-1000, 1000, (500, 2))])
    rng.shuffle(P)
    assert _pair_bound(P, 10.0) > max(30 * len(P), 2e6)  # the Delaunay path
    assert np.array_equal(mst_partition(P, 10.0), scipy_partition(P, 10.0))


def test_three_dimensional_points_match_scipy(global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    for n in (50, 600):
        P = rng.uniform(0, 100, (n, 3))
        assert np.array_equal(mst_partition(P, 12.0), scipy_partition(P, 12.0))


def test_labels_numbered_by_first_occurrence():
    P = np.array([[500.0, 0], [0, 0], [500, 30], [0, 100], [20, 0]])
    assert mst_partition(P, 40).tolist() == [0, 1, 0, 2, 1]
    assert mst_partition(np.empty((0, 2)), 40).shape == (0,)


def test_tabular_fit_predict_and_transform():
    X = np.array([[0.0, 0], [0, 30], [0, 100], [0, 100]])
    est = MSTClusterer(cut=40).fit(X)
    assert est.labels_.tolist() == [0, 0, 1, 1]
    assert est.n_clusters_ == 2
    assert MSTClusterer(cut=40).fit_predict(X).tolist() == [0, 0, 1, 1]
    D = est.transform(np.array([[0.0, 40], [3, 104]]))
    np.testing.assert_allclose(D, [[10.0, 60.0], [np.hypot(3, 74), 5.0]])


def test_fit_predict_rejects_records():
    rec = FrameRecord("t", 1, np.zeros((8, 8), np.uint8), {"keypoints": np.zeros((0, 3))})
    with pytest.raises(TypeError, match="fit_transform"):
        MSTClusterer().fit_predict([rec])


# ------------------------------------------------------------------ frame mode
def keypoint_frames(seed, n_frames=4):
    rng = np.random.default_rng(seed)
    records = []
    for f in range(n_frames):
        n = int(rng.integers(0, 60))
        rows = rng.integers(0, 69, n) * 7
        cols = rng.integers(0, 107, n) * 6
        kp = np.column_stack([rows, cols, rng.integers(160, 191, n)]).astype(np.int32)
        order = np.lexsort((kp[:, 1], kp[:, 0]))
        kp = np.unique(kp[order], axis=0)
        records.append(FrameRecord("syn", f + 1, np.zeros((480, 640), np.uint8), {"keypoints": kp}))
    return FrameSequence(records)


def test_frame_payload_contract(global_random_seed):
    X = keypoint_frames(global_random_seed)
    out = MSTClusterer().fit(X).transform(X)
    for r_in, r in zip(X, out, strict=True):
        kp = r_in.payload["keypoints"]
        labels = r.payload["cluster_labels"]
        boxes = r.payload["cluster_boxes"]
        assert labels.dtype == np.intp and labels.shape == (len(kp),)
        assert boxes.dtype == np.float64 and boxes.shape == (len(np.unique(labels)), 4)
        assert np.array_equal(labels, scipy_partition(kp[:, :2].astype(float), 40.0)) or (
            len(kp) == 0
        )
        for c, (left, top, width, height) in enumerate(boxes):
            member = kp[labels == c]
            assert left == member[:, 1].min() and top == member[:, 0].min()
            assert left + width - 1 == member[:, 1].max()
            assert top + height - 1 == member[:, 0].max()
        assert np.array_equal(r.payload["keypoints"], kp)


def test_single_keypoint_box_is_one_pixel():
    boxes = cluster_boxes(np.array([70]), np.array([300]), np.array([0]))
    assert boxes.tolist() == [[300.0, 70.0, 1.0, 1.0]]


def test_empty_frame():
    rec = FrameRecord("t", 1, np.zeros((8, 8), np.uint8), {"keypoints": np.empty((0, 3), np.int32)})
    out = MSTClusterer().fit_transform([rec])[0]
    assert out.payload["cluster_labels"].shape == (0,)
    assert out.payload["cluster_boxes"].shape == (0, 4)


def test_missing_keypoints_is_a_clear_error():
    X = FrameSequence.from_array(np.zeros((2, 8, 8), np.uint8))
    with pytest.raises(ValueError, match="IntensityKeypointSampler"):
        MSTClusterer().fit(X)


def test_pickle_round_trip_tabular():
    X = np.random.default_rng(0).uniform(0, 300, (50, 2))
    est = MSTClusterer().fit(X)
    again = pickle.loads(pickle.dumps(est))
    assert np.array_equal(again.transform(X), est.transform(X))


_X = keypoint_frames(0, n_frames=3)
_Y = [np.empty((0, 4))] * 3


@pytest.mark.parametrize("name, check", list(record_stage_checks(MSTClusterer(), _X, _Y)))
def test_record_stage_checks(name, check):
    check()


@pytest.mark.parametrize("name, check", list(sklearn_api_checks(MSTClusterer())))
def test_sklearn_api_checks(name, check):
    check()


def _sign_frame(seed, top=100, left=200, height=16, width=6):
    """A noisy frame with one in-band sign and an in-band blob far away."""
    rng = np.random.default_rng(seed)
    img = rng.normal(100, 3, (240, 320))
    img[top : top + height, left : left + width] = rng.normal(175, 3, (height, width))
    img[20:30, 20:40] = 176  # another in-band object, in no cluster's reach
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def test_region_box_is_the_sign_around_its_keypoints(global_random_seed):
    img = _sign_frame(global_random_seed)
    # keypoints of the 7 x 6 grid that fall on the sign (rows 105, 112; column 204)
    rows, cols = np.array([105, 112]), np.array([204, 204])
    labels = np.zeros(2, np.intp)
    keypoint_box = cluster_boxes(rows, cols, labels)
    assert keypoint_box.tolist() == [[204.0, 105.0, 1.0, 8.0]]
    box = region_boxes(img, rows, cols, labels, keypoint_box, (160, 190))
    assert box.tolist() == [[200.0, 100.0, 6.0, 16.0]]
    # one keypoint suffices; the same sign gives the same box
    one = cluster_boxes(rows[:1], cols[:1], labels[:1])
    again = region_boxes(img, rows[:1], cols[:1], labels[:1], one, (160, 190))
    assert again.tolist() == box.tolist()


def test_region_box_stays_within_reach_and_contains_the_keypoints():
    img = np.full((100, 100), 175, np.uint8)  # everything in band
    box = region_boxes(img, np.array([50]), np.array([50]), np.array([0]),
                       np.array([[50.0, 50, 1, 1]]), (160, 190), reach=(14, 12))
    assert box.tolist() == [[38.0, 36.0, 25.0, 29.0]]
    # a keypoint whose pixel is out of band keeps its own box
    box = region_boxes(img, np.array([50]), np.array([50]), np.array([0]),
                       np.array([[50.0, 50, 1, 1]]), (0, 10))
    assert box.tolist() == [[50.0, 50.0, 1.0, 1.0]]


def test_frame_mode_region_boxes_use_the_samplers_band():
    from tunnelsense.tunnel import IntensityKeypointSampler

    X = FrameSequence.from_array(_sign_frame(0)[None])
    Xk = IntensityKeypointSampler().fit_transform(X)
    assert Xk[0].payload["keypoint_band"] == (160.0, 190.0)
    out = MSTClusterer(box="region").fit_transform(Xk)[0].payload
    assert sorted(out["cluster_boxes"].tolist()) == [[20.0, 20.0, 20.0, 10.0], [200.0, 100.0, 6.0, 16.0]]
    # the paper's keypoint rectangles are grid-quantized
    paper = MSTClusterer().fit_transform(Xk)[0].payload["cluster_boxes"]
    assert [204.0, 105.0, 1.0, 8.0] in paper.tolist()
    # an explicit band overrides the payload's; without either it is a clear error
    bare = [FrameRecord(r.tour, r.frame, r.image, {"keypoints": r.payload["keypoints"]}) for r in Xk]
    with pytest.raises(ValueError, match="keypoint_band"):
        MSTClusterer(box="region").fit(bare).transform(bare)
    out = MSTClusterer(box="region", band=(160, 190)).fit_transform(bare)[0].payload
    assert [200.0, 100.0, 6.0, 16.0] in out["cluster_boxes"].tolist()
    with pytest.raises(ValueError, match="reach"):
        MSTClusterer(box="region", reach=(1,)).fit_transform(Xk)
    with pytest.raises(ValueError, match="band"):
        MSTClusterer(box="region", band=(190, 160)).fit_transform(Xk)


def _light_and_far_sign(gain=1.0, offset=0.0):
    img = np.full((80, 160), 100.0)
    img[30:36, 20:26] = 220  # a bright light
    img[30:40, 70:74] = 150  # a dimmer sign 45 px away, chained to it by the cut
    img = np.clip(np.rint(gain * img + offset), 0, 255).astype(np.uint8)
    kp = np.array([[32, 22, 0], [32, 46, 0], [34, 71, 0]], dtype=np.int32)
    return FrameRecord("t", 1, img, {"keypoints": kp})


@pytest.mark.parametrize("gain, offset", [(1.0, 0.0), (0.7, -20.0), (1.3, 10.0)])
def test_separate_gives_a_far_sign_chained_to_a_light_its_own_cluster(gain, offset):
    rec = _light_and_far_sign(gain, offset)
    plain = MSTClusterer(box="contrast").fit_transform([rec])[0].payload
    # one cluster, whose contrast box is the light: the sign is in no box
    assert plain["cluster_labels"].tolist() == [0, 0, 0]
    np.testing.assert_array_equal(plain["cluster_boxes"], [[20, 30, 6, 6]])
    out = MSTClusterer(box="contrast", separate=True).fit_transform([rec])[0].payload
    assert out["cluster_labels"].tolist() == [0, 1, 1]
    # the light's box unchanged, the sign's own box around it (any gain and offset)
    np.testing.assert_array_equal(out["cluster_boxes"], [[20, 30, 6, 6], [70, 30, 4, 10]])


def test_separate_leaves_a_cluster_within_reach_of_its_box_alone():
    img = np.full((80, 160), 100, np.uint8)
    img[30:40, 20:26] = 200
    kp = np.array([[32, 22, 0], [45, 22, 0], [34, 35, 0]], dtype=np.int32)  # within reach
    rec = FrameRecord("t", 1, img, {"keypoints": kp})
    a = MSTClusterer(box="contrast").fit_transform([rec])[0].payload
    b = MSTClusterer(box="contrast", separate=True).fit_transform([rec])[0].payload
    assert b["cluster_labels"].tolist() == a["cluster_labels"].tolist() == [0, 0, 0]
    np.testing.assert_array_equal(a["cluster_boxes"], b["cluster_boxes"])
