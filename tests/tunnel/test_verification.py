import numpy as np
import pytest
from scipy.spatial.distance import cdist
from sklearn.base import clone
from sklearn.cluster import KMeans
from sklearn.utils.estimator_checks import parametrize_with_checks

from tunnelsense import FrameSequence, to_xy
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.tunnel import (
    IntensityKeypointSampler,
    KMeansHistogramVerifier,
    fit_kmeans,
    keypoint_descriptors,
    patch_histograms,
    rank_positive_centers,
)
from tunnelsense.tunnel._common import points_in_boxes
from tunnelsense.tunnel._kmeans import KMeansHistogramCore
from tunnelsense.tunnel._verification import verify_histograms
from tunnelsense.utils import record_stage_checks, sklearn_api_checks


@parametrize_with_checks(
    [
        KMeansHistogramVerifier(),
        KMeansHistogramVerifier(n_positive_clusters=3, n_negative_clusters=5, n_centers=2),
        KMeansHistogramCore(n_positive_clusters=3, n_negative_clusters=5, n_centers=2),
        KMeansHistogramVerifier(max_full_samples=5, batch_size=8, n_steps=5),
    ]
)
def test_sklearn_compatible(estimator, check):
    check(estimator)


def test_patch_histograms_match_numpy(global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    image = rng.integers(0, 256, (40, 50)).astype(np.uint8)
    rows = np.array([0, 5, 20, 39, 39])
    cols = np.array([0, 49, 25, 3, 49])
    H = patch_histograms(image, rows, cols, patch_size=5, bins=32)
    padded = np.pad(image, 2, mode="edge")
    for h, r, c in zip(H, rows, cols, strict=True):
        patch = padded[r : r + 5, c : c + 5]
        expected = np.histogram(patch, bins=32, range=(0, 256))[0] / 25
        np.testing.assert_allclose(h, expected, rtol=1e-6)
    assert H.dtype == np.float32
    np.testing.assert_allclose(H.sum(1), 1, rtol=1e-6)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("binning", ["hard", "linear"])
@pytest.mark.parametrize("context_size", [None, (9, 5)])
def test_contrast_copy_described_by_a_composed_table(global_random_seed, dtype, binning,
                                                     context_size):
    # the verifier describes a frame's contrast copies through composed bin tables,
    # without building them: the same descriptors as those of the copies
    from tunnelsense.tunnel._common import bin_lut
    from tunnelsense.tunnel._descriptors import compose_lut, descriptors_under_luts
    from tunnelsense.tunnel._intensity import background_levels, normalize_lut
    from tunnelsense.tunnel._verification import contrast_copy

    rng = np.random.default_rng(global_random_seed)
    top = 256 if dtype == np.uint8 else 9000
    image = rng.integers(0, top, (48, 64)).astype(dtype)
    rows, cols = rng.integers(0, 48, 30), rng.integers(0, 64, 30)
    kw = dict(patch_size=(7, 3), context_size=context_size, context_weight=1.5, bins=16)
    rng_ = None if dtype == np.uint8 else (0, 10000)
    lut = bin_lut(image.dtype, 16, rng_, binning)
    level, _ = background_levels(image)
    factors = [0.45, 1.0, 1.7, 2.2]
    luts = [lut] + [compose_lut(lut, normalize_lut(image.dtype, level, 1.0, level, f))
                    for f in factors]
    got = descriptors_under_luts(image, rows, cols, luts, **kw)
    want = np.concatenate([
        keypoint_descriptors(im, rows, cols, lut=lut, **kw)
        for im in [image, *(contrast_copy(image, f) for f in factors)]
    ])
    assert got.dtype == want.dtype and np.array_equal(got, want)


def test_patch_histograms_16_bit_range():
    image = np.full((10, 10), 8000, np.uint16)
    image[:, 5:] = 9000
    H = patch_histograms(
        image, np.array([5]), np.array([5]), patch_size=2, bins=4,
        intensity_range=(7000, 11000),
    )
    assert H.tolist() == [[0.0, 0.5, 0.5, 0.0]]


def test_fit_kmeans_small_sets_return_distinct_rows():
    X = np.array([[0.0, 1], [0, 1], [1, 0]])
    C = fit_kmeans(X, 40, random_state=0)
    assert C.tolist() == [[0.0, 1.0], [1.0, 0.0]]


def test_fit_kmeans_mini_batch_inertia_close_to_lloyd(global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    X = rng.dirichlet(np.ones(8) * 0.5, 6000)
    mini = fit_kmeans(
        X, 20, batch_size=512, n_steps=150, max_full_samples=1000,
        random_state=global_random_seed,
    )
    full = KMeans(20, n_init=1, random_state=global_random_seed).fit(X)
    inertia = (cdist(X, mini, "sqeuclidean").min(1)).sum()
    assert inertia <= 1.05 * full.inertia_


def test_rank_positive_centers_is_mean_distance():
    rng = np.random.default_rng(0)
    P, N = rng.random((5, 4)), rng.random((9, 4))
    np.testing.assert_allclose(rank_positive_centers(P, N), cdist(P, N).mean(1))


def test_keeps_the_centres_farthest_from_the_negatives():
    # three positive groups; the one at [0, 0, 1] lies farthest from the negatives
    pos = np.repeat([[0.0, 0, 1], [0.5, 0.5, 0], [0.4, 0.6, 0]], 10, axis=0)
    neg = np.repeat([[0.5, 0.5, 0], [0.6, 0.4, 0]], 10, axis=0)
    X, y = np.vstack([pos, neg]), np.r_[np.ones(30), np.zeros(20)]
    v = KMeansHistogramVerifier(n_centers=1, random_state=0).fit(X, y)
    assert v.centers_.tolist() == [[0.0, 0.0, 1.0]]
    assert v.predict([[0, 0.05, 0.95], [0.5, 0.5, 0]]).tolist() == [1, 0]
    assert v.n_positive_ == 30 and v.n_negative_ == 20


def test_verify_histograms_matches_brute_force(global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    P, N = rng.dirichlet(np.ones(6), 7), rng.dirichlet(np.ones(6), 30)
    H = rng.dirichlet(np.ones(6), 500)
    d_pos, d_neg = cdist(H, P).min(1), cdist(H, N).min(1)
    for md, margin in [(0.3, None), (0.3, 0.0), (0.5, 0.04), (10.0, -0.02)]:
        expected = d_pos <= md
        if margin is not None:
            expected &= d_pos <= d_neg + margin
        got = verify_histograms(H, P, N, max_distance=md, margin=margin)
        # both rules decide some rows each way, and agree with the brute force
        assert 0 < got.sum() < len(H) or md == 10.0
        np.testing.assert_array_equal(got, expected)


def test_margin_rejects_histograms_nearer_a_negative_centre():
    # positives around [1, 0, 0], negatives around [0, 1, 0]; a mixed histogram
    # [0.45, 0.55, 0] lies within max_distance of the positive centre but nearer
    # the negative one
    pos = np.repeat([[1.0, 0, 0]], 20, axis=0)
    neg = np.repeat([[0.0, 1, 0]], 20, axis=0)
    X, y = np.vstack([pos, neg]), np.r_[np.ones(20), np.zeros(20)]
    mixed = [[0.45, 0.55, 0], [0.55, 0.45, 0]]
    paper = KMeansHistogramVerifier(margin=None, max_distance=0.8, random_state=0)
    assert paper.fit(X, y).predict(mixed).tolist() == [1, 1]
    ours = KMeansHistogramVerifier(margin=0.0, max_distance=0.8, random_state=0)
    assert ours.fit(X, y).predict(mixed).tolist() == [0, 1]
    # a positive margin lets a histogram be a little nearer the negatives
    assert ours.set_params(margin=0.2).predict(mixed).tolist() == [1, 1]
    # max_distance still applies with a margin
    assert ours.set_params(max_distance=0.5).predict(mixed).tolist() == [0, 0]


def test_n_centers_none_keeps_every_positive_centre():
    rng = np.random.default_rng(0)
    X = rng.dirichlet(np.ones(8), 600)
    y = np.r_[np.ones(100), np.zeros(500)]
    v = KMeansHistogramVerifier(n_positive_clusters=12, random_state=0).fit(X, y)
    assert v.n_centers is None and v.n_centers_ == 12
    # best (largest Eu) first
    assert np.all(np.diff(rank_positive_centers(v.centers_, v.negative_centers_)) <= 0)
    v10 = KMeansHistogramVerifier(n_positive_clusters=12, n_centers=10, random_state=0)
    np.testing.assert_array_equal(v10.fit(X, y).centers_, v.centers_[:10])


def test_linear_binning_shares_each_pixel_between_two_bins():
    image = np.array([[4, 176, 180, 255]], np.uint8)
    H = patch_histograms(
        image, np.array([0]), np.array([2]), patch_size=(1, 4), binning="linear"
    )
    # bin k spans [8k, 8k + 8); value v sits at bin coordinate (v + 0.5) / 8 - 0.5
    np.testing.assert_allclose(H.sum(), 1, rtol=1e-6)
    expected = np.zeros(32)
    expected[[0, 1]] = [0.9375 / 4, 0.0625 / 4]  # v = 4: x = 0.0625
    expected[[21, 22]] += [0.4375 / 4, 0.5625 / 4]  # v = 176: x = 21.5625
    expected[[22, 23]] += [0.9375 / 4, 0.0625 / 4]  # v = 180: x = 22.0625
    expected[31] += 0.25  # v = 255: past the last centre, clipped
    np.testing.assert_allclose(H[0], expected, atol=1e-7)


@pytest.mark.parametrize(
    "params, match",
    [
        ({"context_size": (25, 0)}, "context_size"),
        ({"context_size": (25, 13, 3)}, "context_size"),
        ({"context_size": 0}, "context_size"),
        ({"context_size": "25x13"}, "context_size"),
        ({"context_weight": 0.0}, "context_weight"),
        ({"context_weight": -1.0}, "context_weight"),
    ],
)
def test_bad_context_is_a_clear_error(params, match):
    X, y = scene(0, n_frames=2)
    Xk = IntensityKeypointSampler().fit(X, y).transform(X)
    with pytest.raises(ValueError, match=match):
        KMeansHistogramVerifier(**params).fit(Xk, y)


@pytest.mark.parametrize(
    "kwargs, match",
    [({"context_size": (0, 5)}, "context_size"), ({"patch_size": -1}, "patch_size"),
     ({"context_weight": float("nan")}, "context_weight")],
)
def test_keypoint_descriptors_bad_arguments(kwargs, match):
    image = np.zeros((10, 10), np.uint8)
    with pytest.raises(ValueError, match=match):
        keypoint_descriptors(image, np.array([5]), np.array([5]), **kwargs)


def test_frame_mode_needs_the_descriptor_it_was_fitted_on():
    """A verifier fitted on 32-bin patch histograms (tabular) or refitted settings
    cannot verify frames described by 64-value descriptors: a clear error."""
    sampler, verifier = _fit_stages(3)
    X, _ = scene(4, n_frames=1)
    Xk = sampler.transform(X)
    verifier.set_params(context_size=None)
    with pytest.raises(ValueError, match="fitted on descriptors of 64 values"):
        verifier.transform(Xk)
    kp = Xk[0].payload["keypoints"]
    H = patch_histograms(Xk[0].image, kp[:, 0], kp[:, 1])
    tabular = KMeansHistogramVerifier(n_positive_clusters=2, n_negative_clusters=2)
    tabular.fit(H, np.arange(len(H)) % 2)
    with pytest.raises(ValueError, match="describe keypoints by 64"):
        tabular.transform(Xk)


def test_narrow_lookup_tables_are_widened():
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, (60, 60), dtype=np.uint8)
    rows, cols = rng.integers(0, 60, 3000), rng.integers(0, 60, 3000)
    lut = (np.arange(256) // 8).astype(np.int16)
    assert np.array_equal(patch_histograms(image, rows, cols, lut=lut),
                          patch_histograms(image, rows, cols))


def test_bad_patch_size_is_a_clear_error():
    with pytest.raises(ValueError, match="patch_size"):
        KMeansHistogramVerifier(patch_size=(7, 0)).fit(np.eye(3), [1, 0, 0])


def test_one_class_is_a_clear_error():
    with pytest.raises(ValueError, match="1 class"):
        KMeansHistogramVerifier().fit(np.eye(3), [1, 1, 1])
    with pytest.raises(ValueError, match="intensity_range"):
        KMeansHistogramVerifier(intensity_range=(5, 5)).fit(np.eye(3), [1, 0, 0])


# ------------------------------------------------------------------ frame mode
def scene(seed, n_frames=6, size=(240, 320)):
    """Tunnel-like frames: a warm wall, indicators (uniform plates) and lamps.

    An indicator is a plate of nearly uniform intensity in the keypoint band, with a
    sharp edge to the darker wall.  A lamp is a saturated core whose glow falls off
    smoothly, so a ring of its halo also lies in the band.
    """
    rng = np.random.default_rng(seed)
    h, w = size
    yy, xx = np.mgrid[:h, :w]
    images, boxes = [], []
    for _ in range(n_frames):
        image = 95 + 0.08 * yy + rng.normal(0, 4, size)
        frame_boxes = []
        for _ in range(2):
            bh = int(rng.integers(16, 48))
            bw = max(bh // 3, 6)
            top, left = int(rng.integers(0, h - bh)), int(rng.integers(0, w - bw))
            image[top : top + bh, left : left + bw] = rng.normal(176, 3, (bh, bw))
            frame_boxes.append([left, top, bw, bh])
        for _ in range(2):
            cy, cx, r = rng.uniform(20, h - 20), rng.uniform(20, w - 20), rng.uniform(3, 8)
            d = np.hypot(yy - cy, xx - cx)
            glow = 160 * np.exp(-np.maximum(d - r, 0) / (1.5 * r))
            image = np.maximum(image, np.where(d < r, 255, 95 + glow))
        images.append(np.clip(np.rint(image), 0, 255).astype(np.uint8))
        boxes.append(np.array(frame_boxes, dtype=float))
    return FrameSequence.from_array(np.stack(images), tour=f"scene-{seed}"), boxes


def _fit_stages(seed):
    X, y = scene(seed)
    sampler = IntensityKeypointSampler().fit(X, y)
    Xk = sampler.transform(X)
    verifier = KMeansHistogramVerifier(random_state=seed).fit(Xk, y)
    return sampler, verifier


def test_frame_mode_keeps_indicators_and_drops_lamp_halos(global_random_seed):
    sampler, verifier = _fit_stages(global_random_seed)
    X, y = scene(global_random_seed + 1000)
    out = verifier.transform(sampler.transform(X))
    hit = n_boxes = kept_neg = all_neg = 0
    for r, b in zip(out, y, strict=True):
        s, k = r.payload["sampled_keypoints"], r.payload["keypoints"]
        assert k.dtype == np.int32 and k.shape[1] == 3
        # kept keypoints are a subset of the sampled ones, in raster order
        assert {tuple(p) for p in k} <= {tuple(p) for p in s}
        assert np.all(np.diff(k[:, 0].astype(np.int64) * 10_000 + k[:, 1]) > 0)
        for box in b:
            n_boxes += 1
            hit += points_in_boxes(k[:, 0], k[:, 1], box[None]).any()
        all_neg += (~points_in_boxes(s[:, 0], s[:, 1], b)).sum()
        kept_neg += (~points_in_boxes(k[:, 0], k[:, 1], b)).sum()
    assert all_neg > 30  # the lamp halos do cross the keypoint band
    assert hit >= 0.8 * n_boxes  # indicators keep a verified keypoint
    assert kept_neg <= 0.1 * all_neg  # halo keypoints are removed


def test_frame_mode_fit_also_verifies_histograms():
    sampler, verifier = _fit_stages(7)
    # 32 bins of the 7 x 3 patch, then 32 of the 25 x 13 context
    assert verifier.n_features_in_ == 64 and verifier.n_frames_fit_ == 6
    X, _ = scene(8, n_frames=1)
    r = sampler.transform(X)[0]
    kp = r.payload["keypoints"]
    H = keypoint_descriptors(r.image, kp[:, 0], kp[:, 1])
    assert np.array_equal(H[:, :32], patch_histograms(r.image, kp[:, 0], kp[:, 1]))
    assert np.allclose(H[:, 32:].sum(1), 1.5)  # context_weight
    kept = verifier.transform([r])[0].payload["keypoints"]
    assert np.array_equal(kp[verifier.predict(H) == 1], kept)
    assert verifier.transform(H).shape == (len(kp), verifier.n_centers_)


def test_frame_mode_bins_over_a_band_of_intensities():
    """``intensity_range`` on 8-bit frames (the measured band option): frame mode
    describes each keypoint by the clipped band histogram, values outside the band
    falling into the end bins."""
    X, y = scene(3)
    sampler = IntensityKeypointSampler().fit(X, y)
    Xk = sampler.transform(X)
    verifier = KMeansHistogramVerifier(
        intensity_range=(128, 224), bins=16, context_size=None, max_distance=0.25,
        random_state=0,
    ).fit(Xk, y)
    assert verifier.n_features_in_ == 16 and verifier.centers_.shape[1] == 16
    r = Xk[0]
    kp = r.payload["keypoints"]
    H = patch_histograms(r.image, kp[:, 0], kp[:, 1], bins=16, intensity_range=(128, 224))
    # the wall (about 95-115) lies below the band: it lands in the first bin only
    wall = patch_histograms(r.image, np.array([2]), np.array([2]), bins=16,
                            intensity_range=(128, 224))
    assert wall[0, 0] == pytest.approx(1.0)
    kept = verifier.transform([r])[0].payload["keypoints"]
    assert np.array_equal(kp[verifier.predict(H) == 1], kept)


def plates_and_surface(seed, n_frames=6, size=(240, 320)):
    """Small indicator plates (16-24 px tall) on a cool wall, and below them an
    extended warm surface (road warmed behind a vehicle) of the plates' intensity:
    the 7 x 3 patches inside both have the same histogram."""
    rng = np.random.default_rng(seed)
    h, w = size
    images, boxes = [], []
    for _ in range(n_frames):
        image = rng.normal(100, 4, size)
        image[160:, :] = rng.normal(176, 3, (h - 160, w))
        frame_boxes = []
        for k in range(3):
            bh = int(rng.integers(16, 25))
            bw = max(bh // 3, 6)
            top, left = int(rng.integers(10, 150 - bh)), 20 + 100 * k + int(rng.integers(0, 60))
            image[top : top + bh, left : left + bw] = rng.normal(176, 3, (bh, bw))
            frame_boxes.append([left, top, bw, bh])
        images.append(np.clip(np.rint(image), 0, 255).astype(np.uint8))
        boxes.append(np.array(frame_boxes, dtype=float))
    return FrameSequence.from_array(np.stack(images), tour=f"plates-{seed}"), boxes


@pytest.mark.parametrize("context_size", [None, (25, 13)])
def test_context_histogram_tells_plates_from_an_extended_surface(
    context_size, global_random_seed
):
    """Without the context histogram the surface's keypoints cannot be told from
    the plates' (the paper's descriptor); with it they are removed."""
    X, y = plates_and_surface(global_random_seed)
    sampler = IntensityKeypointSampler().fit(X, y)
    verifier = KMeansHistogramVerifier(
        context_size=context_size, random_state=global_random_seed
    ).fit(sampler.transform(X), y)
    X, y = plates_and_surface(global_random_seed + 1000)
    hit = n_boxes = surface = surface_kept = 0
    for r, b in zip(verifier.transform(sampler.transform(X)), y, strict=True):
        s, k = r.payload["sampled_keypoints"], r.payload["keypoints"]
        for box in b:
            n_boxes += 1
            hit += points_in_boxes(k[:, 0], k[:, 1], box[None]).any()
        surface += (s[:, 0] >= 175).sum()  # well inside the surface
        surface_kept += (k[:, 0] >= 175).sum()
    assert hit >= 0.85 * n_boxes  # 16 of 18 at worst over seeds 0-24
    if context_size is None:
        assert surface_kept >= 0.2 * surface  # 36-84 % over seeds 0-19 and 42
    else:
        assert surface_kept <= 0.02 * surface


def test_frame_mode_needs_y_and_keypoints():
    X, y = scene(0, n_frames=2)
    with pytest.raises(ValueError, match="requires y"):
        KMeansHistogramVerifier().fit(IntensityKeypointSampler().fit_transform(X))
    with pytest.raises(ValueError, match="IntensityKeypointSampler"):
        KMeansHistogramVerifier().fit(X, y)


_X, _Y = scene(5, n_frames=3, size=(120, 160))
_XK = IntensityKeypointSampler().fit_transform(_X)
_FAST = KMeansHistogramVerifier(n_positive_clusters=8, n_negative_clusters=20, n_centers=4)


@pytest.mark.parametrize("name, check", list(record_stage_checks(_FAST, _XK, _Y)))
def test_record_stage_checks(name, check):
    check()


@pytest.mark.parametrize("name, check", list(sklearn_api_checks(KMeansHistogramVerifier())))
def test_sklearn_api_checks(name, check):
    check()


# ------------------------------------------------------------------ simulated tours
def _indicator_figures(sampler, verifier, tour, min_height):
    """(instances, kept, negatives, negatives kept) on a tour not used for fitting."""
    X, y, _ = to_xy([tour])
    out = verifier.transform(sampler.transform(X))
    tall = tour.boxes((1,), min_height=min_height + 1e-9)
    n = kept = neg = neg_kept = 0
    for r, boxes, tall_boxes in zip(out, y, tall, strict=True):
        s, k = r.payload["sampled_keypoints"], r.payload["keypoints"]
        for box in tall_boxes:
            n += 1
            kept += points_in_boxes(k[:, 0], k[:, 1], box[None]).any()
        neg += (~points_in_boxes(s[:, 0], s[:, 1], boxes)).sum()
        neg_kept += (~points_in_boxes(k[:, 0], k[:, 1], boxes)).sum()
    return n, kept, neg, neg_kept


@pytest.mark.slow
def test_on_simulated_tours_not_used_for_fitting(global_random_seed):
    """Issue 4's validation, on small tours (the full-size figures are in
    docs/tunnel-stages.md, from ``benchmarks/bench_tunnel_stages.py --validation``).

    Issue 4 asks that >= 95 % of the indicators taller than 14 px keep a verified
    keypoint and that >= 80 % of the negative keypoints be removed.  With the
    defaults (7 x 3 patch and 25 x 13 context histograms, all centres,
    ``margin=0.04``, ``max_distance=0.4``), fitted on two 200-frame tours, seeds 0,
    1, 2, 3 and 42 gave 98.9-100 % kept (97.4-100 % of those taller than 30 px) and
    93.8-100 % removed (the 7 x 3 patch alone: 96.9-100 % and 68.1-91.9 %); over
    seeds 0-24 the removal went as low as 84.8 % (seed 15).  The bounds are floors
    under those figures (the removal at issue 4's 80 %), guarding against
    regressions.
    """
    seed = global_random_seed
    train = [
        make_tunnel_tour(200, scenario=sc, random_state=seed + i, first_indicator_m=40.0)
        for i, sc in enumerate(["light", "heavy"])
    ]
    tests = [
        make_tunnel_tour(150, scenario=sc, random_state=seed + 50 + i,
                         first_indicator_m=50.0)
        for i, sc in enumerate(["heavy", "curved"])
    ]
    X, y, _ = to_xy(train)
    sampler = IntensityKeypointSampler().fit(X, y)
    verifier = KMeansHistogramVerifier(random_state=seed).fit(sampler.transform(X), y)
    fig14 = np.sum([_indicator_figures(sampler, verifier, t, 14.0) for t in tests], 0)
    fig30 = np.sum([_indicator_figures(sampler, verifier, t, 30.0) for t in tests], 0)
    assert fig14[0] >= 40 and fig30[0] >= 20 and fig14[2] >= 1000
    assert fig14[1] / fig14[0] >= 0.95
    assert fig30[1] / fig30[0] >= 0.95
    assert 1 - fig14[3] / fig14[2] >= 0.8


@pytest.mark.parametrize("binning", ["hard", "linear"])
@pytest.mark.parametrize("context_size", [(25, 13), (6, 2), 4, (3, 9)])
def test_keypoint_descriptors_are_the_two_patch_histograms(
    context_size, binning, global_random_seed
):
    """One shared gather (patch inside the context) or two (it is not) give the
    histograms of the two patches, at the frame's edges too."""
    rng = np.random.default_rng(global_random_seed)
    image = rng.integers(0, 256, (40, 30), dtype=np.uint8)
    rows = np.r_[0, 39, rng.integers(0, 40, 20)]
    cols = np.r_[29, 0, rng.integers(0, 30, 20)]
    D = keypoint_descriptors(image, rows, cols, patch_size=(7, 3),
                             context_size=context_size, context_weight=1.5,
                             bins=16, binning=binning)
    kw = dict(bins=16, binning=binning)
    assert np.allclose(D[:, :16], patch_histograms(image, rows, cols, patch_size=(7, 3), **kw))
    assert np.allclose(
        D[:, 16:], 1.5 * patch_histograms(image, rows, cols, patch_size=context_size, **kw)
    )
    alone = keypoint_descriptors(image, rows, cols, context_size=None, bins=16)
    assert np.array_equal(alone, patch_histograms(image, rows, cols, bins=16))
    assert keypoint_descriptors(image, rows[:0], cols[:0]).shape == (0, 64)


@pytest.mark.parametrize("n, max_full", [(60, 20_000), (3000, 500)])
def test_fit_kmeans_sample_indices_equal_the_copied_rows(n, max_full, global_random_seed):
    """Full and mini-batch paths: clustering rows by index gives the centres of the
    copied rows, for the same random state."""
    rng = np.random.default_rng(global_random_seed)
    X = rng.random((n, 8))
    idx = np.flatnonzero(rng.random(n) < 0.6)
    kw = dict(max_full_samples=max_full, batch_size=64, n_steps=20,
              random_state=global_random_seed)
    a = fit_kmeans(X, 10, sample_indices=idx, **kw)
    b = fit_kmeans(X[idx], 10, **kw)
    assert np.array_equal(a, b)


@pytest.mark.parametrize("augment", [None, (0.45, 1.0)])
def test_frame_mode_fit_transform_equals_fit_then_transform(augment, global_random_seed):
    """fit_transform verifies the descriptors of the fit, without computing them
    again; the result and the fitted centres are those of fit then transform."""
    X, y = scene(global_random_seed)
    Xk = IntensityKeypointSampler().fit(X, y).transform(X)
    a = KMeansHistogramVerifier(random_state=0, augment_contrast=augment)
    b = clone(a)
    out_a = a.fit_transform(Xk, y)
    out_b = b.fit(Xk, y).transform(Xk)
    assert np.array_equal(a.centers_, b.centers_)
    assert np.array_equal(a.negative_centers_, b.negative_centers_)
    assert len(out_a) == len(out_b) == len(Xk)
    kept = 0
    for ra, rb in zip(out_a, out_b, strict=True):
        for key in ("keypoints", "sampled_keypoints"):
            assert np.array_equal(ra.payload[key], rb.payload[key])
        kept += len(ra.payload["keypoints"])
    assert 0 < kept < sum(len(r.payload["keypoints"]) for r in Xk)
