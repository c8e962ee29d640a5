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
                                    "wet_road_fraction", "wall_fraction",
                                    "tight_hedge_fraction", "bicycles_per_100m"])
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


def test_a_car_in_a_bay_at_right_angles_shows_its_roof_from_above():
    # seen end on, the scan plane runs along the car's axis: the beams from above
    # reach its roof panel (metal, as on a car along the kerb), not only glass
    from tunnelsense.datasets._street_shapes import BODY, GLASS, _car_boxes

    sim = _simulate(1500, "sparse", 5, angled_row_fraction=1.0, bay_angle_deg=90.0,
                    kerb_depth=7.5, parked_cluster_size=4.0, **QUIET)
    depth, height = _coords(sim)
    checked = roofs = 0
    for i, o in enumerate(sim["objects"]):
        if o.get("where") != "angled-bay":
            continue
        boxes = _car_boxes(o, np.linspace(0.05, o["length"] - 0.05, 20))
        for row in boxes:
            row = row[np.isfinite(row[:, 0])]
            top = row[np.argmax(row[:, 3])]
            assert top[4] == BODY  # the highest surface of every cut is the roof
            assert not np.any((row[:, 4] == GLASS) & (row[:, 3] >= top[3]))
        on = (sim["hit"] == i) & (sim["ranges"] < MAX_RANGE)
        for k in np.flatnonzero(on.sum(axis=1) >= 10):
            checked += 1
            h, d = height[k, on[k]], depth[k, on[k]]
            roof = d[h > h.max() - 0.1]
            roofs += roof.max() - roof.min() >= 0.8  # a roof-wide top surface
    assert checked >= 50
    assert roofs > 0.6 * checked


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
    # traffic lane (its mean depth too); its far side lies in the parking lane, and
    # it is shorter along the street than any car driving along it
    run = make_street_scans(2000, scenario="sparse", random_state=12,
                            angled_row_fraction=1.0, bay_angle_deg=90.0, kerb_depth=7.5,
                            parked_cluster_size=4.0, **QUIET)
    assert (run.gt["label"] == "parked").sum() >= 15
    across = _parked_recall(run)  # the default, region_depth="across"
    assert across == _parked_recall(run, region_depth="across")
    assert across["recall"] >= 0.85 and across["precision"] >= 0.95
    assert _parked_recall(run, region_depth="near")["recall"] < across["recall"] - 0.3


def test_a_body_across_the_street_is_no_traffic():
    from tunnelsense.street._classes import stands_across

    cum = np.arange(60) * 0.15
    # a car at 45 degrees: the near side advances 1.5 m over its 4.4 m
    s = np.arange(30)
    assert stands_across(s, np.linspace(2.5, 4.0, 30), np.full(30, 4.6), cum)
    # end on (a bay at right angles): 1.8 m along the street, 1.4 m deep
    assert stands_across(s[:12], np.full(12, 3.0), np.full(12, 4.4), cum)
    # traffic reaching into the parking lane keeps its near side, as long as a car
    assert not stands_across(s, np.full(30, 2.6), np.full(30, 4.3), cum)
    # ... and a short object showing only a face (a van's rear seen briefly) too
    assert not stands_across(s[:12], np.full(12, 2.6), np.full(12, 2.7), cum)
    # no body above the kerb
    assert not stands_across(s[:5], np.full(5, np.inf), np.full(5, np.nan), cum)


def test_traffic_reaching_into_the_parking_lane_stays_passing():
    # a street 1.25 m narrower than the regions assume (kerb at 5.2 m): the
    # passing vehicles' far sides lie in region II; "span" would park them
    from tunnelsense.metrics import street_scores
    from tunnelsense.street import make_parking_pipeline

    fit = make_street_scans(1000, scenario="sparse", random_state=11)
    run = make_street_scans(2000, scenario="sparse", random_state=101, kerb_depth=5.2,
                            passing_per_min=12.0)
    scores = {}
    for mode in ("across", "span"):
        model = make_parking_pipeline(region_depth=mode).fit(fit.scans)
        scores[mode] = street_scores(run.gt, model[-1].detect(run.scans))["passing"]
    assert scores["span"]["recall"] < scores["across"]["recall"]
    assert scores["across"]["recall"] >= 0.9


def test_tight_hedges_stand_right_behind_the_kerb():
    sim = _simulate(2000, "sparse", 8, tight_hedge_fraction=1.0, **QUIET)
    hedges = [i for i, o in enumerate(sim["objects"]) if o["kind"] == "hedge"]
    assert hedges
    depth, height = _coords(sim)
    kerb, kh = 6.45, 0.13
    on = np.isin(sim["hit"], hedges) & (sim["ranges"] < MAX_RANGE)
    assert on.any(axis=1).mean() > 0.6
    # the ragged face 0.0-0.3 m behind the kerb (+ its wiggle, 0.2 m), on the footway
    assert np.all((depth[on] > kerb - 0.12) & (depth[on] < kerb + 0.3 + 0.2 + 1.5 + 0.12))
    assert np.quantile(depth[on], 0.05) < kerb + 0.35
    # on the footway (foliage lets some beams in, a little deeper and lower)
    assert np.quantile(height[on], 0.01) > kh - 0.05


def test_parked_bicycles_are_thin_and_where_they_were_put():
    sim = _simulate(3000, "sparse", 9, bicycles_per_100m=6.0, **QUIET)
    bikes = [i for i, o in enumerate(sim["objects"]) if o["kind"] == "bicycle"]
    assert any(sim["objects"][i]["across"] for i in bikes)
    assert any(not sim["objects"][i]["across"] for i in bikes)
    assert all(o["label"] is None for o in sim["objects"] if o["kind"] == "bicycle")
    assert not (sim["gt"]["first_scan"] < 0).any()
    depth, height = _coords(sim)
    kerb = 6.45
    seen = 0
    for i in bikes:
        o = sim["objects"][i]
        on = (sim["hit"] == i) & (sim["ranges"] < MAX_RANGE)
        if not on.any():
            continue
        seen += 1
        d, h = depth[on], height[on]
        assert h.max() < o["base"] + 1.05 + 0.05  # the handlebar is its top
        if o["across"]:  # on the footway, its front 0.2-0.5 m behind the kerb
            assert d.min() > kerb + 0.2 - 0.1 and d.max() < kerb + 0.5 + 1.85 + 0.1
        else:  # in the parking lane, as thin as its bar is wide
            assert d.min() > o["depth_near"] - 0.1
            assert d.max() < o["depth_near"] + o["bar"] + 0.1 and d.max() < kerb
    assert seen >= 5


def test_a_near_vertical_face_is_no_kerb_step():
    from tunnelsense.street._geometry import kerb_steps

    # the road, then a vehicle's face 1.6 m away: its beams lie within 3 cm in
    # height and creep outwards by millimetres - it rises, it does not lie flat
    d = np.array([[1.40, 1.45, 1.50, 1.56, 1.58, 1.59, 1.60]])
    h = np.array([[0.0, 0.0, 0.01, 0.07, 0.075, 0.09, 0.2]])
    assert np.isnan(kerb_steps(d, h)[0])
    # the same heights spread outwards over a footway are a kerb step
    d2 = np.array([[1.40, 1.45, 1.50, 1.56, 1.80, 2.05, 2.30]])
    assert kerb_steps(d2, h)[0] == pytest.approx(1.53)


def test_a_car_in_a_bay_at_45_degrees_is_no_motorbike():
    from tunnelsense.street._classes import near_travel, vehicle_class

    # cut obliquely: short cross-sections, little roof, but its near side advances
    # 2 m across the street over its 4 m along it
    along = np.linspace(0.0, 4.0, 30)
    travel = near_travel(3.0 + 0.5 * along, along)
    assert travel == pytest.approx(2.0)
    car = {"roof": 0.15, "wall": 0.0, "top": 1.45, "extent": 0.6, "length": 4.0,
           "travel": travel}
    assert vehicle_class(car) == "car"
    # a row of motorbikes nose to tail keeps its near side (steps of their offsets)
    steps = np.where(along < 2.0, 5.3, 4.8)
    row = dict(car, roof=0.0, top=1.0, travel=near_travel(steps, along))
    assert row["travel"] < 1.2 and vehicle_class(row) == "motorbike"


def test_cars_in_bays_at_45_degrees_are_counted_as_cars():
    # single cars and short rows in bays (long rows of overlapping cars at 45
    # degrees are not yet split: a scan sees two of them)
    run = make_street_scans(3000, scenario="sparse", random_state=13,
                            angled_row_fraction=0.6, bay_angle_deg=45.0, kerb_depth=7.5,
                            **QUIET)
    from tunnelsense.metrics import street_class_scores
    from tunnelsense.street import make_parking_pipeline

    fit = make_street_scans(1500, scenario="sparse", random_state=11)
    model = make_parking_pipeline().fit(fit.scans)
    detected = model[-1].detect(run.scans)
    cars = street_class_scores(run.gt, detected)["classes"]["car"]
    assert cars["matched"] >= 10
    assert cars["correct"] >= 0.9 * cars["matched"]


def test_end_on_faces_parks_a_van_seen_end_on_not_one_driving_past():
    from _street_scenes import make_run

    from tunnelsense.street import ScanClusterer
    from tunnelsense.street._classes import faces_end_on

    speed = 11.0
    # a van in a bay at right angles: 1.9 m along the street, its face 2.3 m high
    # in the traffic lane (2.6 m from the sensor), its body out of sight behind it
    van = dict(s0=3.0, s1=4.9, depth=2.6, width=5.0, bottom=0.3, top=2.3)
    past = dict(van, s1=8.5, width=1.9)  # the same van driving along the street
    est = ScanClusterer(speed=speed, end_on_faces=True)
    for box, label in ((van, "parked"), (past, "passing")):
        run = make_run([box], [label], n_scans=90, speed=speed)
        det = est.fit(run.scans).detect(run.scans)
        assert det["label"].tolist() == [label]
    # off by default: a van overtaking a crawling probe car looks the same
    run = make_run([van], ["parked"], n_scans=90, speed=speed)
    assert ScanClusterer(speed=speed).fit(run.scans).detect(run.scans)[
        "label"].tolist() == ["passing"]
    # at the run's start the face may be a longer vehicle's rear cut short
    run = make_run([dict(van, s0=-0.5, s1=1.4)], ["parked"], n_scans=90, speed=speed)
    assert (est.detect(run.scans)["label"] == "parked").sum() == 0
    cum = np.arange(60) * 0.15
    wall = np.full(30, 0b10)
    assert faces_end_on(np.arange(13), wall[:13], cum)
    assert not faces_end_on(np.arange(13), np.zeros(13, int), cum)  # no tall face
    assert not faces_end_on(np.arange(6), wall[:6], cum)  # 0.9 m: narrower than any
    assert not faces_end_on(np.arange(30), wall, cum)  # 4.5 m along: driving past
