"""Physics of the hard and randomized streets: vans, camber, roll drift, touching
bumpers, the cross-sections of people and bins, reproducible random factors."""

import numpy as np
import pytest

from tunnelsense.datasets import make_street_scans
from tunnelsense.datasets._street import _simulate
from tunnelsense.datasets._street_params import _DRAWN
from tunnelsense.datasets._street_sensor import HIT_ROAD
from tunnelsense.datasets._street_shapes import _PROFILES

QUIET = dict(passing_per_min=0.0, pedestrians_per_100m=0.0, bins_per_100m=0.0,
             bollard_rows_per_100m=0.0, trees_per_100m=0.0, hedge_fraction=0.0)


def heights(s):
    """True height of every beam's return above the road at the vehicle."""
    r = np.where(s["ranges"] < s["geometry"].range_max, s["ranges"], np.nan)
    theta = s["geometry"].angles(r.shape[1])[None, :] + s["roll"][:, None]
    return r * np.cos(theta), s["height"][:, None] + r * np.sin(theta)


def test_van_roof_above_the_roi_body_inside():
    s = _simulate(1500, "sparse", 3, van_fraction=1.0, motorbike_fraction=0.0,
                  van_height_min=2.1, van_height_max=2.3, **QUIET)
    depth, height = heights(s)
    vans = [i for i, o in enumerate(s["objects"]) if o["kind"] == "van" and "id" in o]
    assert vans
    for i in vans:
        h = height[s["hit"] == i]
        assert 2.1 <= max(s["objects"][i]["top_h"]) <= 2.3
        assert np.nanmax(h) > 2.0  # the roof leaves the region of interest
        assert np.mean((h > 0.1) & (h < 2.0)) > 0.5  # the body is inside


def test_cross_fall_tilts_the_road_profile():
    s = _simulate(300, "sparse", 4, cross_fall=0.03, camber_drop=0.0, roll_drift_deg=0.0,
                  parked_gap_m=1000.0, **QUIET)
    depth, height = heights(s)
    road = (s["hit"] == HIT_ROAD) & np.isfinite(depth) & (depth > 0.5)
    slope = np.polyfit(depth[road], height[road], 1)[0]
    assert slope == pytest.approx(-0.03, abs=0.003)


def test_hard_roll_drifts_slowly_within_range():
    s = _simulate(4000, "hard", 5)
    roll = np.rad2deg(s["roll"])
    assert roll.min() > -0.3 and roll.max() < 3.3
    per_second = np.abs(np.diff(roll)) * 75
    assert np.percentile(per_second, 99) < 1.0  # slow (body sway aside)
    assert 0.02 <= s["info"]["params"]["cross_fall"] <= 0.03


def test_touching_pair_has_gap_zero():
    s = _simulate(1500, "hard", 6, touching_fraction=1.0, parked_cluster_size=4.0)
    parked = sorted((o for o in s["objects"] if o["label"] == "parked"),
                    key=lambda o: o["x0"])
    gaps = np.array([b["x0"] - (a["x0"] + a["length"])
                     for a, b in zip(parked, parked[1:], strict=False)])
    assert np.any(gaps == 0.0)
    assert np.all((gaps == 0.0) | (gaps > 1.0))  # touching, or another row


@pytest.mark.parametrize("kind, lo, hi", [("pedestrian", 0.3, 0.6), ("bin", 0.55, 0.7),
                                          ("communal_bin", 0.8, 1.2)])
def test_clutter_cross_sections(kind, lo, hi):
    s = _simulate(1500, "hard", 7, pedestrians_per_100m=20.0, bins_per_100m=5.0,
                  communal_bins_per_100m=5.0)
    found = [o for o in s["objects"] if o["kind"] == kind]
    assert found
    for o in found[:20]:
        boxes = _PROFILES[kind](o, np.array([o["length"] / 2]))[0]
        boxes = boxes[np.isfinite(boxes[:, 0])]
        assert lo <= boxes[:, 1].max() - boxes[:, 0].min() <= hi  # depth across
        if kind != "communal_bin":
            assert o["length"] <= 0.75  # along the street


def test_hard_street_has_groups_walkers_and_bin_rows():
    s = _simulate(3000, "hard", 8)
    peds = [o for o in s["objects"] if o["kind"] == "pedestrian"]
    assert any(o["speed"] != 0 and 4.0 <= o["depth_near"] <= 4.3 for o in peds)
    kinds = {o["kind"] for o in s["objects"]}
    assert {"bin", "communal_bin", "bollard", "small", "van", "motorbike"} <= kinds
    labels = {o["label"] for o in s["objects"] if o["kind"] == "motorbike"
              and o["speed"] == 0}
    assert labels == {"parked"}


@pytest.mark.slow
def test_randomized_is_reproducible_by_seed_and_draws_its_factors():
    a = make_street_scans(400, scenario="randomized", random_state=9)
    b = make_street_scans(400, scenario="randomized", random_state=9)
    c = make_street_scans(400, scenario="randomized", random_state=10)
    assert np.array_equal(a.scans.ranges(), b.scans.ranges(), equal_nan=True)
    assert a.info["params"] == b.info["params"] != c.info["params"]
    for key, (lo, hi) in _DRAWN["randomized"].items():
        assert lo <= a.info["params"][key] <= hi, key
    fixed = make_street_scans(400, scenario="randomized", random_state=9,
                              mount_height=2.0)
    assert fixed.info["params"]["mount_height"] == 2.0
    assert fixed.info["params"]["roll_deg"] == a.info["params"]["roll_deg"]


def test_pitch_leans_the_scan_plane_and_drifts():
    kw = dict(pitch_deg=8.0, pitch_drift_deg=1.0, roll_drift_deg=0.0, camber_drop=0.0,
              parked_gap_m=1000.0, **QUIET)
    s = _simulate(1500, "sparse", 11, **kw)
    pitch = np.rad2deg(s["pitch"])
    assert 6.9 < pitch.min() < pitch.max() < 9.1 and pitch.max() - pitch.min() > 0.2
    assert s["info"]["pitch_deg_max"] == pytest.approx(pitch.max(), abs=1e-3)
    # a leaning plane reaches the road farther: range = height / (-sin(theta) cos(pitch))
    r = np.where(s["hit"] == HIT_ROAD, s["ranges"], np.nan)
    theta = s["geometry"].angles(r.shape[1])[None, :] + s["roll"][:, None]
    level = s["height"][:, None] + r * np.sin(theta)
    leaned = s["height"][:, None] + r * np.sin(theta) * np.cos(s["pitch"])[:, None]
    near = np.isfinite(r) & (r < 4.0)
    assert abs(np.nanmedian(leaned[near])) < 0.005
    assert np.nanmedian(level[near]) < -0.01  # 2 m x (1 / cos 8 deg - 1)
    # no pitch: nothing drawn for it, the run unchanged
    flat = _simulate(300, "sparse", 11)
    assert not flat["pitch"].any() and "pitch_deg_max" not in flat["info"]


def test_stop_and_go_brakes_stands_and_drives_on_with_the_speed_in_the_scans():
    base = _simulate(3000, "sparse", 12, **QUIET)
    kw = dict(stops_per_min=2.0, stop_duration_s=10.0)
    s = _simulate(3000, "sparse", 12, **QUIET, **kw)
    v, t, x = s["speed"], s["stamps"], s["x"]
    standing = v == 0
    assert standing.any() and not standing[0] and not standing[-1]
    # one stop in every 30 s of a 40 s run: one or two stands of 5-15 s each
    edges = np.flatnonzero(np.diff(standing.astype(int)))
    stands = [t[b] - t[a] for a, b in zip(edges[::2], edges[1::2], strict=False)]
    assert 1 <= len(stands) <= 2 and all(4.9 < d < 15.1 for d in stands)
    assert np.all(np.diff(x) >= 0) and np.all(np.diff(x)[standing[1:] & standing[:-1]] == 0)
    # braking and accelerating: at most 3 m/s2 down, 2 m/s2 up (between scans)
    dv = np.diff(v) / np.diff(t)
    assert dv.min() > -3.1 and dv.max() < 2.1 + 1.0  # (+ the slow speed changes)
    # before the first braking the run is the one without stops
    brake = int(np.flatnonzero(v < base["speed"])[0])
    assert brake > 0 and np.array_equal(v[:brake], base["speed"][:brake])
    run = make_street_scans(3000, scenario="sparse", random_state=12, **QUIET, **kw)
    assert np.array_equal([r.payload["speed"] for r in run.scans], v)
    assert run.info["speed_kmh_min"] == 0.0
    with pytest.raises(ValueError, match="stops_per_min"):
        make_street_scans(100, stops_per_min=-1.0)
