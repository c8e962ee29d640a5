import numpy as np
import pytest
from sklearn.base import clone
from sklearn.ensemble import AdaBoostClassifier
from sklearn.tree import DecisionTreeClassifier
from sklearn.utils.estimator_checks import parametrize_with_checks

from tunnelsense import FrameRecord, FrameSequence
from tunnelsense.tunnel import WeightedAdaBoost, box_histograms, centres_in_boxes
from tunnelsense.tunnel._appearance import stump_decision
from tunnelsense.tunnel._contrast import core_boxes
from tunnelsense.tunnel._stumps import WeightedAdaBoostCore
from tunnelsense.utils import record_stage_checks


@parametrize_with_checks(
    [WeightedAdaBoost(n_estimators=10), WeightedAdaBoost(positive_weight=1.0),
     WeightedAdaBoostCore(n_estimators=10)]
)
def test_sklearn_compatible(estimator, check):
    check(estimator)


def _histograms(rng, n, bins=32):
    X = rng.dirichlet(np.ones(bins), n)
    y = ((X[:, 3] + X[:, 7] + rng.normal(0, 0.02, n)) > 0.07).astype(int)
    return X, y


@pytest.mark.parametrize("positive_weight", [1.0, 7.0])
def test_same_stumps_and_decisions_as_sklearn(global_random_seed, positive_weight):
    rng = np.random.default_rng(global_random_seed)
    X, y = _histograms(rng, 1500)
    weights = np.where(y == 1, positive_weight, 1.0)
    sk = AdaBoostClassifier(
        DecisionTreeClassifier(max_depth=1), n_estimators=30, random_state=0
    ).fit(X, y, sample_weight=weights)
    ours = WeightedAdaBoost(n_estimators=30, positive_weight=positive_weight).fit(X, y)
    assert np.array_equal(
        ours.stump_features_, [e.tree_.feature[0] for e in sk.estimators_]
    )
    theirs = np.array([e.tree_.threshold[0] for e in sk.estimators_])
    # the same split of the training rows; where between two training values the
    # threshold lies is scikit-learn's choice (1.6 put one 1e-5 away from 1.9's)
    np.testing.assert_allclose(ours.stump_thresholds_, theirs, rtol=0, atol=1e-4)
    X_test, _ = _histograms(rng, 4000)
    # values exactly on the thresholds both place alike, in float32, probe the
    # comparison
    same = np.flatnonzero(ours.stump_thresholds_ == theirs)
    X_test[same, ours.stump_features_[same]] = ours.stump_thresholds_[same].astype(
        np.float32)
    assert np.array_equal(ours.predict(X_test), sk.predict(X_test))
    np.testing.assert_allclose(
        ours.decision_function(X_test), sk.decision_function(X_test), atol=1e-12
    )


@pytest.mark.parametrize("n_classes", [2, 3, 9])
def test_stump_fitter_finds_fit_stumps_split(global_random_seed, n_classes):
    # samme fits its stumps with _StumpFitter (sort order and candidate splits
    # found once): the same split as fit_stump for every weighting, ties included
    from tunnelsense.tunnel._stumps import FEATURE_THRESHOLD, _StumpFitter, fit_stump

    rng = np.random.default_rng(global_random_seed)
    n = 300
    X = np.column_stack([
        rng.normal(size=n),                      # continuous
        rng.integers(0, 4, n) / 3.0,             # few distinct values (histogram bins)
        np.full(n, 0.5),                         # constant: no split
        rng.integers(0, 2, n).astype(float),     # two values
    ]).astype(np.float32)
    y = rng.integers(0, n_classes, n)
    X[:, 0] += y  # an informative feature
    order = np.argsort(X, axis=0, kind="stable")
    values = np.take_along_axis(X, order, axis=0)
    onehot = (y[:, None] == np.arange(n_classes)).astype(np.float64)
    v = values.astype(np.float64)
    distinct = v[1:] > v[:-1] + FEATURE_THRESHOLD
    fitter = _StumpFitter(values, order, onehot, distinct)
    for weights in (np.full(n, 1.0 / n), rng.dirichlet(np.ones(n)),
                    np.where(np.arange(n) < 5, 1.0, 1e-12)):
        assert fitter.fit(weights) == fit_stump(values, order, onehot, weights, distinct)
    pure = np.zeros_like(onehot)  # one class only: no split
    pure[:, -1] = 1.0
    got = _StumpFitter(values, order, pure, distinct).fit(np.ones(n))
    assert got == fit_stump(values, order, pure, np.ones(n), distinct)
    assert got[1] == np.inf


def test_array_decision_equals_stump_by_stump_reference(global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    X, y = _histograms(rng, 600)
    y = y + (X[:, 0] > 0.06)  # three classes
    clf = WeightedAdaBoost(n_estimators=15).fit(X, y)
    K = len(clf.classes_)
    X_test, _ = _histograms(rng, 500)
    ref = sum(
        np.where(
            (np.where(X_test.astype(np.float32)[:, f] <= t, lft, rgt)[:, None] == np.arange(K)),
            w,
            -w / (K - 1),
        )
        for f, t, (lft, rgt), w in zip(
            clf.stump_features_, clf.stump_thresholds_, clf.stump_classes_, clf.stump_weights_,
            strict=True,
        )
    ) / clf.stump_weights_.sum()
    np.testing.assert_array_equal(clf.decision_function(X_test), ref)
    assert np.array_equal(clf.predict(X_test), clf.classes_[ref.argmax(1)])


def test_positive_weight_raises_recall_on_positives(global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    n_pos, n_neg = 150, 1500
    pos = rng.dirichlet(np.r_[np.ones(16), 1.2 * np.ones(16)] * 5, n_pos)
    neg = rng.dirichlet(np.r_[1.2 * np.ones(16), np.ones(16)] * 5, n_neg)
    X, y = np.vstack([pos, neg]), np.r_[np.ones(n_pos), np.zeros(n_neg)]
    even = WeightedAdaBoost(positive_weight=1.0).fit(X, y).predict(X)
    biased = WeightedAdaBoost(positive_weight=7.0).fit(X, y).predict(X)
    recall_even, recall_biased = even[y == 1].mean(), biased[y == 1].mean()
    assert recall_biased > recall_even
    assert biased[y == 0].mean() >= even[y == 0].mean()  # paid with false positives


def test_stump_decision_is_fast_path_of_predict():
    X = np.array([[0.1, 0.9], [0.6, 0.4]])
    d = stump_decision(
        X, np.array([0]), np.array([0.5]), np.array([1]), np.array([0]),
        np.array([2.0]), 2, 2.0,
    )
    np.testing.assert_array_equal(d, [2.0, -2.0])  # scikit-learn's binary SAMME range


# ------------------------------------------------------------------ frame mode
def _frame(frame, boxes, kinds, tour="t", rng=None):
    """A frame with indicator-like (bright, dark rim) and lamp-like (saturated) blobs."""
    rng = np.random.default_rng(frame) if rng is None else rng
    img = rng.normal(100, 3, (120, 160)).clip(0, 255).astype(np.uint8)
    for (left, top, w, h), kind in zip(boxes, kinds, strict=True):
        l0, t0 = int(left), int(top)
        if kind == "indicator":
            img[t0 : t0 + int(h), l0 : l0 + int(w)] = 175
        else:  # lamp: hot core with a halo in the band
            img[t0 - 3 : t0 + int(h) + 3, l0 - 3 : l0 + int(w) + 3] = 170
            img[t0 + 2 : t0 + int(h) - 2, l0 + 1 : l0 + int(w) - 1] = 255
    rec = FrameRecord(tour, frame, img, {"cluster_boxes": np.asarray(boxes, float).reshape(-1, 4)})
    gt = np.array([b for b, k in zip(boxes, kinds, strict=True) if k == "indicator"], float)
    return rec, gt.reshape(-1, 4)


def _frames(n=12, seed=0):
    rng = np.random.default_rng(seed)
    X, y = [], []
    for f in range(1, n + 1):
        boxes = [(20 + rng.integers(0, 20), 30, 8, 18), (100 + rng.integers(0, 20), 40, 10, 14)]
        rec, gt = _frame(f, boxes, ["indicator", "lamp"], rng=rng)
        X.append(rec)
        y.append(gt)
    return FrameSequence(X), y


def test_frame_mode_labels_clusters():
    X, y = _frames()
    ada = WeightedAdaBoost(n_estimators=10).fit(X, y)
    assert ada.n_clusters_fit_ == 24 and ada.n_positive_fit_ == 12
    out = ada.transform(X)
    assert len(out) == len(X)
    for r in out:
        assert r.payload["appearance"].dtype == bool
        assert r.payload["appearance"].tolist() == [True, False]
        assert r.payload["appearance_score"].shape == (2,)
        assert r.payload["cluster_histograms"].shape == (2, 32)
        np.testing.assert_allclose(r.payload["cluster_histograms"].sum(1), 1.0)


def test_frame_mode_errors():
    X, y = _frames(4)
    with pytest.raises(ValueError, match="requires y"):
        WeightedAdaBoost().fit(X)
    with pytest.raises(ValueError, match="positive and negative"):
        WeightedAdaBoost().fit(X, [np.empty((0, 4))] * 4)
    bare = [FrameRecord("t", 1, np.zeros((8, 8), np.uint8))]
    with pytest.raises(ValueError, match="MSTClusterer"):
        WeightedAdaBoost().fit(bare, [np.empty((0, 4))])
    tab = WeightedAdaBoost(n_estimators=3).fit(np.eye(4), [0, 1, 2, 3])
    with pytest.raises(ValueError, match="fitted on 2-D arrays"):
        tab.transform(X)
    fitted = WeightedAdaBoost(n_estimators=3).fit(X, y)
    with pytest.raises(TypeError, match="transform"):
        fitted.predict(X)


def test_empty_frames_pass_through():
    X, y = _frames(4)
    ada = WeightedAdaBoost(n_estimators=5).fit(X, y)
    empty = X[0].evolve(cluster_boxes=np.empty((0, 4)))
    out = ada.transform([empty])[0]
    assert out.payload["appearance"].shape == (0,)
    assert out.payload["cluster_histograms"].shape == (0, 32)


def test_box_histograms_and_margin():
    img = np.zeros((40, 40), np.uint8)
    img[10:30, 10:20] = 200
    tight = box_histograms(img, np.array([[10, 10, 10, 20.0]]), bins=4)
    np.testing.assert_allclose(tight, [[0, 0, 0, 1]])
    grown = box_histograms(img, np.array([[10, 10, 10, 20.0]]), bins=4, margin=0.25)
    assert 0 < grown[0, 0] < 1  # the rim of dark wall is in
    # clipped to the image
    edge = box_histograms(img, np.array([[-5, -5, 3, 3.0]]), bins=4)
    np.testing.assert_allclose(edge.sum(), 1.0)


def test_centres_in_boxes():
    gt = np.array([[0, 0, 10, 10.0]])
    boxes = np.array([[8, 8, 4, 4], [8, 8, 6, 6], [0, 0, 1, 1]], float)
    assert centres_in_boxes(boxes, gt).tolist() == [False, False, True]
    assert centres_in_boxes(boxes, np.empty((0, 4))).tolist() == [False] * 3


_X, _Y = _frames(6)


@pytest.mark.parametrize(
    "name, check", list(record_stage_checks(WeightedAdaBoost(n_estimators=5), _X, _Y))
)
def test_record_stage_checks(name, check):
    check()


@pytest.mark.parametrize("params", [{}, {"features": "invariant", "augment": 2},
                                    {"features": "invariant-any-shape", "augment": 2},
                                    {"features": "invariant", "augment": 2,
                                     "widest_sign": 1.25, "core": (0.7,)}])
def test_frame_mode_fit_transform_equals_fit_then_transform(params):
    """fit_transform scores the features of the fit without computing them again."""
    X, y = _frames(seed=3)
    a = WeightedAdaBoost(n_estimators=10, random_state=0, **params)
    b = clone(a)
    out_a = a.fit_transform(X, y)
    out_b = b.fit(X, y).transform(X)
    assert np.array_equal(a.stump_features_, b.stump_features_)
    for ra, rb in zip(out_a, out_b, strict=True):
        for key in ("appearance", "appearance_score", "cluster_histograms"):
            assert np.array_equal(ra.payload[key], rb.payload[key])
    assert any(r.payload["appearance"].any() for r in out_a)


def _sign_in_halo(frame=99):
    """An indicator (rows 40-57, columns 30-37) under a halo of two thirds of its
    contrast reaching above and beside it; the cluster's box spans both."""
    rng = np.random.default_rng(frame)
    img = rng.normal(100, 3, (120, 160)).clip(0, 255).astype(np.uint8)
    img[26:40, 24:44] = 150
    img[40:58, 30:38] = 175
    box = np.array([[24.0, 26.0, 20.0, 32.0]])
    return FrameRecord("t", frame, img, {"cluster_boxes": box})


def test_core_scores_the_sign_inside_a_halo():
    X, y = _frames()
    plain = WeightedAdaBoost(n_estimators=10).fit(X, y)
    cored = clone(plain).set_params(core=(0.5, 0.85)).fit(X, y)
    # training is the same: the cores are scored at transform only
    assert np.array_equal(plain.stump_thresholds_, cored.stump_thresholds_)
    rec = _sign_in_halo()
    s_box = plain.transform([rec])[0].payload["appearance_score"]
    s_core = cored.transform([rec])[0].payload["appearance_score"]
    # the core at 0.85 of the contrast is the sign's own rectangle, at 0.5 the
    # sign with the halo (the box)
    cores = core_boxes(rec.image, rec.payload["cluster_boxes"], fractions=(0.5, 0.85))
    np.testing.assert_array_equal(cores[0], [[24, 26, 20, 32], [30, 40, 8, 18]])
    sign = rec.evolve(cluster_boxes=np.array([[30.0, 40.0, 8.0, 18.0]]))
    s_sign = plain.transform([sign])[0].payload["appearance_score"]
    np.testing.assert_allclose(s_core, np.maximum(s_box, s_sign))
    # the better-scored rectangle is the cluster's box from here on
    boxes = cored.transform([rec])[0].payload["cluster_boxes"]
    expected = sign.payload["cluster_boxes"] if s_sign[0] > s_box[0] else rec.payload[
        "cluster_boxes"]
    np.testing.assert_array_equal(boxes, expected)
    # clusters of the training frames: a lamp stays negative, an indicator positive
    for r in cored.transform(X):
        assert r.payload["appearance"].tolist() == [True, False]


def test_core_must_be_fractions():
    X, y = _frames(4)
    for bad in [(), (0.5, 1.0), (0.0,), ("a",), ((0.5,),)]:
        with pytest.raises(ValueError, match="core must be"):
            WeightedAdaBoost(n_estimators=3, core=bad).fit(X, y)


def test_core_fit_transform_equals_fit_then_transform():
    X, y = _frames(seed=5)
    X = FrameSequence([*X, _sign_in_halo()])
    y = [*y, np.array([[30.0, 40.0, 8.0, 18.0]])]
    a = WeightedAdaBoost(n_estimators=10, core=(0.5, 0.7, 0.85))
    out_a = a.fit_transform(X, y)
    out_b = clone(a).fit(X, y).transform(X)
    for ra, rb in zip(out_a, out_b, strict=True):
        for key in ("appearance_score", "cluster_boxes"):
            assert np.array_equal(ra.payload[key], rb.payload[key])


def test_any_shape_features_leave_out_the_proportions():
    """``features="invariant-any-shape"``: the invariant features with the two log
    aspect ratios at 0, so no stump splits on a sign's proportions, and a square
    sign is judged on its intensities as an upright one is."""
    from tunnelsense.tunnel._appearance_features import _SHAPE_COLUMNS, _invariant_rows
    from tunnelsense.tunnel._invariant import box_patches

    X, y = _frames(seed=3)
    rec = X[0]
    rects = rec.payload["cluster_boxes"]
    patches = box_patches(rec.image, rects, 0.25)
    full = _invariant_rows(patches, rects[:, [3, 2]].tolist(), "invariant")
    free = _invariant_rows(patches, rects[:, [3, 2]].tolist(), "invariant-any-shape")
    shape = list(_SHAPE_COLUMNS)
    assert (full[:, shape] != 0).any() and (free[:, shape] == 0).all()
    rest = np.setdiff1d(np.arange(full.shape[1]), shape)
    assert np.array_equal(full[:, rest], free[:, rest])
    ada = WeightedAdaBoost(n_estimators=10, random_state=0,
                           features="invariant-any-shape", augment=2).fit(X, y)
    assert not np.isin(ada.stump_features_, shape).any()
    square, _ = _frame(50, [(20, 30, 14, 14), (100, 40, 10, 14)], ["indicator", "lamp"],
                       rng=np.random.default_rng(7))
    assert ada.transform([square])[0].payload["appearance"].tolist() == [True, False]


def test_widest_sign_gives_upright_and_square_signs_the_same_proportions():
    """``widest_sign``: the two log aspect ratios clipped from above at
    ``-log(widest_sign)``: an upright and a square sign get the same figures, a
    shape wider than ``widest_sign`` keeps its own; the other features unchanged."""
    from tunnelsense.tunnel._appearance_features import _SHAPE_COLUMNS, _invariant_rows
    from tunnelsense.tunnel._invariant import box_patches

    rec, _ = _frame(60, [(20, 30, 8, 18), (60, 30, 14, 14), (100, 40, 30, 10)],
                    ["indicator"] * 3, rng=np.random.default_rng(11))
    rects = rec.payload["cluster_boxes"]
    patches = box_patches(rec.image, rects, 0.25)
    full = _invariant_rows(patches, rects[:, [3, 2]].tolist(), "invariant")
    clipped = _invariant_rows(patches, rects[:, [3, 2]].tolist(), "invariant", 1.25)
    shape = list(_SHAPE_COLUMNS)
    # as measured: upright > 0, square about 0, wide < -log(1.25)
    assert full[0, shape[1]] > 0.5 and abs(full[1, shape[1]]) < 0.01
    assert (full[2, shape] < -np.log(1.25)).all()
    np.testing.assert_allclose(clipped[:2, shape], -np.log(1.25))
    np.testing.assert_array_equal(clipped[2, shape], full[2, shape])
    rest = np.setdiff1d(np.arange(full.shape[1]), shape)
    assert np.array_equal(full[:, rest], clipped[:, rest])
    # the machine sees the clipped figures: trained on upright signs only, no stump
    # threshold on the proportions lies above the clip
    X, y = _frames(seed=3)
    ada = WeightedAdaBoost(n_estimators=10, random_state=0, features="invariant",
                           widest_sign=1.25, augment=2).fit(X, y)
    on_shape = np.isin(ada.stump_features_, shape)
    assert (ada.stump_thresholds_[on_shape] < -np.log(1.25)).all()


@pytest.mark.parametrize("bad", [0.9, 0.0, -1.0])
def test_widest_sign_must_be_at_least_one(bad):
    X, y = _frames(4)
    with pytest.raises(ValueError, match="widest_sign"):
        WeightedAdaBoost(n_estimators=3, features="invariant", widest_sign=bad).fit(X, y)


def test_invariant_core_transform_frame_by_frame_or_at_once():
    """The invariant features of all frames' clusters and cores are scored in one
    call, by transform and by fit_transform (the clusters' features of the fit,
    the cores' computed): the same payloads as one frame at a time, with frames
    without clusters among them (in the middle and at the end)."""
    X, y = _frames(seed=6)
    empty = X[0].evolve(cluster_boxes=np.empty((0, 4)))
    X = FrameSequence([X[0], empty.evolve(), *X[1:], _sign_in_halo(), empty.evolve()])
    y = [y[0], np.empty((0, 4)), *y[1:], np.array([[30.0, 40.0, 8.0, 18.0]]),
         np.empty((0, 4))]
    X = FrameSequence(r if i != len(X) - 1 else FrameRecord("t", 100, r.image, r.payload)
                      for i, r in enumerate(X))
    a = WeightedAdaBoost(n_estimators=10, features="invariant", core=(0.5, 0.7, 0.85),
                         random_state=0)
    out_a = a.fit_transform(X, y)
    b = clone(a).fit(X, y)
    out_b = b.transform(X)
    out_c = [b.transform([r])[0] for r in X]
    assert any(len(r.payload["cluster_boxes"]) == 0 for r in out_b)
    for ra, rb, rc in zip(out_a, out_b, out_c, strict=True):
        assert ra.payload.keys() == rb.payload.keys() == rc.payload.keys()
        for key in ("appearance", "appearance_score", "cluster_histograms",
                    "cluster_boxes"):
            for other in (rb, rc):
                assert ra.payload[key].dtype == other.payload[key].dtype
                assert np.array_equal(ra.payload[key], other.payload[key])
