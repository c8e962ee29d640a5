"""The detector's options for another camera and a curving tunnel."""

import numpy as np
import pytest

from tunnelsense import FrameRecord, FrameSequence
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.tunnel import (
    PCCVerifier,
    WeightedAdaBoost,
    box_histograms,
    curve_fit_r,
    make_indicator_pipeline,
    motion_fit_r,
    pearson_r,
)
from tunnelsense.tunnel._invariant import invariant_features, perturb_patch
from tunnelsense.tunnel._pipeline import PAPER_SETTINGS, PIPELINE_DEFAULTS

STILL = dict(first_indicator_m=45.0, lateral_jitter_m=0.0, pitch_jitter_deg=0.0,
             traffic_per_km=0.0, speed_kmh=80.0)


def _sign(tour):
    gt = tour.gt
    rows = gt[(gt["class"] == 1) & (gt["frame"] == 1)]
    row = rows.loc[rows["bb_height"].idxmax()]
    box = np.array([[row["bb_left"], row["bb_top"], row["bb_width"], row["bb_height"]]])
    return tour.frames[0].image, np.round(box)


@pytest.mark.parametrize("change", [dict(noise_sigma=5.0),
                                    dict(noise_sigma=5.0, gain=1.3, offset=-40.0)])
def test_invariant_features_move_less_than_the_raw_histogram(change):
    """Camera A (noise 3) against a camera with more noise (and another gain)."""
    img_a, box = _sign(make_tunnel_tour(1, random_state=21, noise_sigma=3.0, **STILL))
    img_b, box_b = _sign(make_tunnel_tour(1, random_state=21, **{**STILL, **change}))
    assert np.array_equal(box, box_b) and box[0, 3] >= 14
    raw = np.abs(box_histograms(img_a, box, margin=0.25)
                 - box_histograms(img_b, box, margin=0.25)).sum()
    inv_a = invariant_features(img_a, box)[0, :16]
    inv_b = invariant_features(img_b, box)[0, :16]
    inv = np.abs(inv_a - inv_b).sum()
    # both are distributions (L1 distance in [0, 2])
    assert inv < 0.6 * raw, (inv, raw)


def test_perturbed_patch_is_reproducible_and_scaled():
    patch = np.full((30, 16), 170, np.uint8)
    a, hw = perturb_patch(patch, np.random.default_rng(1), (24.0, 10.0))
    b, _ = perturb_patch(patch, np.random.default_rng(1), (24.0, 10.0))
    assert np.array_equal(a, b)
    scale = hw[0] / 24.0
    assert 0.75 <= scale <= 1.25
    assert a.shape == (round(30 * scale), round(16 * scale))


def _paths():
    curved = make_tunnel_tour(100, random_state=3, curve_radius_m=800.0,
                              first_indicator_m=75.0, speed_kmh=90.0, traffic_per_km=0,
                              focal_length_px=560.0, mount_height_m=1.6)
    g = curved.gt[(curved.gt["class"] == 1) & (curved.gt["bb_height"] >= 8)]
    sign = g.groupby("id").filter(lambda d: len(d) >= 40)
    heavy = make_tunnel_tour(150, scenario="heavy", random_state=4)
    v = heavy.gt[heavy.gt["class"] == 3]
    # vehicles followed for the whole tour that keep (nearly) to their column
    still = v.groupby("id").filter(
        lambda d: len(d) == 150 and np.ptp(d["bb_left"] + d["bb_width"] / 2) < 10
    )
    return sign, still


def _centres(d):
    return (d["bb_left"] + d["bb_width"] / 2).to_numpy(), (
        d["bb_top"] + d["bb_height"] / 2).to_numpy()


def test_quadratic_criterion_accepts_curved_sign_path_and_rejects_vehicles():
    sign, vehicles = _paths()
    assert sign["id"].nunique() >= 1 and vehicles["id"].nunique() >= 2
    for _, d in sign.groupby("id"):
        assert curve_fit_r(*_centres(d)) >= 0.98
    for _, d in vehicles.groupby("id"):
        assert curve_fit_r(*_centres(d)) < 0.9
        # nor do they move smoothly in time (the "quadratic-motion" criterion)
        assert motion_fit_r(d["frame"], *_centres(d)) < 0.9


def _track(xs, ys, tid=1):
    return [
        FrameRecord("t", k + 1, np.zeros((8, 8), np.uint8),
                    {"cluster_boxes": np.array([[x - 2, y - 4, 4, 8]]),
                     "appearance": np.array([True]), "track_ids": np.array([tid])})
        for k, (x, y) in enumerate(zip(xs, ys, strict=True))
    ]


def test_quadratic_criterion_in_the_verifier():
    k = np.arange(30.0)
    # a path bending through a quarter of its direction: a line fits it badly
    xs, ys = 300 - 8 * k, 200 - 0.35 * (k - 15) ** 2
    X = _track(xs, ys)
    assert abs(pearson_r(xs, ys)) < 0.9
    pearson = PCCVerifier().fit(X).predict(X)
    quadratic = PCCVerifier(criterion="quadratic").fit(X).predict(X)
    assert sum(len(r.payload["detections"]) for r in pearson) == 0
    assert sum(len(r.payload["detections"]) for r in quadratic) == 30
    # a vehicle ahead jittering in place: no path
    rng = np.random.default_rng(0)
    J = _track(320 + rng.normal(0, 2, 30), 240 + rng.normal(0, 2, 30))
    out = PCCVerifier(criterion="quadratic").fit(J).predict(J)
    assert sum(len(r.payload["detections"]) for r in out) == 0


def test_motion_fit_r_is_scale_free_and_needs_motion():
    rng = np.random.default_rng(3)
    t = np.arange(20.0)
    x, y = 280 - 1.2 * t, 220 - 0.3 * t + rng.normal(0, 0.8, 20)
    r = motion_fit_r(t, x, y)
    # another resolution and another image position: the same figure
    assert motion_fit_r(t, 0.5 * x + 7, 0.5 * y - 3) == pytest.approx(r)
    # time in other units (frame numbers of another rate) changes nothing
    assert motion_fit_r(2 * t + 100, x, y) == pytest.approx(r)
    assert motion_fit_r(t[:3], x[:3], y[:3]) == 0.0
    assert motion_fit_r(t, np.full(20, 5.0), np.full(20, 9.0)) == 0.0
    assert motion_fit_r(np.full(20, 4.0), x, y) == 0.0


def test_short_flat_path_with_pitch_jitter():
    """A far sign's short, nearly horizontal stretch (the stream ends) under the
    camera's body pitch: a smooth motion in time, but no function y(x)."""
    k = np.arange(30.0)
    rng = np.random.default_rng(5)
    pitch = rng.normal(0, 1.0, 30)
    xs, ys = 285 - 0.85 * k, 223 - 0.25 * k + 1.2 * pitch
    X = _track(xs, ys)
    assert curve_fit_r(xs, ys) < 0.95 <= motion_fit_r(k + 1, xs, ys)
    quadratic = PCCVerifier(criterion="quadratic").fit(X).predict(X)
    motion = PCCVerifier(criterion="quadratic-motion").fit(X).predict(X)
    assert sum(len(r.payload["detections"]) for r in quadratic) == 0
    assert sum(len(r.payload["detections"]) for r in motion) == 30
    assert all(r.payload["motion_r"][0] >= 0.95 for r in motion)
    # a cluster jittering in place, also with a flat (pitch-like) jitter: no motion
    for sx, sy in ((2.0, 2.0), (0.3, 2.0)):
        J = _track(320 + rng.normal(0, sx, 30), 240 + rng.normal(0, sy, 30))
        out = PCCVerifier(criterion="quadratic-motion").fit(J).predict(J)
        assert sum(len(r.payload["detections"]) for r in out) == 0


def _frames(n=8, seed=0):
    rng = np.random.default_rng(seed)
    X, y = [], []
    for f in range(1, n + 1):
        img = rng.normal(100, 3, (80, 120)).clip(0, 255).astype(np.uint8)
        left = 20 + int(rng.integers(0, 20))
        img[20:38, left:left + 8] = 175
        img[40:44, 80:100] = 175  # a wide warm patch (a vehicle's bumper)
        boxes = np.array([[left, 20, 8, 18], [80, 40, 20, 4]], float)
        X.append(FrameRecord("t", f, img, {"cluster_boxes": boxes}))
        y.append(boxes[:1])
    return FrameSequence(X), y


def test_invariant_features_and_augmentation_in_the_stage():
    X, y = _frames()
    ada = WeightedAdaBoost(n_estimators=5, features="invariant", augment=2,
                           random_state=0).fit(X, y)
    assert ada.n_features_in_ == 22
    assert (ada.n_clusters_fit_, ada.n_positive_fit_) == (48, 24)
    again = WeightedAdaBoost(n_estimators=5, features="invariant", augment=2,
                             random_state=0).fit(X, y)
    np.testing.assert_array_equal(ada.stump_thresholds_, again.stump_thresholds_)
    out = ada.transform(X)
    assert [r.payload["appearance"].tolist() for r in out] == [[True, False]] * 8
    assert out[0].payload["cluster_histograms"].shape == (2, 32)  # raw, for the linker
    # augmentation of the raw histograms too
    raw = WeightedAdaBoost(n_estimators=5, augment=1, random_state=0).fit(X, y)
    assert (raw.n_features_in_, raw.n_clusters_fit_) == (32, 32)


def test_paper_preset_and_defaults():
    p = make_indicator_pipeline().get_params()
    assert all(p[k] == v for k, v in PIPELINE_DEFAULTS.items())
    assert (p["appearance__features"], p["motion__criterion"]) == (
        "invariant", "quadratic-motion")
    paper = make_indicator_pipeline(preset="paper", min_r=0.9).get_params()
    assert all(paper[k] == v for k, v in PAPER_SETTINGS.items())
    assert paper["motion__min_r"] == 0.9
    assert (paper["appearance__features"], paper["motion__criterion"]) == (
        "histogram", "pearson")
    with pytest.raises(ValueError, match="preset"):
        make_indicator_pipeline(preset="nonsense")
