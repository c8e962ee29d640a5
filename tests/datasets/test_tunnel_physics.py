"""Physics of the tunnel simulator's camera, sensor and tunnel parameters."""

import math

import numpy as np
import pytest

from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.datasets._tunnel_params import RANDOMIZED_RANGES, _randomized

STILL = dict(first_indicator_m=60.0, lateral_jitter_m=0.0, pitch_jitter_deg=0.0,
             traffic_per_km=0.0, speed_kmh=80.0)


def _indicator(tour, frame=1):
    gt = tour.gt
    rows = gt[(gt["class"] == 1) & (gt["frame"] == frame)]
    return rows.loc[rows["bb_height"].idxmax()]  # the nearest sign


def _images(tour):
    return np.stack([r.image for r in tour.frames]).astype(np.float64)


def test_focal_length_scales_sign_as_f_over_z():
    a = _indicator(make_tunnel_tour(1, random_state=3, focal_length_px=800.0, **STILL))
    b = _indicator(make_tunnel_tour(1, random_state=3, focal_length_px=560.0, **STILL))
    assert b["bb_height"] / a["bb_height"] == pytest.approx(560 / 800, rel=0.02)
    # a 1.0 m sign 60 m ahead: f * 1.0 / Z
    assert a["bb_height"] == pytest.approx(800 * 1.0 / 60.0, rel=0.05)


def test_sign_size_parameter_scales_its_image():
    a = _indicator(make_tunnel_tour(1, random_state=3, **STILL))
    b = _indicator(make_tunnel_tour(1, random_state=3, indicator_size_m=(0.45, 1.5),
                                    **STILL))
    assert b["bb_height"] / a["bb_height"] == pytest.approx(1.5, rel=0.03)


@pytest.mark.parametrize("radius", [1500.0, -1500.0])
def test_curve_moves_sign_towards_its_inside(radius):
    """A curve to the right (radius > 0) moves what is ahead to the right."""
    kw = dict(STILL, first_indicator_m=120.0)
    straight = _indicator(make_tunnel_tour(1, random_state=4, **kw))
    curved = _indicator(make_tunnel_tour(1, random_state=4, curve_radius_m=radius, **kw))
    shift = (curved["bb_left"] + curved["bb_width"] / 2) - (
        straight["bb_left"] + straight["bb_width"] / 2
    )
    # lateral offset of the road 120 m ahead: Z^2 / (2 R), seen at f / Z
    expected = 800.0 * 120.0 / (2 * radius)
    assert np.sign(shift) == np.sign(radius)
    assert shift == pytest.approx(expected, rel=0.2)


def test_static_pitch_moves_scene_down():
    a = _indicator(make_tunnel_tour(1, random_state=3, **STILL))
    b = _indicator(make_tunnel_tour(1, random_state=3, pitch_deg=1.0, **STILL))
    assert b["bb_top"] - a["bb_top"] == pytest.approx(800 * math.tan(math.radians(1)),
                                                      rel=0.1)


@pytest.mark.parametrize("sigma", [3.0, 5.0])
def test_noise_sigma_is_measured_on_the_walls(sigma):
    kw = dict(STILL, first_indicator_m=250.0)
    clean = _images(make_tunnel_tour(2, random_state=5, noise_sigma=0.0, **kw))
    noisy = _images(make_tunnel_tour(2, random_state=5, noise_sigma=sigma, **kw))
    diff = (noisy - clean)[:, 100:380, 20:620]
    # rounding adds 1/12 of a grey level squared to each image's variance
    assert diff.std() == pytest.approx(math.sqrt(sigma**2 + 1 / 6), rel=0.05)
    # white noise: neighbouring pixels are uncorrelated
    assert abs(np.corrcoef(diff[:, :, :-1].ravel(), diff[:, :, 1:].ravel())[0, 1]) < 0.05


def test_correlated_noise_has_its_correlation_length():
    kw = dict(STILL, first_indicator_m=250.0)
    clean = _images(make_tunnel_tour(1, random_state=6, noise_sigma=0.0, **kw))
    noisy = _images(make_tunnel_tour(1, random_state=6, noise_sigma=8.0,
                                     noise_corr_px=2.0, **kw))
    diff = (noisy - clean)[0, 100:380, 20:620]
    assert diff.std() == pytest.approx(8.0, rel=0.08)
    # a Gaussian kernel of sigma s correlates lag d by exp(-d^2 / (4 s^2))
    for lag in (1, 2, 4):
        r = np.corrcoef(diff[:, :-lag].ravel(), diff[:, lag:].ravel())[0, 1]
        assert r == pytest.approx(math.exp(-(lag**2) / 16.0), abs=0.05)


def test_gain_and_offset_map_the_scene():
    kw = dict(STILL, noise_sigma=0.0, fpn_sigma=0.0)
    a = _images(make_tunnel_tour(1, random_state=7, **kw))[0]
    b = _images(make_tunnel_tour(1, random_state=7, gain=1.2, offset=-10.0, **kw))[0]
    centre = (slice(220, 260), slice(300, 340))  # vignetting adds about 3 here
    vig = 3.0
    want = 1.2 * (a[centre] - vig) - 10.0 + vig
    assert np.abs(b[centre] - want).max() <= 1.5


def test_fixed_pattern_noise_level():
    kw = dict(STILL, noise_sigma=0.0)
    a = _images(make_tunnel_tour(1, random_state=8, fpn_sigma=0.0, **kw))[0]
    b = _images(make_tunnel_tour(1, random_state=8, fpn_sigma=4.0, **kw))[0]
    columns = (b - a)[100:380].mean(0)
    assert columns.std() == pytest.approx(4.0, rel=0.15)


def test_randomized_scenario_draws_within_ranges_and_by_seed():
    draws = [_randomized(seed) for seed in range(60)]
    for d in draws:
        for key in ("focal_length_px", "mount_height_m", "noise_sigma", "gain",
                    "offset", "noise_corr_px", "lamp_spacing_m", "traffic_per_km"):
            lo, hi = RANDOMIZED_RANGES[key]
            assert lo <= d[key] <= hi
        if not math.isinf(d["curve_radius_m"]):
            lo, hi = RANDOMIZED_RANGES["curve_radius_m"]
            assert lo <= abs(d["curve_radius_m"]) <= hi
    radii = [d["curve_radius_m"] for d in draws]
    assert any(math.isinf(r) for r in radii)
    assert any(r > 0 and not math.isinf(r) for r in radii)
    assert any(r < 0 and not math.isinf(r) for r in radii)
    a = make_tunnel_tour(3, scenario="randomized", random_state=9)
    b = make_tunnel_tour(3, scenario="randomized", random_state=9)
    c = make_tunnel_tour(3, scenario="randomized", random_state=10)
    assert np.array_equal(_images(a), _images(b)) and a.info == b.info
    assert a.info["focal_length_px"] != c.info["focal_length_px"]
    # the focal length of the sensor drawn (a 320x240 one has half of it)
    drawn = _randomized(9)
    assert a.info["focal_length_px"] == pytest.approx(
        drawn["focal_length_px"] * drawn["sensor_scale"])
    # an override replaces the drawn value
    d = make_tunnel_tour(1, scenario="randomized", random_state=9, noise_sigma=1.0)
    assert d.info["noise_sigma"] == 1.0


@pytest.mark.parametrize("bad", [dict(noise_corr_px=-1.0), dict(gain=0.0),
                                 dict(indicator_size_m=(0.4,)), dict(pitch_deg=30.0)])
def test_bad_physical_parameters_are_refused(bad):
    name = next(iter(bad))
    with pytest.raises(ValueError, match=name):
        make_tunnel_tour(1, random_state=0, **bad)


@pytest.mark.parametrize("radius", [5000.0, -5000.0])
def test_change_of_grade_lifts_or_lowers_what_is_ahead(radius):
    """A sag (radius > 0) raises the road ahead by Z^2 / 2R: the sign moves up."""
    kw = dict(STILL, first_indicator_m=150.0)
    flat = _indicator(make_tunnel_tour(1, random_state=3, **kw))
    graded = _indicator(make_tunnel_tour(1, random_state=3,
                                         vertical_curve_radius_m=radius, **kw))
    shift = graded["bb_top"] - flat["bb_top"]
    assert shift == pytest.approx(-800.0 * 150.0 / (2 * radius), rel=0.05)
    with pytest.raises(ValueError, match="vertical_curve_radius_m"):
        make_tunnel_tour(1, random_state=0, vertical_curve_radius_m=100.0)
