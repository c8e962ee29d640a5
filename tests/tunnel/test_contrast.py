"""Keypoints on local contrast: IntensityKeypointSampler(radiometry="contrast")."""

import numpy as np
import pytest

from tunnelsense import to_xy
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.io import load_model, save_model
from tunnelsense.tunnel import IntensityKeypointSampler
from tunnelsense.tunnel._common import points_in_boxes
from tunnelsense.tunnel._contrast import (
    _at_least,
    background_cells,
    contrast_band,
    grid_contrast,
    sample_contrast_keypoints,
)
from tunnelsense.utils import record_stage_checks

QUIET = dict(first_indicator_m=40.0, lateral_jitter_m=0.0, pitch_jitter_deg=0.0,
             traffic_per_km=0.0, speed_kmh=80.0, focal_length_px=700.0)
CONTRAST = dict(band="learned", radiometry="contrast", gain_tolerance=0.0)


@pytest.fixture(scope="module")
def tours():
    plain = make_tunnel_tour(40, random_state=4, **QUIET)
    other = make_tunnel_tour(40, random_state=4, gain=0.7, offset=-20.0, **QUIET)
    warm = make_tunnel_tour(40, random_state=4, ambient_warming=37.0, **QUIET)
    return plain, other, warm


def _keypoint_set(seq):
    return {tuple(k[:2]) for r in seq for k in r.payload["keypoints"].tolist()}


def _signs_sampled(seq, y, min_height=10.0):
    """Indicator boxes at least ``min_height`` px tall holding a keypoint, and all."""
    hit = total = 0
    for r, boxes in zip(seq, y, strict=True):
        kp = r.payload["keypoints"]
        for left, top, w, h in np.asarray(boxes).reshape(-1, 4):
            if h < min_height:
                continue
            total += 1
            hit += bool(np.any((kp[:, 0] >= top) & (kp[:, 0] < top + h)
                               & (kp[:, 1] >= left) & (kp[:, 1] < left + w)))
    return hit, total


def test_background_ignores_a_sign_and_follows_an_affine_change():
    rng = np.random.default_rng(0)
    img = np.tile(np.linspace(80, 120, 640), (480, 1)) + rng.normal(0, 3, (480, 640))
    img[200:260, 320:347] = 200
    img = img.round().clip(0, 255)
    bg, level, spread = background_cells(img.astype(np.uint8))
    assert abs(bg[14, 20] - 100.5) < 3  # the sign's blocks hold the wall's level
    other = (0.7 * img - 20).round().clip(0, 255).astype(np.uint8)
    bg2, level2, spread2 = background_cells(other)
    assert level2 == pytest.approx(0.7 * level - 20, abs=0.6)
    assert spread2 == pytest.approx(0.7 * spread, rel=0.05)
    assert np.abs(bg2 - (0.7 * bg - 20)).max() < 1.0


def test_grid_contrast_and_sampling_on_the_grid():
    img = np.full((28, 24), 100, np.uint8)
    img[7, 6] = 150
    img[14, 12] = 250
    bg = np.full((4, 4), 100.0)
    c = grid_contrast(img, bg)
    assert c.shape == (4, 4) and c[1, 1] == 50 and c[2, 2] == 150
    kp = sample_contrast_keypoints(img, bg, 20, 100)
    assert kp.tolist() == [[7, 6, 150]]


def test_contrast_band_refuses_boxes_without_pixels():
    with pytest.raises(ValueError, match="no indicator box"):
        contrast_band([np.zeros((48, 64), np.uint8)], [np.zeros((0, 4))])


def test_gain_and_offset_leave_the_contrast_keypoints(tours):
    plain, other, _ = tours
    X, y, _ = to_xy([plain])
    Xo, _, _ = to_xy([other])
    sampler = IntensityKeypointSampler(**CONTRAST).fit(X, y)
    assert 0 < sampler.contrast_low_ < sampler.contrast_high_
    a, b = _keypoint_set(sampler.transform(X)), _keypoint_set(sampler.transform(Xo))
    assert len(a) > 100
    assert len(a & b) >= 0.9 * len(a | b)


def test_a_warmer_lining_keeps_the_signs_sampled(tours):
    """Warm air halves a sign's contrast: the learned contrast band loses signs, the
    band widened to less than half the training contrast keeps them."""
    plain, _, warm = tours
    X, y, _ = to_xy([plain])
    Xw, yw, _ = to_xy([warm])
    contrast = IntensityKeypointSampler(**CONTRAST, min_contrast=0.4).fit(X, y)
    learned = IntensityKeypointSampler(**CONTRAST).fit(X, y)
    hit, total = _signs_sampled(contrast.transform(Xw), yw)
    assert total >= 10
    assert hit >= 0.9 * total
    assert _signs_sampled(learned.transform(Xw), yw)[0] <= 0.8 * total


def test_min_and_max_contrast_widen_the_learned_band(tours):
    X, y, _ = to_xy([tours[0]])
    full = IntensityKeypointSampler(**CONTRAST).fit(X, y)
    wide = IntensityKeypointSampler(**CONTRAST, min_contrast=0.5,
                                    max_contrast=1.5).fit(X, y)
    assert wide.contrast_low_ == pytest.approx(0.5 * full.contrast_low_, abs=1e-5)
    assert wide.contrast_high_ == pytest.approx(1.5 * full.contrast_high_, abs=1e-5)
    assert wide.low_ == pytest.approx(
        wide.ref_level_ + wide.contrast_low_ * wide.ref_spread_, abs=1e-4)


def _raw_counts(X, gain=24, offset=7000):
    """The frames as a 16-bit camera's raw counts: ``gain * I + offset``."""
    from tunnelsense import FrameRecord, FrameSequence

    return FrameSequence(
        FrameRecord(r.tour, r.frame, r.image.astype(np.uint16) * gain + offset)
        for r in X
    )


def test_a_16_bit_camera_gets_the_8_bit_picture_and_the_same_keypoints(tours):
    """Raw 16-bit counts: the later stages read an 8-bit picture (background at
    grey level 100, the training signs' median contrast 75 above it) and the
    keypoints are those of the same frames in 8 bits."""
    plain, other, _ = tours
    X, y, _ = to_xy([plain])
    Xo, _, _ = to_xy([other])
    eight = IntensityKeypointSampler(**CONTRAST).fit(X, y)
    deep = IntensityKeypointSampler(**CONTRAST).fit(_raw_counts(X), y)
    assert deep.pixel_dtype_ == "uint16" and deep.ref_level_ == 100.0
    assert deep.raw_spread_ == pytest.approx(24 * eight.ref_spread_, rel=0.02)
    assert deep.contrast_low_ == pytest.approx(eight.contrast_low_, rel=0.02)
    assert 100 < deep.low_ < deep.high_
    out = deep.transform(_raw_counts(Xo, gain=31, offset=5000))
    assert out[0].image.dtype == np.uint8
    level = np.median([np.median(r.image) for r in out])
    assert abs(level - 100) < 10
    a = _keypoint_set(eight.transform(X))
    b = _keypoint_set(deep.transform(_raw_counts(X)))
    c = _keypoint_set(out)
    assert len(a) > 100
    assert len(a & b) >= 0.95 * len(a | b)
    assert len(a & c) >= 0.9 * len(a | c)
    with pytest.raises(Exception, match="fitted on uint16 frames"):
        deep.transform(X)


def test_contrast_needs_a_learned_band(tours):
    X, y, _ = to_xy([tours[0]])
    with pytest.raises(ValueError, match="band='learned'"):
        IntensityKeypointSampler(radiometry="contrast").fit(X, y)


def test_contrast_sampler_survives_a_skops_round_trip(tours, tmp_path):
    plain, other, _ = tours
    X, y, _ = to_xy([plain])
    Xo, _, _ = to_xy([other])
    est = IntensityKeypointSampler(band="learned", radiometry="contrast",
                                   frame_size="training").fit(X, y)
    back = load_model(save_model(est, tmp_path / "m.skops"))
    assert back.contrast_low_ == est.contrast_low_
    assert _keypoint_set(back.transform(Xo)) == _keypoint_set(est.transform(Xo))


def test_record_stage_checks_of_the_contrast_sampler(tours):
    X, y, _ = to_xy([tours[0]])
    est = IntensityKeypointSampler(band="learned", radiometry="contrast")
    for name, check in record_stage_checks(est, X[:3], y[:3]):
        check()
        assert name.startswith("check_")


def test_surround_histograms_ignore_gain_offset_and_contrast():
    from tunnelsense.tunnel._descriptors import surround_histograms

    rng = np.random.default_rng(1)
    wall = rng.normal(100, 2, (60, 60))
    plate = wall.copy()
    plate[10:40, 20:30] += 70
    rows, cols = np.array([20, 25, 50]), np.array([24, 26, 10])
    base = surround_histograms(plate.round().astype(np.uint8), rows, cols)
    assert base.shape == (3, 32)
    assert np.allclose(base.sum(axis=1), 1.0)
    for gain, offset, contrast in [(0.7, -20, 1.0), (1.3, 20, 1.0), (1.0, 0, 0.5)]:
        other = wall.copy()
        other[10:40, 20:30] += 70 * contrast
        img = (gain * other + offset).round().clip(0, 255).astype(np.uint8)
        h = surround_histograms(img, rows, cols)
        # the plate's keypoints: the same peak (bins 22-26, z within 1 +/- 0.125)
        assert h[:2, 22:27].sum(axis=1).min() >= 0.9
        assert np.abs(h[:2] - base[:2]).sum(axis=1).max() <= 0.6


def test_verifier_surround_normalization_describes_by_one_histogram(tours):
    from tunnelsense.tunnel import KMeansHistogramVerifier

    plain, other, _ = tours
    X, y, _ = to_xy([plain])
    Xo, _, _ = to_xy([other])
    sampled = IntensityKeypointSampler(**CONTRAST).fit_transform(X, y)
    ver = KMeansHistogramVerifier(normalize="surround", context_size=None,
                                  n_negative_clusters=40, random_state=0)
    ver.fit(sampled, y)
    assert ver.n_features_in_ == 32
    out = ver.transform(sampled)
    kept = sum(len(r.payload["keypoints"]) for r in out)
    assert 0 < kept < sum(len(r.payload["sampled_keypoints"]) for r in out)


def test_contrast_region_ignores_gain_offset_and_a_dim_rim():
    from tunnelsense.tunnel._contrast import contrast_region_boxes

    rng = np.random.default_rng(0)
    img = rng.normal(100, 2, (60, 60))
    img[20:36, 27:33] += 80          # a 16 x 6 px sign
    img[36:44, 27:33] += 25          # a dim rim below it (lining joint)
    rows, cols = np.array([21, 28, 35]), np.array([30, 30, 30])
    box = np.array([[30.0, 21.0, 1.0, 15.0]])
    labels = np.zeros(3, dtype=np.intp)
    out = []
    for g, o in ((1.0, 0.0), (0.7, -20.0), (1.3, 20.0)):
        frame = np.clip(np.rint(g * img + o), 0, 255).astype(np.uint8)
        out.append(contrast_region_boxes(frame, rows, cols, labels, box))
    assert out[0].tolist() == [[27.0, 20.0, 6.0, 16.0]]
    for b in out[1:]:
        assert b.tolist() == out[0].tolist()
    # a grey band low enough for half the contrast takes the rim too
    from tunnelsense.tunnel._mst import region_boxes

    frame = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    assert region_boxes(frame, rows, cols, labels, box, (120, 255))[0, 3] > 16


def test_clusterer_box_contrast_holds_a_keypoint_in_the_grown_rectangle(tours):
    from tunnelsense.tunnel import MSTClusterer

    plain, _, _ = tours
    X, y, _ = to_xy([plain])
    kp = IntensityKeypointSampler(**CONTRAST).fit(X, y).transform(X)
    out = MSTClusterer(box="contrast").fit_transform(kp)
    keyed = MSTClusterer(box="keypoints").fit_transform(kp)
    n = 0
    for a, b in zip(out, keyed, strict=True):
        ba, bb = a.payload["cluster_boxes"], b.payload["cluster_boxes"]
        assert ba.shape == bb.shape
        kp_r, kp_c = a.payload["keypoints"][:, 0], a.payload["keypoints"][:, 1]
        for k, (box, rect) in enumerate(zip(ba, bb, strict=True)):
            # within the keypoints' rectangle grown by the reach (14, 12)
            assert box[0] >= rect[0] - 12 and box[1] >= rect[1] - 14
            assert box[0] + box[2] <= rect[0] + rect[2] + 12
            assert box[1] + box[3] <= rect[1] + rect[3] + 14
            own = a.payload["cluster_labels"] == k
            inside = points_in_boxes(kp_r[own], kp_c[own], box[None])
            assert inside.any()
        n += int((ba[:, 3] > bb[:, 3]).sum())
    assert n > 0


@pytest.mark.parametrize("deep", [False, True])
@pytest.mark.parametrize("tolerance", [0.0, "learned"])
def test_fit_transform_equals_fit_then_transform(tours, deep, tolerance):
    """fit_transform reuses the canonical frames its fit made where the frame's map
    is the same: the same frames (pixels) and payloads as fit, then transform, on
    8-bit frames and on 16-bit counts (whose fit maps by other reference levels
    than its transform)."""
    plain, _, _ = tours
    X, y, _ = to_xy([plain])
    if deep:
        X = _raw_counts(X)
    kw = dict(CONTRAST, gain_tolerance=tolerance)
    a = IntensityKeypointSampler(**kw).fit_transform(X, y)
    b = IntensityKeypointSampler(**kw).fit(X, y).transform(X)
    assert a[0].image.dtype == np.uint8
    for ra, rb in zip(a, b, strict=True):
        assert np.array_equal(ra.image, rb.image)
        assert ra.payload.keys() == rb.payload.keys()
        for key in ra.payload:
            assert np.array_equal(ra.payload[key], rb.payload[key])


def test_at_least_is_the_float_comparison():
    # integer pixels against the least integer at or above the level: the same mask
    # as comparing in floating point, levels between, at and beyond the pixel values
    rng = np.random.default_rng(0)
    for dtype in (np.uint8, np.uint16, np.float32):
        top = 255 if dtype == np.uint8 else 1000
        pixels = rng.integers(0, top + 1, (9, 7)).astype(dtype)
        levels = np.r_[rng.uniform(-3, top + 3, 50), np.arange(-2, 5), top - 1, top,
                       top + 0.5, top + 2, 70000.5]
        for level in levels.tolist():
            got = _at_least(pixels, level)
            assert got.dtype == np.uint8
            np.testing.assert_array_equal(got, (pixels >= level).astype(np.uint8))
