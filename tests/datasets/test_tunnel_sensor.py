"""Physics of the simulated FIR sensor: unit gain and offset, automatic gain control,
warm air, and a lower resolution with the same field of view."""

import math

import cv2
import numpy as np
import pytest

from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.datasets._tunnel_params import RANDOMIZED_RANGES, _randomized

# no noise, no fixed pattern, nothing moving: the scene itself
QUIET = dict(first_indicator_m=40.0, lateral_jitter_m=0.0, pitch_jitter_deg=0.0,
             traffic_per_km=0.0, speed_kmh=80.0, noise_sigma=0.0, fpn_sigma=0.0)


def _vignetting(h, w):
    yy, xx = np.mgrid[0:h, 0:w]
    r2 = ((xx - w / 2) / (w / 2)) ** 2 + ((yy - h / 2) / (h / 2)) ** 2
    return 3.0 - 3.0 * r2


def _sign(tour, frame=1):
    gt = tour.gt
    rows = gt[(gt["class"] == 1) & (gt["frame"] == frame)]
    return rows.loc[rows["bb_height"].idxmax()]


def test_gain_and_offset_map_each_pixel_affinely():
    """pixel = clip(g * I + o) with I the scene, before the vignetting is added."""
    g, o = 1.2, -15.0
    a = make_tunnel_tour(2, random_state=5, **QUIET).frames[1].image.astype(float)
    b = make_tunnel_tour(2, random_state=5, gain=g, offset=o, **QUIET).frames[1].image
    v = _vignetting(*a.shape)
    expected = g * (a - v) + o + v
    inside = (a > 1) & (a < 254) & (expected > 1) & (expected < 254)
    assert inside.mean() > 0.9
    # two roundings to whole grey levels: at most (g + 1) / 2
    assert np.abs(b[inside] - expected[inside]).max() <= (g + 1) / 2 + 1e-6
    # and clipped where the scene goes beyond the 8-bit range
    assert b.max() == 255


def test_half_resolution_is_the_scene_at_half_focal_length():
    full = make_tunnel_tour(2, random_state=5, focal_length_px=700.0, **QUIET)
    half = make_tunnel_tour(2, random_state=5, focal_length_px=700.0, sensor_scale=0.5,
                            **QUIET)
    assert half.image_shape == (240, 320)
    assert half.info["focal_length_px"] == 350.0
    assert half.info["sensor_scale"] == 0.5
    # the same field of view: the sign's box is the full frame's, halved
    a, b = _sign(full), _sign(half)
    for key in ("bb_left", "bb_top", "bb_width", "bb_height"):
        assert b[key] == pytest.approx(0.5 * a[key], abs=0.05 + 0.02 * abs(a[key]))
    # and the image is the full one averaged over 2 x 2 pixels (up to the optical
    # blur, which is given in pixels of each sensor)
    small = cv2.resize(full.frames[1].image, (320, 240), interpolation=cv2.INTER_AREA)
    diff = np.abs(small.astype(float) - half.frames[1].image)
    assert np.median(diff) <= 1.0
    assert diff.mean() < 2.0


def test_warm_air_raises_the_lining_and_halves_the_sign_contrast():
    kw = dict(random_state=5, focal_length_px=800.0, **QUIET)
    cold = make_tunnel_tour(1, **kw)
    s = _sign(cold)
    img = cold.frames[0].image.astype(float)
    r0, r1 = int(s["bb_top"] + 0.3 * s["bb_height"]), int(s["bb_top"] + 0.7 * s["bb_height"])
    c0, c1 = int(s["bb_left"] + 0.3 * s["bb_width"]), int(s["bb_left"] + 0.7 * s["bb_width"])
    wall = np.median(img[r0:r1, int(s["bb_left"]) - 12 : int(s["bb_left"]) - 4])
    plate = np.median(img[r0:r1, c0:c1])
    contrast = plate - wall
    assert contrast > 40
    warm = make_tunnel_tour(1, ambient_warming=contrast / 2, **kw)
    assert warm.info["ambient_warming"] == pytest.approx(contrast / 2)
    img2 = warm.frames[0].image.astype(float)
    wall2 = np.median(img2[r0:r1, int(s["bb_left"]) - 12 : int(s["bb_left"]) - 4])
    plate2 = np.median(img2[r0:r1, c0:c1])
    assert plate2 == pytest.approx(plate, abs=1.0)  # the lit sign keeps its level
    assert plate2 - wall2 == pytest.approx(contrast / 2, abs=2.0)
    assert np.median(img2) == pytest.approx(np.median(img) + contrast / 2, abs=2.0)


def test_automatic_gain_control_is_an_affine_map_per_frame_driven_by_hot_objects():
    kw = dict(random_state=7, scenario="heavy", noise_sigma=0.0, fpn_sigma=0.0)
    plain = make_tunnel_tour(90, **kw)
    agc = make_tunnel_tour(90, agc=True, **kw)
    assert agc.info["agc"] is True and "agc" not in plain.info
    assert agc.info["agc_gain_min"] < agc.info["agc_gain_max"]
    gains = []
    for a, b in zip(plain.frames, agc.frames, strict=True):
        x, y = a.image.astype(float), b.image.astype(float)
        ok = (x > 2) & (x < 253) & (y > 2) & (y < 253)
        g, o = np.polyfit(x[ok], y[ok], 1)
        err = np.abs(y[ok] - (g * x[ok] + o))  # two roundings, a least-squares line
        assert np.percentile(err, 99.9) <= 0.75 + 0.5 * g and err.max() <= 2.0
        gains.append(g)
    gains = np.array(gains)
    # the gain follows the hot end of the view: lower when more of it is hot
    hot = np.array([np.percentile(f.image[4::8, 4::8], 99.5) for f in plain.frames])
    assert np.ptp(gains) > 0.05
    assert np.corrcoef(hot, gains)[0, 1] < -0.3
    assert gains.min() >= agc.info["agc_gain_min"] - 0.01
    assert gains.max() <= agc.info["agc_gain_max"] + 0.01


def test_randomized_scenario_draws_the_sensor_and_air_factors():
    draws = [_randomized(seed) for seed in range(40)]
    assert {d["sensor_scale"] for d in draws} == {0.5, 1.0}
    assert {d["agc"] for d in draws} == {False, True}
    warm = [d["ambient_warming"] for d in draws]
    lo, hi = RANDOMIZED_RANGES["ambient_warming"]
    assert any(w == 0.0 for w in warm) and any(w > 0 for w in warm)
    assert all(lo <= w <= hi for w in warm)
    seed = next(s for s, d in enumerate(draws) if d["sensor_scale"] == 0.5)
    t = make_tunnel_tour(1, scenario="randomized", random_state=seed)
    assert t.image_shape == (240, 320)
    assert t.info["focal_length_px"] == pytest.approx(0.5 * draws[seed]["focal_length_px"])


@pytest.mark.parametrize("bad", [dict(sensor_scale=0.0), dict(ambient_warming=math.nan),
                                 dict(agc="yes"), dict(agc_time_s=0.0)])
def test_bad_sensor_parameters_are_refused(bad):
    name = next(iter(bad))
    with pytest.raises((ValueError, TypeError), match=name):
        make_tunnel_tour(1, random_state=0, **bad)
