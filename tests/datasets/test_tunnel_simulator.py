"""Physics checks of the far-infrared tunnel simulator (issue 3, FIR half)."""

import numpy as np
import pandas as pd
import pytest

from tunnelsense import MOT_GT_COLUMNS, Tour
from tunnelsense.datasets import TUNNEL_SCENARIOS, make_tunnel_tour

BAND = (160, 190)


@pytest.fixture(scope="module")
def straight_tour():
    # 300 frames at 90 km/h: 250 m, the first indicator 60 m ahead is driven past
    return make_tunnel_tour(
        300, scenario="heavy", random_state=7, first_indicator_m=60.0, speed_kmh=90.0
    )


def _stack(tour):
    return np.stack([r.image for r in tour.frames])


def _interior(images, row, margin=1):
    """Pixels of a gt box, ``margin`` px inside its edges (edge pixels are mixed)."""
    h, w = images.shape[1:]
    top, left = row.bb_top, row.bb_left
    i0 = max(int(np.ceil(top)) + margin, 0)
    i1 = min(int(np.floor(top + row.bb_height)) - margin, h)
    j0 = max(int(np.ceil(left)) + margin, 0)
    j1 = min(int(np.floor(left + row.bb_width)) - margin, w)
    return images[int(row.frame) - 1, i0:i1, j0:j1]


def _tracks(gt, cls):
    for _, track in gt[gt["class"] == cls].groupby("id"):
        yield track.sort_values("frame")


def _centres(track):
    cx = (track.bb_left + track.bb_width / 2).to_numpy()
    cy = (track.bb_top + track.bb_height / 2).to_numpy()
    return cx, cy


@pytest.mark.slow
def test_tour_structure(straight_tour):
    tour = straight_tour
    assert isinstance(tour, Tour)
    assert len(tour) == 300
    images = _stack(tour)
    assert images.dtype == np.uint8 and images.shape == (300, 480, 640)
    gt = tour.gt
    assert list(gt.columns) == list(MOT_GT_COLUMNS)
    assert gt["frame"].between(1, 300).all()
    assert set(gt["class"].unique()) == {1, 2, 3, 4}
    assert (gt["conf"] == 1).all()
    assert gt["visibility"].between(0, 1, inclusive="right").all()
    assert (gt["bb_height"] >= 2).all() and (gt["bb_width"] > 0).all()
    # ids are persistent and belong to one class each
    assert (gt.groupby("id")["class"].nunique() == 1).all()
    assert not gt.duplicated(["frame", "id"]).any()
    # background: walls, road and arch lie at 80-125 grey levels
    median = np.median(images[:, 300:, :])
    assert 80 <= median <= 125
    for key in ("scenario", "seed", "focal_length_px", "mount_height_m", "distance_m"):
        assert isinstance(tour.info[key], str | int | float)
    assert tour.info["scenario"] == "heavy" and tour.info["seed"] == 7


def test_indicator_pixels_in_band(straight_tour):
    images = _stack(straight_tour)
    gt = straight_tour.gt
    big = gt[(gt["class"] == 1) & (gt["bb_height"] > 20) & (gt["visibility"] >= 1)]
    assert len(big) > 20
    fractions = []
    for row in big.itertuples():
        patch = _interior(images, row)
        fractions.append(np.mean((patch >= BAND[0]) & (patch <= BAND[1])))
    assert min(fractions) >= 0.9


def test_indicator_grows_to_about_80px_and_leaves(straight_tour):
    gt = straight_tour.gt
    passed = 0
    for track in _tracks(gt, 1):
        full = track[track["visibility"] >= 1]
        if track["visibility"].iloc[-1] < 1 and len(full):
            passed += 1
            assert 60 <= full["bb_height"].max() <= 100
            # it leaves through the left edge, away from the vanishing point
            assert track["bb_left"].iloc[-1] < 0
    assert passed >= 1


def test_indicator_trajectories_straight(straight_tour):
    long_tracks = [t for t in _tracks(straight_tour.gt, 1) if len(t) >= 30]
    assert long_tracks
    for track in long_tracks:
        cx, cy = _centres(track)
        assert abs(np.corrcoef(cx, cy)[0, 1]) > 0.99


def test_some_lamp_passes_through_band(straight_tour):
    images = _stack(straight_tour)
    gt = straight_tour.gt
    in_band_far = saturated_near = 0
    for track in _tracks(gt, 2):
        peaks = np.array(
            [
                _interior(images, row, margin=0).max(initial=0)
                for row in track.itertuples()
            ]
        )
        heights = track["bb_height"].to_numpy()
        far = (peaks >= BAND[0]) & (peaks <= BAND[1]) & (heights < 6)
        near = (peaks == 255) & (heights > 10)
        in_band_far += bool(far.any() and near.any())
        saturated_near += bool(near.any())
    assert saturated_near >= 5
    assert in_band_far >= 1
    # near lamps: the glow's ring around the saturated glass passes through the band
    near_rows = gt[(gt["class"] == 2) & (gt["bb_height"] > 15) & (gt["visibility"] >= 1)]
    ring = 0
    for row in near_rows.itertuples():
        top = int(row.bb_top + row.bb_height) + 1
        left, right = int(row.bb_left), int(row.bb_left + row.bb_width)
        below = images[int(row.frame) - 1, top : top + 12, max(left, 0) : right]
        ring += bool(np.any((below >= BAND[0]) & (below <= BAND[1])))
    assert ring >= 0.5 * len(near_rows) > 0


def test_vehicles_move_less_than_indicators(straight_tour):
    gt = straight_tour.gt

    def mean_steps(cls, complete):
        out = []
        for track in _tracks(gt, cls):
            if len(track) < 10 or (complete and track["visibility"].iloc[-1] >= 1):
                continue
            cx, cy = _centres(track)
            out.append(np.mean(np.hypot(np.diff(cx), np.diff(cy))))
        return np.array(out)

    vehicles = mean_steps(3, complete=False)
    indicators = mean_steps(1, complete=True)  # tracks driven past
    assert len(vehicles) >= 3 and len(indicators) >= 1
    assert np.median(vehicles) < np.min(indicators)


@pytest.mark.slow
def test_indicator_count_matches_distance():
    # a small image keeps this fast; the count is geometry, not resolution
    small = {"image_shape": (96, 128), "focal_length_px": 160.0, "traffic_per_km": 0.0}
    for seed, n_frames in [(0, 240), (1, 650)]:
        tour = make_tunnel_tour(n_frames, random_state=seed, **small)
        info = tour.info
        expected = info["distance_m"] / info["indicator_spacing_m"]
        assert abs(info["n_indicators_passed"] - expected) < 1
        ids = tour.gt.loc[tour.gt["class"] == 1, "id"].nunique()
        assert ids == info["n_indicators"] >= 1
        # plus those still ahead (within 300 m) at the end of the tour
        assert 0 <= ids - info["n_indicators_passed"] <= 2


def test_same_seed_identical_other_seed_differs():
    a = make_tunnel_tour(25, random_state=3)
    b = make_tunnel_tour(25, random_state=3)
    c = make_tunnel_tour(25, random_state=4)
    assert np.array_equal(_stack(a), _stack(b))
    pd.testing.assert_frame_equal(a.gt, b.gt)
    assert a.info == b.info
    assert not np.array_equal(_stack(a), _stack(c))
    assert not a.gt.equals(c.gt)


@pytest.mark.parametrize("scenario", TUNNEL_SCENARIOS)
def test_every_scenario_runs(scenario, global_random_seed):
    tour = make_tunnel_tour(12, scenario=scenario, random_state=global_random_seed)
    assert len(tour) == 12 and tour.info["scenario"] == scenario
    assert tour.name == f"tunnel-{scenario}-{global_random_seed}"
    assert (tour.gt["class"] == 2).any()


def test_curved_scenario_is_another_camera():
    assert {"light", "heavy", "curved"} <= set(TUNNEL_SCENARIOS)
    light = make_tunnel_tour(2, scenario="light", random_state=0).info
    curved = make_tunnel_tour(2, scenario="curved", random_state=0).info
    for key in ("focal_length_px", "mount_height_m", "noise_sigma", "curve_radius_m"):
        assert light[key] != curved[key]


def test_overrides_change_the_physics():
    tour = make_tunnel_tour(
        4, random_state=0, focal_length_px=500.0, speed_kmh=(72.0, 72.0), name="x"
    )
    assert tour.name == "x"
    assert tour.info["focal_length_px"] == 500.0
    assert tour.info["speed_kmh_min"] == pytest.approx(72.0)
    assert tour.info["distance_m"] == pytest.approx(4 * 20.0 / 30.0, abs=1e-3)


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"n_frames": 0}, ValueError, "n_frames"),
        ({"n_frames": 2.5}, ValueError, "n_frames"),
        ({"scenario": "foggy"}, ValueError, "light"),
        ({"bogus_param": 1}, TypeError, "bogus_param"),
        ({"speed_kmh": (90, 60)}, ValueError, "speed_kmh"),
        ({"focal_length_px": -1}, ValueError, "focal_length_px"),
        ({"noise_sigma": "loud"}, TypeError, "noise_sigma"),
        ({"curve_radius_m": 10}, ValueError, "curve_radius_m"),
        ({"image_shape": (480,)}, ValueError, "image_shape"),
        ({"random_state": -3}, ValueError, "random_state"),
    ],
)
def test_bad_arguments(kwargs, error, match):
    kwargs = {"n_frames": 2, **kwargs}
    with pytest.raises(error, match=match):
        make_tunnel_tour(**kwargs)
