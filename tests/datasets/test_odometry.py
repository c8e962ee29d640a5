"""Physics of the simulated positions, odometry and indicator map."""

import numpy as np
import pytest

from tunnelsense.datasets import (
    make_tunnel_kinematics,
    make_tunnel_odometry,
    make_tunnel_tour,
    simulate_indicator_detections,
)
from tunnelsense.io import read_tour, write_tour
from tunnelsense.positioning import (
    dead_reckoning,
    estimate_pass,
    read_indicator_map,
    read_odometry,
    read_positions,
)


@pytest.fixture(scope="module")
def tour():
    # 300 frames at 90 km/h: 250 m, indicators at 60 m and 260 m
    return make_tunnel_tour(300, random_state=7, first_indicator_m=60.0, speed_kmh=90.0)


@pytest.mark.slow
def test_true_speed_integrates_to_the_chainage(tour):
    positions, odometry, _ = make_tunnel_odometry(tour, scale_error=0.0, speed_bias=0.0,
                                                  speed_noise=0.0)
    s = positions["chainage"].to_numpy()
    dt = np.diff(positions["stamp"].to_numpy())
    np.testing.assert_allclose(np.diff(s), odometry["speed"].to_numpy()[:-1] * dt,
                               rtol=1e-12)
    assert s[0] == 0.0
    # the tour's distance is the last chainage plus the last frame's step
    assert s[-1] + odometry["speed"].iloc[-1] / 30 == pytest.approx(
        tour.info["distance_m"], abs=1e-3)
    np.testing.assert_allclose(positions["stamp"], np.arange(300) / 30.0)
    assert positions["frame"].tolist() == list(range(1, 301))


def test_odometry_distance_is_off_by_the_scale_error(global_random_seed):
    truth = make_tunnel_kinematics(2000.0, random_state=global_random_seed)
    for scale in (-0.02, 0.03, 0.05):
        positions, odometry, _ = make_tunnel_odometry(
            truth, scale_error=scale, speed_bias=0.0, speed_noise=0.1,
            random_state=global_random_seed)
        true = positions["chainage"].iloc[-1]
        odo = dead_reckoning(odometry)[-1]
        # white speed noise: the distance's sd is 0.1 m/s * dt * sqrt(n)
        sd = 0.1 / 30 * np.sqrt(len(odometry))
        assert abs(odo - (1 + scale) * true) < 4 * sd + 1e-9
        # the bias adds speed_bias * time
        _, biased = make_tunnel_odometry(truth, scale_error=scale, speed_bias=0.2,
                                         speed_noise=0.0)[:2]
        duration = positions["stamp"].iloc[-1]
        assert dead_reckoning(biased)[-1] == pytest.approx(
            (1 + scale) * true + 0.2 * duration, rel=1e-9)


def test_yaw_rate_follows_the_curve():
    truth = make_tunnel_kinematics(1000.0, curve_radius_m=1500.0, random_state=0)
    _, odometry, _ = make_tunnel_odometry(truth, yaw_bias=0.0, yaw_noise=0.0)
    np.testing.assert_allclose(odometry["yaw_rate"], np.asarray(truth.speed) / 1500.0)


def test_indicator_map_spacing(tour):
    _, _, indicators = make_tunnel_odometry(tour)
    c = indicators["chainage"].to_numpy()
    assert c[0] == pytest.approx(60.0)
    np.testing.assert_allclose(np.diff(c), tour.info["indicator_spacing_m"])
    assert (indicators["side"] == "left").all()
    assert set(indicators["id"]) >= set(tour.gt.loc[tour.gt["class"] == 1, "id"])


def test_indicators_pass_the_camera_where_the_map_says(tour):
    """A sign's gt box height is f H / depth: 1/h reaches 0 at its map chainage."""
    positions, _, indicators = make_tunnel_odometry(tour)
    s = positions["chainage"].to_numpy()
    signs = tour.gt[tour.gt["class"] == 1]
    checked = 0
    for oid, track in signs.groupby("id"):
        track = track[track["bb_height"] >= 8].sort_values("frame")
        if len(track) < 10:
            continue
        where = s[track["frame"].to_numpy() - 1]
        passed, _ = estimate_pass(where, track["bb_height"].to_numpy())
        expected = indicators.loc[indicators["id"] == oid, "chainage"].item()
        assert passed == pytest.approx(expected, abs=0.15)
        # and the box height matches the pinhole model with the 1.0 m sign
        depth = expected - where
        np.testing.assert_allclose(track["bb_height"], 800.0 / depth, rtol=0.01)
        checked += 1
    assert checked == 2


@pytest.mark.slow
def test_odometry_does_not_touch_the_renderer(tour):
    """The same seed gives the same frames, gt and odometry; odometry is separate."""
    again = make_tunnel_tour(300, random_state=7, first_indicator_m=60.0, speed_kmh=90.0)
    assert np.array_equal(tour.frames[150].image, again.frames[150].image)
    a = make_tunnel_odometry(tour)[1]
    b = make_tunnel_odometry(again)[1]
    assert a.equals(b)
    other = make_tunnel_odometry(tour, random_state=1)[1]
    assert not a["speed"].equals(other["speed"])


def test_write_tour_writes_the_tables(tour, tmp_path):
    write_tour(tour, tmp_path / "t")
    positions, odometry, indicators = make_tunnel_odometry(tour)
    assert read_positions(tmp_path / "t" / "positions.csv").equals(positions)
    np.testing.assert_array_equal(read_odometry(tmp_path / "t" / "odometry.csv"),
                                  odometry)
    got = read_indicator_map(tmp_path / "t" / "indicators.csv")
    assert got.equals(indicators)
    # a tour read back has no kinematics; its tables are on disk
    back = read_tour(tmp_path / "t")
    assert getattr(back, "kinematics", None) is None
    with pytest.raises(TypeError, match="positions.csv"):
        make_tunnel_odometry(back)


def test_odometry_parameters_are_checked(tour):
    with pytest.raises(ValueError, match="scale_error"):
        make_tunnel_odometry(tour, scale_error=2.0)
    with pytest.raises(ValueError, match="speed_noise"):
        make_tunnel_odometry(tour, speed_noise=-1.0)


def test_statistical_detections_follow_the_pinhole_model():
    truth = make_tunnel_kinematics(1000.0, first_indicator_m=100.0, random_state=3)
    det = simulate_indicator_detections(truth, box_noise=0.0, missed=[2],
                                        false_alarms=[350.0], random_state=0)
    ids = set(det["id"])
    assert 2 not in ids and 1 in ids
    assert max(ids) == len(truth.indicator_ids) + 1  # the false alarm
    s = np.asarray(truth.chainage)
    one = det[det["id"] == 1]
    depth = 100.0 - s[one["frame"].to_numpy() - 1]
    np.testing.assert_allclose(one["bb_height"], 800.0 / depth)
    assert depth.min() >= 9.3 and one["bb_height"].min() >= 12.0


def test_a_tour_started_mid_tunnel_on_an_irregular_map(global_random_seed):
    """Chainages are the tunnel's: the tour starts 1 km in; gaps drawn from a range."""
    truth = make_tunnel_kinematics(2000.0, start_chainage_m=1000.0,
                                   indicator_spacing_m=(150.0, 250.0),
                                   random_state=global_random_seed)
    regular = make_tunnel_kinematics(2000.0, random_state=global_random_seed)
    s = np.asarray(truth.chainage)
    # the same motion, shifted by the start
    np.testing.assert_allclose(s - 1000.0, regular.chainage, atol=1e-9)
    gaps = np.diff(truth.indicator_chainage)
    assert gaps.min() >= 150.0 and gaps.max() <= 250.0 and gaps.std() > 15.0
    # the map covers the tunnel behind the start and 300 m past the end
    assert truth.indicator_chainage[0] < 270.0
    assert s[-1] < truth.indicator_chainage[-1] <= s[-1] + 300.0
    positions, odometry, indicators = make_tunnel_odometry(
        truth, scale_error=0.0, speed_bias=0.0, speed_noise=0.0)
    assert positions["chainage"].iloc[0] == 1000.0
    np.testing.assert_allclose(dead_reckoning(odometry, initial_chainage=1000.0), s,
                               atol=1e-6)
    # signs behind the start are never seen; each one ahead passes where the map says
    det = simulate_indicator_detections(truth, box_noise=0.0, random_state=0)
    seen = indicators.set_index("id").loc[sorted(set(det["id"])), "chainage"]
    assert seen.min() > 1000.0
    for oid, track in det.groupby("id"):
        where = s[track["frame"].to_numpy() - 1]
        passed, _ = estimate_pass(where, track["bb_height"].to_numpy())
        assert passed == pytest.approx(seen[oid], abs=1e-6)
    with pytest.raises(ValueError, match="indicator_spacing_m"):
        make_tunnel_kinematics(100.0, indicator_spacing_m=(250.0, 150.0))
