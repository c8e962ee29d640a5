"""The simulator's conditions no scenario uses: cars in angled bays, caravans, a wet
road and walls at the back of the footway.  Off by default (a run stays as it was);
what the scanner sees of them is what the geometry says."""

import numpy as np
import pytest

from tunnelsense.datasets import make_street_scans
from tunnelsense.datasets._street import _simulate
from tunnelsense.datasets._street_sensor import HIT_ROAD, MAX_RANGE

QUIET = dict(passing_per_min=0.0, pedestrians_per_100m=0.0, bins_per_100m=0.0,
             bollard_rows_per_100m=0.0, trees_per_100m=0.0, hedge_fraction=0.0)


def _coords(sim):
    theta = sim["geometry"].angles(sim["ranges"].shape[1])[None, :] + sim["roll"][:, None]
    with np.errstate(invalid="ignore"):
        depth = sim["ranges"] * np.cos(theta)
        height = sim["height"][:, None] + sim["ranges"] * np.sin(theta)
    return depth, height


@pytest.mark.parametrize("factor", ["angled_row_fraction", "caravan_fraction",
                                    "wet_road_fraction", "wall_fraction"])
def test_new_factors_at_zero_leave_a_run_unchanged(factor):
    a = make_street_scans(300, scenario="hard", random_state=3)
    b = make_street_scans(300, scenario="hard", random_state=3, **{factor: 0.0})
    assert np.array_equal(np.stack([s.ranges for s in a.scans]),
                          np.stack([s.ranges for s in b.scans]), equal_nan=True)
    assert a.info == b.info
    assert factor not in a.info["params"]


@pytest.mark.parametrize("angle", [90.0, 45.0])
def test_cars_in_angled_bays_span_their_footprint(angle):
    sim = _simulate(1500, "sparse", 5, angled_row_fraction=1.0, bay_angle_deg=angle,
                    kerb_depth=7.5, parked_cluster_size=4.0, **QUIET)
    depth, height = _coords(sim)
    checked = 0
    for i, o in enumerate(sim["objects"]):
        if o.get("where") != "angled-bay":
            continue
        L, W, phi = o["car_length"], o["car_width"], o["bay_angle"]
        # the footprint's extents along and across the street
        assert o["length"] == pytest.approx(L * abs(np.cos(phi)) + W * np.sin(phi))
        assert o["width"] == pytest.approx(L * np.sin(phi) + W * abs(np.cos(phi)))
        assert 7.5 - 0.3 - 1e-9 <= o["depth_near"] + o["width"] <= 7.5 - 0.1 + 1e-9
        on = (sim["hit"] == i) & (sim["ranges"] < MAX_RANGE)
        scans = np.flatnonzero(on.any(axis=1))
        if len(scans) < 10 or scans[0] == 0 or scans[-1] == len(sim["x"]) - 1:
            continue
        checked += 1
        seen = sim["x"][scans[-1]] - sim["x"][scans[0]]
        step = np.median(np.diff(sim["x"]))
        assert seen <= o["length"] + 2 * step  # never seen beyond the footprint
        d = depth[on]
        # the returns lie inside the footprint's depth, and the near end is seen
        assert d.min() >= o["depth_near"] - 0.1
        assert d.max() <= o["depth_near"] + o["width"] + 0.1
        # deep across the street (the far end may hide behind the roof)
        assert d.max() - d.min() > 1.5
        assert 1.2 < height[on].max() < 1.7
    assert checked >= 5


def test_caravans_are_tall_boxes_on_one_axle_classed_as_vans():
    sim = _simulate(3000, "sparse", 6, caravan_fraction=0.6, parked_cluster_size=3.0,
                    **QUIET)
    vans = [v for v in sim["info"]["vehicles"] if v["kind"] == "caravan"]
    assert len(vans) >= 3
    assert all(5.0 <= v["length"] <= 7.9 and 2.3 <= v["height"] <= 2.7 for v in vans)
    ids = {v["id"] for v in vans}
    assert set(sim["gt"].loc[sim["gt"]["id"].isin(ids), "vehicle_class"]) == {"van"}
    depth, height = _coords(sim)
    for i, o in enumerate(sim["objects"]):
        if o["kind"] != "caravan":
            continue
        on = (sim["hit"] == i) & (sim["ranges"] < MAX_RANGE)
        if on.sum() > 50:
            # a box: the returns reach above the 2 m region of interest
            assert np.nanmax(height[on]) > 2.0


def test_a_wet_road_returns_nothing_in_patches_and_leaves_the_rest():
    dry = _simulate(800, "sparse", 7)
    wet = _simulate(800, "sparse", 7, wet_road_fraction=0.5)
    road = dry["hit"] == HIT_ROAD
    lost = road & (wet["hit"] != HIT_ROAD)
    assert 0.35 < lost.sum() / road.sum() < 0.65
    assert np.all(wet["ranges"][lost] == MAX_RANGE)
    assert np.array_equal(wet["ranges"][~lost], dry["ranges"][~lost], equal_nan=True)
    # in patches: a lost beam's neighbour on the road is mostly lost too
    both = road[:, 1:] & road[:, :-1]
    assert (lost[:, 1:] & lost[:, :-1])[both].sum() > 0.6 * lost[:, 1:][both].sum()
    flooded = _simulate(300, "sparse", 7, wet_road_fraction=1.0)
    assert not np.any(flooded["hit"] == HIT_ROAD)


def test_walls_stand_just_behind_the_kerb_above_the_footway():
    sim = _simulate(2000, "sparse", 8, wall_fraction=1.0, **QUIET)
    walls = [i for i, o in enumerate(sim["objects"]) if o["kind"] == "wall"]
    assert walls
    depth, height = _coords(sim)
    kerb, kh = 6.45, 0.13
    on = np.isin(sim["hit"], walls) & (sim["ranges"] < MAX_RANGE)
    assert on.any(axis=1).mean() > 0.8  # most of the street has a wall
    # its face 0.1-0.5 m behind the kerb, its top 0.25 m thick
    assert np.all((depth[on] > kerb + 0.1 - 0.12) & (depth[on] < kerb + 0.75 + 0.12))  # noise
    assert np.all(height[on] > kh - 0.05)


def _parked_recall(run, **params):
    from tunnelsense.metrics import street_scores
    from tunnelsense.street import make_parking_pipeline

    fit = make_street_scans(1500, scenario="sparse", random_state=11)
    model = make_parking_pipeline(**params).fit(fit.scans)
    return street_scores(run.gt, model[-1].detect(run.scans))["parked"]


def test_cars_in_bays_at_right_angles_are_parked_by_their_far_side():
    # seen from the road a car in a bay at right angles has its near end in the
    # traffic lane (its mean depth too); its far side lies in the parking lane
    run = make_street_scans(2000, scenario="sparse", random_state=12,
                            angled_row_fraction=1.0, bay_angle_deg=90.0, kerb_depth=7.5,
                            parked_cluster_size=4.0, **QUIET)
    assert (run.gt["label"] == "parked").sum() >= 15
    span = _parked_recall(run, region_depth="span")
    assert span["recall"] >= 0.85 and span["precision"] >= 0.95
    assert _parked_recall(run)["recall"] < span["recall"] - 0.3  # region_depth="near"
