"""A motorbike whose far end touches a taller hedge: carved out of the hedge's object."""

import numpy as np
import pytest
from _street_scenes import make_run, sedan

from tunnelsense.metrics import street_scores
from tunnelsense.street import ScanClusterer
from tunnelsense.street._carving import (
    flat_face,
    long_runs,
    protrusions,
    raised_section,
    under_gap,
    widen,
)


def test_a_motorbike_against_a_hedge_is_carved_out():
    from tunnelsense.datasets import make_street_scans

    # a run with a motorbike across the footway whose far end touches the hedge
    # behind it: one cluster with the hedge in every scan
    run = make_street_scans(600, scenario="sparse", random_state=111,
                            motorbike_fraction=0.6, motorbike_across_fraction=0.6,
                            motorbike_footway_fraction=0.5, parked_cluster_size=4.0,
                            parked_gap_m=12.0)
    found = {}
    for carve in (False, True):
        det = ScanClusterer(carve_protrusions=carve).fit(run.scans).detect(run.scans)
        found[carve] = street_scores(run.gt, det)["parked"], det
    (before, det0), (after, det1) = found[False], found[True]
    assert after["tp"] == before["tp"] + 1 and after["fp"] == before["fp"] == 0
    new = det1[~det1["first_scan"].isin(det0["first_scan"])]
    assert new["vehicle_class"].tolist() == ["motorbike"]
    assert new["label"].tolist() == ["parked"]
    # online, scan by scan, the same objects
    est = ScanClusterer().fit(run.scans)
    stream = est.start_stream()
    rows = [row for r in [*stream.push_many(run.scans), *stream.close()]
            for row in r.payload["finished_objects"]]
    online = [row[1:5] for row in rows if row[4] == "parked"]
    batch = [tuple(t) for t in det1[["id", "first_scan", "last_scan", "label"]]
             .itertuples(index=False) if t[3] == "parked"]
    assert online == batch


def test_protrusions_need_the_face_on_both_sides():
    length = 0.15 * np.arange(11)
    near = np.array([7.0, 7.1, 7.0, 5.5, 5.6, 7.0, 7.1, 7.0, 7.0, 7.0])
    face, runs = protrusions(near, 0.5, length, 2.4)
    assert runs == [(3, 4)]
    # at an object's end (no face after it), or longer than the limit: none
    assert protrusions(near[:5], 0.5, length[:6], 2.4)[1] == []
    assert protrusions(near, 0.5, length, 0.2)[1] == []
    # a face seen as no body (NaN) next to it is no face
    near[5] = np.nan
    assert protrusions(near, 0.5, length, 2.4)[1] == []
    assert widen(np.array([7.0, 6.9, 5.5, 6.95, 7.0]), 2, 2, 7.0, length, 0.2) == (1, 3)
    assert widen(np.array([7.0, 6.9, 5.5, 6.95, 7.0]), 2, 2, 7.0, length, 0.1) == (2, 2)


def test_raised_section_needs_the_beam_below_to_pass_farther():
    pts = np.array([[7.2, 0.15], [6.1, 0.5], [6.1, 0.6], [7.3, 1.4]])
    beams = np.arange(4)
    section = np.array([False, True, True, False])
    assert raised_section(pts, beams, section, 0.2, 0.1)
    pts[0] = [6.1, 0.4]  # standing on something at its own depth
    assert not raised_section(pts, beams, section, 0.2, 0.1)
    # its lowest point on the ground
    assert not raised_section(pts, beams, np.array([True, True, True, False]), 0.2, 0.1)
    # the beam below missing (no return in the region of interest): no evidence
    assert not raised_section(pts[1:], beams[1:], section[1:], 0.2, 0.1)


def test_a_motorbike_carved_from_two_runs_of_one_structure_counts_once():
    from tunnelsense.datasets import make_street_scans

    # a rolled sensor: one motorbike's front comes nearer than the hedge in two
    # runs of scans, with a scan at the face between them (its screen)
    run = make_street_scans(2000, scenario="sparse", random_state=104,
                            motorbike_fraction=0.6, motorbike_across_fraction=0.6,
                            motorbike_footway_fraction=0.5, parked_cluster_size=4.0,
                            parked_gap_m=12.0, roll_deg=-5.0)
    scores = [street_scores(run.gt, ScanClusterer(carve_protrusions=c).fit(
        run.scans).detect(run.scans))["parked"] for c in (False, True)]
    assert scores[1]["tp"] >= scores[0]["tp"] + 2
    assert scores[1]["fp"] == scores[0]["fp"]
    det = ScanClusterer().fit(run.scans).detect(run.scans)
    parked = det[det["label"] == "parked"].sort_values("first_scan")
    # no two parked objects share a scan at the depth of the carved ones
    carved = parked[parked["mean_depth"] > 6.0]
    for _, row in carved.iterrows():
        others = parked[(parked["id"] != row["id"]) & (parked["first_scan"] <= row[
            "last_scan"]) & (parked["last_scan"] >= row["first_scan"])]
        assert (abs(others["mean_depth"] - row["mean_depth"]) > 0.5).all()


def test_protrusions_at_an_objects_end_and_the_face_behind_them():
    length = 0.15 * np.arange(11)
    # a car at the start of a wall's object, another inside it
    near = np.array([4.5, 4.6, 6.6, 6.6, 4.4, 4.5, 6.6, 6.7, 6.6, 6.6])
    assert protrusions(near, 0.5, length, 25.0)[1] == [(4, 5)]
    assert protrusions(near, 0.5, length, 25.0, ends=True)[1] == [(0, 1), (4, 5)]
    # cars covering most of the wall: the median is a car, the upper quartile the wall
    near = np.array([4.5, 4.5, 4.6, 6.6, 4.4, 4.5, 4.5, 6.7, 6.6, 6.6])
    assert protrusions(near, 0.5, length, 25.0)[0] < 6.0
    face, runs = protrusions(near, 0.5, length, 25.0, ends=True, quantile=75.0)
    assert face >= 6.6 and runs == [(0, 2), (4, 6)]


def test_a_flat_face_shows_no_roof_and_no_raised_body():
    near = np.array([6.6, 6.6, 4.5, 4.5, 6.6, 6.6, 6.6, 6.6])
    lengths = np.full(8, 0.15)
    wall = np.array([2, 2, 5, 5, 2, 2, 2, 2])  # the car in front shows roof, raised
    assert flat_face(near, wall, 6.6, [(2, 3)], 0.5, lengths, 5, 0.2)
    # a car at the face's depth (no nearer than it by the margin) counts to it
    near[2:4] = 6.3
    assert flat_face(near, wall, 6.6, [(2, 3)], 0.5, lengths, 5, 0.2)
    assert not flat_face(near, wall, 6.6, [], 0.5, lengths, 5, 0.2)
    # a van's flank: a raised body between its wheels along half of it
    van = np.array([2, 6, 6, 6, 2, 2, 6, 2])
    assert not flat_face(np.full(8, 4.5), van, 4.5, [], 0.5, lengths, 5, 0.2)
    assert not flat_face(np.full(8, np.nan), wall, np.nan, [], 0.5, lengths, 5, 0.2)


@pytest.mark.parametrize("seed", [8, 11])
def test_cars_in_front_of_a_wall_are_carved_out_and_the_wall_is_no_van(seed):
    from tunnelsense.datasets import make_street_scans

    # a wall 0.1-0.5 m behind the kerb along the whole street: single linkage joins
    # a car's roof to it, and a stretch of wall alone has a vertical face like a van
    quiet = dict(passing_per_min=0.0, pedestrians_per_100m=0.0, bins_per_100m=0.0,
                 bollard_rows_per_100m=0.0, trees_per_100m=0.0, hedge_fraction=0.0)
    run = make_street_scans(800, scenario="sparse", random_state=seed,
                            wall_fraction=1.0, **quiet)
    scores = [street_scores(run.gt, ScanClusterer(carve_protrusions=c).fit(
        run.scans).detect(run.scans))["parked"] for c in (False, True)]
    assert scores[0]["fp"] > 0  # the wall (with the cars in front) a "van"
    assert scores[1]["fp"] == 0 and scores[1]["fn"] == 0
    assert scores[1]["tp"] >= scores[0]["tp"]
    # online, scan by scan, the same parked vehicles
    est = ScanClusterer().fit(run.scans)
    det = est.detect(run.scans)
    stream = est.start_stream()
    rows = [row for r in [*stream.push_many(run.scans), *stream.close()]
            for row in r.payload["finished_objects"]]
    assert [row[1:5] for row in rows if row[4] == "parked"] == [
        tuple(t) for t in det[["id", "first_scan", "last_scan", "label"]]
        .itertuples(index=False) if t[3] == "parked"]


def test_a_ragged_hedge_behind_the_kerb_is_no_van_judged_by_the_ground():
    from tunnelsense.datasets import make_street_scans

    # a hedge tight behind the kerb: beams reach into its foliage and through its
    # gaps ("raised" at some point), its thick top is roof-wide, yet its face
    # stands on the footway; cars in front of it join it in one object
    run = make_street_scans(2000, scenario="sparse", random_state=104,
                            tight_hedge_fraction=0.6)
    est = ScanClusterer(flat_by_ground=False).fit(run.scans)
    before = street_scores(run.gt, est.detect(run.scans))["parked"]
    after = street_scores(run.gt, est.set_params(flat_by_ground=True).detect(
        run.scans))["parked"]
    assert before["fn"] > 0 and before["fp"] > 0
    assert after["tp"] > before["tp"] and after["fp"] < before["fp"]


def test_under_gap_needs_the_next_beam_farther_and_lower():
    pts = np.array([[5.0, 0.15], [5.0, 0.2], [5.0, 0.25]])
    beams = np.arange(3)
    section = np.ones(3, dtype=bool)

    def gap(below):
        under = np.array([below, [5.0, 0.15], [5.0, 0.2]], dtype=float)
        return under_gap(pts, beams, under, section, 0.1)

    assert gap([5.4, 0.0])  # under a car's sill, to the road
    assert not gap([5.0, 0.1])  # the same face, one beam lower
    assert not gap([5.25, 0.12])  # into foliage: farther, not lower
    assert not gap([5.4, 0.1])  # farther, but not lower by the resolution
    assert not gap([4.8, 0.0])  # the footway in front of a wall
    assert not gap([np.nan, np.nan])  # no return says nothing
    assert not under_gap(pts, beams, pts, np.zeros(3, bool), 0.1)


def test_long_runs_keep_stretches_not_single_scans():
    mask = np.array([1, 0, 1, 1, 0, 1, 1, 1, 1], dtype=bool)
    kept = long_runs(mask, np.full(9, 0.15), 0.5)
    assert kept.tolist() == [False] * 5 + [True] * 4
    assert long_runs(mask, np.full(9, 0.3), 0.5).tolist() == [
        False, False, True, True, False, True, True, True, True]
    assert not long_runs(np.zeros(0, bool), np.zeros(0), 0.5).any()


def test_long_runs_can_ask_for_a_count_of_scans():
    # at a low scan rate two scans through a gap in foliage span 0.9 m
    mask = np.array([1, 1, 0, 1, 1, 1, 0, 1], dtype=bool)
    metres = np.full(8, 0.44)
    assert long_runs(mask, metres, 0.5).tolist() == [
        True, True, False, True, True, True, False, False]
    assert long_runs(mask, metres, 0.5, min_count=3).tolist() == [
        False, False, False, True, True, True, False, False]


def test_a_hedge_standing_on_the_ground_is_no_vehicle_but_low_cars_are():
    # a thick hedge (its top roof-wide, 1.1 m) on the footway just behind two cars
    # whose bodies come down to 0.15 m: single linkage joins the cars' roofs to the
    # hedge's face in every scan, one 19 m object
    speed = 11.0
    hedge = [dict(s0=1.0, s1=20.0, depth=6.5, top=1.3, width=1.1, bottom=0.0)]
    cars = [dict(s0=4.0, s1=8.4, depth=4.7, top=sedan, bottom=0.15),
            dict(s0=12.0, s1=16.4, depth=4.7, top=sedan, bottom=0.15)]
    labels = [None, "parked", "parked"]
    run = make_run(hedge + cars, labels, n_scans=int(21.0 / speed * 75), speed=speed,
                   mount_height=2.4)
    old = ScanClusterer(flat_by_ground=False).fit(run.scans)
    new = ScanClusterer().fit(run.scans)
    before = street_scores(run.gt, old.detect(run.scans))["parked"]
    after = street_scores(run.gt, new.detect(run.scans))["parked"]
    # with a roof counted as a vehicle's mark, the hedge and the cars are one "van"
    assert before["tp"] == 0 and before["fp"] == 1
    assert after["tp"] == 2 and after["fp"] == 0


def _low_pair(bottom, rate=75.0, speed=11.0):
    """Two cars nose to tail, their bodies ``bottom`` above the road."""
    pair = [dict(s0=4.0, s1=8.4, depth=4.7, top=sedan, bottom=bottom),
            dict(s0=8.45, s1=12.85, depth=4.7, top=sedan, bottom=bottom)]
    return make_run(pair, ["parked", "parked"], n_scans=int(14.0 / speed * rate),
                    speed=speed, rate=rate, mount_height=2.4)


@pytest.mark.parametrize("bottom", [0.0, 0.15])
def test_two_low_cars_left_unsplit_stay_a_vehicle_by_the_gap_under_them(bottom):
    # the two cars, left unsplit, are one 9 m object without a body raised 0.2 m:
    # the beams passing under their bodies to the road keep it a vehicle
    run = _low_pair(bottom)
    det = ScanClusterer(split_merged=False).fit(run.scans).detect(run.scans)
    parked = det[det.label == "parked"]
    if bottom > 0:
        assert len(parked) == 1 and parked.length.iloc[0] > 8.0
    else:  # the gap is what tells: the same boxes standing on the road are a wall
        assert len(parked) == 0


@pytest.mark.parametrize("rate", [25.0, 50.0])
def test_the_gap_under_low_cars_counts_at_other_scan_rates(rate):
    # at 25 Hz a scan covers 0.44 m, at 50 Hz 0.22 m: min_gap_length and
    # min_gap_scans both hold over the 9 m under the pair
    run = _low_pair(0.15, rate=rate)
    est = ScanClusterer(split_merged=False).fit(run.scans)
    parked = est.detect(run.scans).query("label == 'parked'")
    assert len(parked) == 1 and parked.length.iloc[0] > 8.0
    # asking for more scans than the pair spans leaves no mark: a wall
    n_scans = int(9.0 / 11.0 * rate) + 2
    walled = est.set_params(min_gap_scans=n_scans).detect(run.scans)
    assert not (walled.label == "parked").any()


@pytest.mark.parametrize(("name", "value"), [("min_gap_length", -0.1),
                                             ("min_gap_scans", 0),
                                             ("min_gap_scans", 1.5)])
def test_gap_parameters_are_checked(name, value):
    run = _low_pair(0.15)
    with pytest.raises(ValueError, match=name):
        ScanClusterer(**{name: value}).fit(run.scans)


@pytest.mark.parametrize("seed", range(5))
def test_lowest_marks_are_raised_section_and_under_gap_scan_by_scan(seed):
    from tunnelsense.street._sections import lowest_marks

    rng = np.random.default_rng(seed)
    n_scans = 12
    sizes = rng.integers(0, 9, n_scans)
    scan = np.repeat(np.arange(n_scans), sizes)
    # beams in order within a scan, some missing (no return in the region)
    beams = np.concatenate([np.sort(rng.choice(12, k, replace=False)) for k in sizes])
    points = np.column_stack([rng.uniform(4.0, 6.0, len(scan)),
                              rng.uniform(0.0, 0.6, len(scan))])
    under = np.column_stack([rng.uniform(4.0, 6.5, len(scan)),
                             rng.uniform(0.0, 0.6, len(scan))])
    under[rng.random(len(scan)) < 0.2] = np.nan
    section = rng.random(len(scan)) < 0.6
    raised, gap = lowest_marks(points, beams, scan, under, section, n_scans, 0.2, 0.1)
    for s in range(n_scans):
        at = scan == s
        assert raised[s] == raised_section(points[at], beams[at], section[at], 0.2,
                                           0.1, absent=True)
        assert gap[s] == under_gap(points[at], beams[at], under[at], section[at], 0.1)
    assert raised.any() and gap.any() and not raised.all()
