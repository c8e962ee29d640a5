"""The laser street simulator: physics, ground truth, determinism, argument checks."""

import functools
import json

import numpy as np
import pandas as pd
import pytest

from tunnelsense import RUN_GT_COLUMNS, LaserGeometry, Run
from tunnelsense.datasets import STREET_SCENARIOS, make_street_scans
from tunnelsense.datasets._street import _simulate
from tunnelsense.datasets._street_sensor import HIT_ROAD, MAX_RANGE, MEASURE_LIMIT

N = 2000


@functools.lru_cache(maxsize=16)
def sim(scenario, seed, n=N, **overrides):
    return _simulate(n, scenario, seed, **overrides)


def points(s, *, true_roll=True):
    """Depth and height of every beam, from the ranges and the geometry (NaN: none)."""
    g = s["geometry"]
    r = s["ranges"]
    theta = g.angles(r.shape[1])[None, :] + (s["roll"][:, None] if true_roll else 0.0)
    rr = np.where(np.isfinite(r) & (r < g.range_max), r, np.nan)
    return rr * np.cos(theta), g.mount_height + rr * np.sin(theta)


def object_index(s):
    """gt id -> index of the simulated object."""
    return {o["id"]: i for i, o in enumerate(s["objects"]) if "id" in o}


@pytest.mark.parametrize("scenario", STREET_SCENARIOS)
def test_every_scenario_runs(scenario, global_random_seed):
    run = make_street_scans(600, scenario=scenario, random_state=global_random_seed)
    assert isinstance(run, Run)
    assert len(run) == 600
    assert run.name == f"street-{scenario}-{global_random_seed}"
    g = run.geometry
    assert isinstance(g, LaserGeometry)
    assert g.range_max == MAX_RANGE
    ranges = run.scans.ranges()
    if scenario != "randomized":  # which draws the angular resolution
        assert np.isclose(np.rad2deg(g.angle_increment), 0.5)
        assert ranges.shape == (600, 241)
    stamps = np.array([r.stamp for r in run.scans])
    assert np.all(np.diff(stamps) > 0)
    assert np.isclose(np.median(np.diff(stamps)), 1 / 75, rtol=0.05)
    gt = run.gt
    assert list(gt.columns) == [*RUN_GT_COLUMNS, "vehicle_class"]
    assert set(gt["vehicle_class"]) <= {"car", "van", "motorbike"}
    assert [str(t) for t in gt.dtypes[:3]] == ["int64"] * 3
    assert set(gt["label"]) <= {"parked", "passing"}
    assert (gt["label"] == "parked").any()
    assert gt["id"].is_unique
    assert ((gt["first_scan"] >= 0) & (gt["first_scan"] <= gt["last_scan"])
            & (gt["last_scan"] < 600)).all()
    info = json.loads(json.dumps(run.info))  # plain JSON-able values
    assert info["scenario"] == scenario
    assert info["seed"] == global_random_seed
    assert 30 < info["speed_kmh_mean"] < 50
    assert info["n_parked"] + info["n_passing"] == len(gt)
    # targets agree with the intervals
    targets = run.targets()
    assert sum(len(t) for t in targets) == int((gt["last_scan"] - gt["first_scan"] + 1).sum())


@pytest.mark.parametrize("scenario", STREET_SCENARIOS)
def test_vehicle_mean_depths_lie_in_their_regions(scenario, global_random_seed):
    """Parked vehicles' ROI returns average 4-6.6 m deep (the near side in the hard and
    randomized streets), passing ones under 4 m."""
    s = sim(scenario, global_random_seed)
    depth, height = points(s)
    roi = (height > 0.1) & (height < 2.0)
    index = object_index(s)
    means = {"parked": [], "passing": []}
    for row in s["gt"].itertuples(index=False):
        mine = (s["hit"] == index[row.id]) & roi
        assert mine.any(), f"vehicle {row.id} has no returns in the region of interest"
        # its returns come from the scans its body crosses the scan plane
        scans = np.nonzero(mine.any(axis=1))[0]
        assert row.first_scan <= scans.min() and scans.max() <= row.last_scan
        # rows half on the sidewalk (hard, randomized): the near side is in region II
        near_side = scenario in ("hard", "randomized") and row.label == "parked"
        means[row.label].append(np.percentile(depth[mine], 5) if near_side
                                else depth[mine].mean())
    parked, passing = np.array(means["parked"]), np.array(means["passing"])
    assert len(parked) >= 5
    low = 3.95 if scenario in ("hard", "randomized") else 4.0  # range noise at 4.0 m
    assert np.all((parked > low) & (parked < 6.6)), parked
    assert np.all(passing < 4.0), passing
    assert np.all(passing > 1.4), passing


def test_crowded_street_has_the_hard_cases():
    """Boundary cars, vans above 2 m, motorbikes, touching bumpers, clutter in region II."""
    s = sim("crowded", 1, 4000)
    depth, height = points(s)
    kinds = {v["kind"] for v in s["info"]["vehicles"]}
    assert {"car", "van", "motorbike"} <= kinds
    index = object_index(s)
    by_where = {}
    for v in s["info"]["vehicles"]:
        mine = (s["hit"] == index[v["id"]]) & (height > 0.1) & (height < 2.0)
        by_where.setdefault(v["where"], []).append(depth[mine].mean())
    assert min(by_where["boundary-near"]) < 4.3
    assert max(by_where["boundary-far"]) > 6.2
    vans = [index[v["id"]] for v in s["info"]["vehicles"] if v["kind"] == "van"]
    assert (height[np.isin(s["hit"], vans)] > 2.05).any()
    parked = s["gt"][s["gt"]["label"] == "parked"].sort_values("first_scan")
    assert (parked["first_scan"].to_numpy()[1:] - parked["last_scan"].to_numpy()[:-1] <= 1).any()
    # pedestrians, bins and bollards: in region II, never in the ground truth
    for kind in ("pedestrian", "bin", "bollard"):
        idx = [i for i, o in enumerate(s["objects"]) if o["kind"] == kind]
        mine = np.isin(s["hit"], idx) & (height > 0.1) & (height < 2.0)
        assert mine.any(), kind
        assert ((depth[mine] > 4.0) & (depth[mine] < 6.6)).mean() > 0.5, kind
        assert not any("id" in s["objects"][i] for i in idx)
    # bushes lie beyond 6.6 m
    bushes = [i for i, o in enumerate(s["objects"]) if o["kind"] == "hedge"]
    assert np.nanmin(depth[np.isin(s["hit"], bushes)]) > 6.6


@pytest.mark.parametrize("scenario", ["sparse", "dense"])
def test_road_is_level_after_the_mount_height(scenario, global_random_seed):
    s = sim(scenario, global_random_seed)
    depth, height = points(s, true_roll=False)  # the nominal geometry only
    near = depth < 1.4  # the first beams, which hit the road next to the vehicle
    assert (near[:, :5] | np.isnan(s["ranges"][:, :5])).all()
    assert near[:, :5].mean() > 0.99
    h = np.abs(height[near])
    assert np.median(h) < 0.012
    assert np.quantile(h, 0.995) < 0.05
    # the whole road, up to the kerb (camber included), stays within +-0.1 m
    road = s["hit"] == HIT_ROAD
    assert np.nanmax(np.abs(height[road])) < 0.1
    assert abs(s["info"]["roll_deg_mean"]) < 0.05


@pytest.mark.parametrize("scenario", ["tilted", "crowded"])
def test_road_is_tilted_by_the_unknown_roll(scenario, global_random_seed):
    s = sim(scenario, global_random_seed)
    depth, height = points(s, true_roll=False)
    near = depth < 1.4
    # the slope of a line fitted to the first road returns (of 25 scans, 1/3 s) gives
    # the roll
    est, true = [], []
    for a in range(0, len(depth), 25):
        d, h, m = depth[a:a + 25], height[a:a + 25], near[a:a + 25]
        slope = np.polyfit(d[m], h[m], 1)[0]
        est.append(-np.degrees(np.arctan(slope)))
        true.append(np.degrees(s["roll"][a:a + 25]).mean())
    est, true = np.array(est), np.array(true)
    # the road's camber (falling toward the kerb) adds a small bias; the drift is tracked
    bias = np.median(est - true)
    assert abs(bias) < 0.3
    assert np.median(np.abs(est - true - bias)) < 0.1
    lo = 2.0 if scenario == "tilted" else 1.0
    assert abs(np.median(est)) > lo - 0.7
    assert abs(np.median(true)) > lo - 0.7
    # it drifts along the run
    smooth = np.convolve(est, np.ones(3) / 3, mode="valid")
    assert np.ptp(smooth) > 0.1
    # with the true roll applied, the near road is level again
    _, level = points(s, true_roll=True)
    assert np.median(np.abs(level[near])) < 0.015
    assert s["geometry"].mount_height == (2.4 if scenario == "tilted" else 2.0)


def test_max_range_returns_are_8191(global_random_seed):
    s = sim("sparse", global_random_seed)
    r = s["ranges"]
    ok = ~np.isnan(r)
    assert np.all((r[ok] <= MEASURE_LIMIT) | (r[ok] == MAX_RANGE))
    assert np.all(r[ok] >= s["geometry"].range_min)
    # the top beams look into the sky: almost all 8.191
    assert (r[:, -20:] == MAX_RANGE).mean() > 0.8
    assert (r == 8.191).sum() > 0.1 * r.size
    # dropouts exist but are rare; ranges come in millimetre steps
    assert 0 < np.isnan(r).mean() < 0.03
    assert np.allclose(r[ok] * 1000, np.round(r[ok] * 1000))
    # noise of 1-3 cm: the near road's heights scatter by about 1 cm
    depth, height = points(s, true_roll=True)
    assert 0.005 < np.nanstd(height[depth < 1.4]) < 0.03


def test_same_seed_same_bytes_other_seed_differs():
    a = make_street_scans(400, scenario="crowded", random_state=7)
    b = make_street_scans(400, scenario="crowded", random_state=7)
    c = make_street_scans(400, scenario="crowded", random_state=8)
    ra, rb, rc = (x.scans.ranges() for x in (a, b, c))
    assert ra.tobytes() == rb.tobytes()
    assert np.array([x.stamp for x in a.scans]).tobytes() == np.array(
        [x.stamp for x in b.scans]).tobytes()
    pd.testing.assert_frame_equal(a.gt, b.gt)
    assert json.dumps(a.info, sort_keys=True) == json.dumps(b.info, sort_keys=True)
    assert ra.tobytes() != rc.tobytes()
    # a run made with random_state=None records a seed that reproduces it
    d = make_street_scans(200, random_state=None)
    e = make_street_scans(200, random_state=d.info["seed"])
    assert d.scans.ranges().tobytes() == e.scans.ranges().tobytes()


def test_scan_intervals_follow_the_speeds():
    """A parked vehicle spans length / ego speed; a passing one length / relative speed."""
    s = sim("dense", 3, 4000)
    rate = s["info"]["scan_rate_hz"]
    gt = s["gt"].set_index("id")
    for veh in s["info"]["vehicles"]:
        row = gt.loc[veh["id"]]
        if row.first_scan == 0 or row.last_scan == len(s["ranges"]) - 1:
            continue  # cut by the start or end of the run
        n = row.last_scan - row.first_scan + 1
        v = s["speed"][row.first_scan:row.last_scan + 1].mean()  # the ego's, meanwhile
        rel = v - veh["speed_kmh"] / 3.6
        expected = veh["length"] / abs(rel) * rate
        assert abs(n - expected) < 0.12 * expected + 2, veh
        if veh["label"] == "passing":
            assert abs(n - veh["length"] / v * rate) > 0.2 * n


def test_overrides_change_the_physics():
    slow = sim("sparse", 5, 2000, speed_kmh=20.0)
    fast = sim("sparse", 5)
    assert 17 < slow["info"]["speed_kmh_mean"] < 23
    assert slow["info"]["distance_m"] < 0.6 * fast["info"]["distance_m"]
    low = sim("sparse", 5, 2000, mount_height=1.6, roll_deg=-2.5)
    assert low["geometry"].mount_height == 1.6
    assert np.isclose(low["info"]["roll_deg_mean"], -2.5, atol=0.05)
    depth, height = points(low, true_roll=True)
    assert np.median(np.abs(height[depth < 1.4])) < 0.015
    empty = sim("sparse", 5, 500, parked_gap_m=1000.0, passing_per_min=0.0)
    assert len(empty["gt"]) <= 1


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"n_scans": 0}, ValueError, "n_scans"),
        ({"n_scans": 10.5}, TypeError, "n_scans"),
        ({"n_scans": "100"}, TypeError, "n_scans"),
        ({"scenario": "foggy"}, ValueError, "scenario.*foggy"),
        ({"sped_kmh": 40}, TypeError, "sped_kmh"),
        ({"speed_kmh": -5}, ValueError, "speed_kmh"),
        ({"speed_kmh": "fast"}, TypeError, "speed_kmh"),
        ({"mount_height": float("nan")}, ValueError, "mount_height"),
        ({"angle_min_deg": -10, "angle_max_deg": -20}, ValueError, "angle_max_deg"),
        ({"random_state": "seed"}, TypeError, "random_state"),
        ({"name": 3}, TypeError, "name"),
    ],
)
def test_bad_arguments_raise_clear_errors(kwargs, error, match):
    kwargs = {"n_scans": 50, **kwargs}
    with pytest.raises(error, match=match):
        make_street_scans(**kwargs)


def test_plots(tmp_path):
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from tunnelsense.plotting import plot_range_image, plot_scan, scan_points

    run = make_street_scans(300, scenario="dense", random_state=0)
    ax = plot_scan(run.scans[10])
    # road points in black, max-range arc in blue: as many points as beams with returns
    offsets = [len(c.get_offsets()) for c in ax.collections]
    r = run.scans[10].ranges
    assert sum(offsets) == np.count_nonzero(~np.isnan(r))
    d, h, none = scan_points(r, run.geometry)
    assert np.all(none == ~(np.isfinite(r) & (r < 8.191)))
    ax2 = plot_range_image(run)
    assert ax2.images[0].get_array().shape == (241, 300)
    with pytest.raises(ValueError, match="geometry"):
        plot_scan(r)
    with pytest.raises(ValueError, match="labels"):
        plot_scan(run.scans[0], labels=np.zeros(3))
    plt.close("all")
