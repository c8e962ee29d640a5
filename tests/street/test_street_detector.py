"""ScanClusterer on hand-built scans and on simulated runs."""

import pickle

import numpy as np
import pandas as pd
import pytest
from _street_scenes import make_run, sedan
from sklearn.model_selection import GridSearchCV, GroupKFold

from tunnelsense import LaserGeometry, ScanRecord, ScanSequence, to_xy
from tunnelsense.datasets import make_street_scans
from tunnelsense.metrics import make_street_scorer, street_scores
from tunnelsense.street import ScanClusterer, make_parking_pipeline, split_profile
from tunnelsense.utils import record_stage_checks, sklearn_api_checks

SPEED = 11.0


def nose_to_tail_run(tilt=0.0):
    boxes = [
        dict(s0=2.0, s1=6.4, depth=4.6, top=sedan),
        dict(s0=6.45, s1=10.85, depth=4.6, top=sedan),  # bumpers 5 cm apart
        dict(s0=14.0, s1=14.5, depth=5.0, top=1.75, width=0.4),  # a pedestrian
        dict(s0=16.0, s1=16.15, depth=5.2, top=0.9, width=0.15),  # a bollard
        dict(s0=17.0, s1=17.7, depth=5.0, top=1.1, width=0.6),  # a bin
        dict(s0=19.0, s1=24.0, depth=4.5, top=2.6, bottom=0.3),  # a van, roof above ROI
        dict(s0=26.0, s1=30.4, depth=3.7, top=sedan),  # near the I|II boundary
        dict(s0=20.0, s1=24.5, depth=1.2, top=1.5),  # a passing car beside the van
    ]
    labels = ["parked", "parked", None, None, None, "parked", "parked", "passing"]
    return make_run(boxes, labels, n_scans=240, speed=SPEED, tilt=tilt)


@pytest.fixture(scope="module")
def scene():
    return nose_to_tail_run()


def test_detects_every_vehicle_once(scene):
    est = ScanClusterer(speed=SPEED, regions=(3.0, 6.6)).fit(scene.scans)
    det = est.detect(scene.scans)
    s = street_scores(scene.gt, det)
    assert s["parked"]["tp"] == 4 and s["parked"]["fp"] == 0
    assert s["passing"]["tp"] == 1 and s["passing"]["fp"] == 0
    other = est.detect(scene.scans, all_objects=True)
    # the pedestrian, the bollard and the bin are there, but not as vehicles
    small = other[(other.first_scan > 90) & (other.last_scan < 125)]
    assert len(small) >= 3 and set(small.label) == {"other"}


def test_split_merged_separates_touching_bumpers(scene):
    on = ScanClusterer(speed=SPEED, regions=(3.0, 6.6)).fit(scene.scans)
    off = ScanClusterer(speed=SPEED, regions=(3.0, 6.6), split_merged=False).fit(
        scene.scans
    )
    d_on, d_off = on.detect(scene.scans), off.detect(scene.scans)
    assert street_scores(scene.gt, d_on)["parked"]["tp"] == 4
    # without splitting, the two cars touching bumpers are one 8.8 m object
    assert (d_on.label == "parked").sum() == (d_off.label == "parked").sum() + 1
    assert d_off.length.max() > 8.0 > 5.0 > d_on.length.max()


def test_region_labels_parameter(scene):
    est = ScanClusterer(speed=SPEED, regions=(3.0, 6.6),
                        region_labels=("parked", "passing", "roadside")).fit(scene.scans)
    det = est.detect(scene.scans)
    assert (det.label == "passing").sum() == 4 and (det.label == "parked").sum() == 1


def test_tilt_compensation_matters():
    run = nose_to_tail_run(tilt=np.deg2rad(-4.0))  # the road seems to rise
    on = ScanClusterer(speed=SPEED, regions=(3.0, 6.6)).fit(run.scans)
    off = ScanClusterer(speed=SPEED, regions=(3.0, 6.6), tilt_compensation=False).fit(
        run.scans
    )
    s_on = street_scores(run.gt, on.detect(run.scans))["parked"]
    s_off = street_scores(run.gt, off.detect(run.scans))["parked"]
    assert s_on["tp"] == 4 and s_on["fp"] == 0
    assert s_off["tp"] < 4 or s_off["fp"] > 0
    tilts = [r.payload["tilt"] for r in on.transform(run.scans)]
    np.testing.assert_allclose(tilts, np.deg2rad(-4.0), atol=np.deg2rad(0.2))


def test_outputs_keep_samples_and_order(scene):
    est = ScanClusterer(speed=SPEED).fit(scene.scans)
    X = list(scene.scans)[::-1]  # any order in, same order out
    out = est.transform(X)
    assert [r.key for r in out] == [r.key for r in X]
    y = est.predict(X)
    assert len(y) == len(X) and all(a.shape[1] == 2 for a in y)
    det = est.detect(scene.scans)
    first = det.iloc[0]
    assert [first.id, 1] in est.predict(scene.scans)[first.first_scan].tolist()


def test_objects_break_at_long_scan_gaps_and_runs(scene):
    est = ScanClusterer(speed=SPEED).fit(scene.scans)
    whole = est.detect(scene.scans)
    car = whole[whole.label == "parked"].iloc[0]
    mid = (car.first_scan + car.last_scan) // 2
    X = [r for r in scene.scans if r.scan != mid]  # one scan missing: linked across
    det = est.detect(X, all_objects=True)
    assert ((det.first_scan < mid) & (det.last_scan > mid)).any()
    # a missing stretch longer than max_missing_length ends the objects there
    det = est.set_params(max_missing_length=None).detect(X, all_objects=True)
    assert not ((det.first_scan < mid) & (det.last_scan > mid)).any()
    est.set_params(max_missing_length=1.5)
    # two copies of the run under two names: twice the objects, none across runs
    other = [ScanRecord("copy", r.scan, r.ranges, r.stamp, r.geometry).evolve(
        speed=r.payload["speed"]) for r in scene.scans]
    both = est.detect(list(scene.scans) + other)
    assert len(both) == 2 * len(whole)
    assert set(both.run) == {scene.name, "copy"}


GEOM = LaserGeometry(np.deg2rad(-80), np.deg2rad(0.5), 0.1, 8.191, 2.0)


def scans(ranges, stamps=None, run="bad"):
    ranges = np.asarray(ranges, dtype=float)
    stamps = np.arange(len(ranges)) / 75 if stamps is None else stamps
    X = ScanSequence.from_arrays(ranges, stamps, GEOM, run=run)
    return ScanSequence([r.evolve(speed=11.1) for r in X])  # the ego speed (m/s)


@pytest.mark.parametrize("fill", [np.nan, np.inf, 8.191, 50.0])
def test_all_no_return_gives_empty_result(fill):
    X = scans(np.full((5, 241), fill))
    est = ScanClusterer().fit(X)
    out = est.transform(X)
    assert all(r.payload["points"].shape == (0, 2) for r in out)
    assert len(est.detect(X, all_objects=True)) == 0
    assert all(a.shape == (0, 2) for a in est.predict(X))


def test_single_point_scan():
    r = np.full((3, 241), np.nan)
    r[1, 150] = 4.0  # one return at -5 deg: 1.65 m above the road, 4 m away
    X = scans(r)
    out = ScanClusterer(spray_beams=0).fit(X).transform(X)
    assert [len(o.payload["points"]) for o in out] == [0, 1, 0]
    assert out[1].payload["clusters"].tolist() == [0]
    # among dropouts (NaN says nothing) it stays; with every beam around it passing
    # on (nothing within range), it is taken for a raindrop
    out = ScanClusterer().fit(X).transform(X)
    assert [len(o.payload["points"]) for o in out] == [0, 1, 0]
    r[np.isnan(r)] = np.inf
    X = scans(r)
    out = ScanClusterer().fit(X).transform(X)
    assert [len(o.payload["points"]) for o in out] == [0, 0, 0]


def test_mismatched_angle_count_raises():
    X = list(scans(np.full((3, 241), 5.0)))
    X.append(ScanRecord("bad", 3, np.full(240, 5.0), 0.04, GEOM).evolve(speed=11.1))
    with pytest.raises(ValueError, match="240 ranges.*241"):
        ScanClusterer().fit(X).transform(X)


def test_unsorted_stamps_raise():
    X = scans(np.full((4, 241), 5.0), stamps=np.array([0.0, 0.02, 0.01, 0.03]))
    with pytest.raises(ValueError, match="stamps of run 'bad' are not sorted"):
        ScanClusterer().fit(X).predict(X)


def test_duplicate_scan_raises():
    X = list(scans(np.full((2, 241), 5.0)))
    with pytest.raises(ValueError, match="twice"):
        ScanClusterer().fit(X).predict(X + X[:1])


def test_bad_parameters_raise():
    X = scans(np.full((2, 241), 5.0))
    with pytest.raises(ValueError, match="regions"):
        ScanClusterer(regions=(6.6, 4.0)).fit(X)
    with pytest.raises(ValueError, match="region_labels"):
        ScanClusterer(region_labels=("a", "b")).fit(X)
    with pytest.raises(ValueError, match="cut"):
        ScanClusterer(cut=-1).fit(X)
    with pytest.raises(TypeError, match="ScanRecord"):
        ScanClusterer().fit(np.zeros((3, 241)))


def test_split_profile_needs_two_humps():
    car = sedan(np.linspace(0, 4.4, 30))
    assert split_profile(np.r_[car, car], 4.4 / 30, min_length=1.5) == [30]
    assert split_profile(car, 4.4 / 30, min_length=1.5) == []
    van = np.full(40, 1.99)
    assert split_profile(van, 0.15, min_length=1.5) == []


@pytest.fixture(scope="module")
def small_runs():
    return [make_street_scans(600, scenario=s, random_state=7 + i)
            for i, s in enumerate(("sparse", "dense", "crowded"))]


@pytest.mark.parametrize("name, check", list(sklearn_api_checks(ScanClusterer())))
def test_sklearn_api(name, check):
    check()


def test_record_stage_checks(small_runs):
    X, y, _ = small_runs[0].xy()
    for _name, check in record_stage_checks(ScanClusterer(), X[:150], y[:150]):
        check()


def test_grid_search_group_kfold(small_runs):
    X, y, groups = to_xy(small_runs)
    search = GridSearchCV(
        make_parking_pipeline(),
        {"cluster__cut": [0.3, 0.6], "cluster__link_distance": [0.5]},
        cv=GroupKFold(3), scoring=make_street_scorer("parked", "f1"),
        error_score="raise",
    ).fit(X, y, groups=groups)
    assert search.best_params_["cluster__cut"] in (0.3, 0.6)
    assert search.best_score_ > 0.8
    assert len(search.predict(X)) == len(X)


def test_joblib_and_pickle_round_trip(small_runs):
    pipe = make_parking_pipeline(cut=0.5).fit(small_runs[0].scans)
    back = pickle.loads(pickle.dumps(pipe))
    X = small_runs[1].scans
    a, b = pipe.predict(X), back.predict(X)
    assert all(np.array_equal(u, v) for u, v in zip(a, b, strict=True))


@pytest.mark.parametrize("scenario", ["sparse", "dense", "tilted", "crowded"])
def test_simulated_scenarios(scenario, global_random_seed):
    """Short runs (2 x 1,500 scans); docs/street.md quotes 4,000-scan runs.

    The issue's target is recall >= 90 % at precision >= 99 % on 4,000-scan runs; on
    runs this short (20-60 parked vehicles) one false positive moves precision by
    2-5 %, so the bound here is looser: over seeds 0-39 the lowest pair gave recall
    0.93 and precision 0.94 (sparse), 0.975 (crowded).
    """
    runs = [
        make_street_scans(1500, scenario=scenario, random_state=global_random_seed + k)
        for k in range(2)
    ]
    gt = pd.concat([r.gt.assign(run=r.name) for r in runs])
    det = pd.concat([ScanClusterer().fit(r.scans).detect(r.scans) for r in runs])
    s = street_scores(gt, det)["parked"]
    assert s["recall"] >= 0.9
    assert s["precision"] >= 0.93


# ---------------------------------------------------------- beyond the paper: objects
def _clutter_row():
    """Pedestrians and bins standing shoulder to shoulder at the kerb (2.9 m)."""
    return [
        dict(s0=3.0, s1=3.4, depth=5.0, top=1.75, width=0.4, bottom=0.0),
        dict(s0=3.4, s1=4.1, depth=5.2, top=1.1, width=0.6, bottom=0.0),
        dict(s0=4.1, s1=4.5, depth=4.9, top=1.8, width=0.4, bottom=0.0),
        dict(s0=4.5, s1=4.9, depth=5.1, top=1.65, width=0.4, bottom=0.0),
        dict(s0=4.9, s1=5.6, depth=5.2, top=1.05, width=0.6, bottom=0.0),
        dict(s0=5.6, s1=5.9, depth=5.0, top=1.7, width=0.4, bottom=0.0),
    ]


def test_row_of_pedestrians_and_bins_is_not_a_vehicle():
    run = make_run(_clutter_row(), [None] * 6, n_scans=80, speed=SPEED)
    det = ScanClusterer(speed=SPEED).fit(run.scans).detect(run.scans, all_objects=True)
    assert len(det) and set(det.label) == {"other"}
    # the row links into one object long enough to pass the length rules: only the
    # cross-section evidence (no roof, no wall, not raised) rejects it
    off = ScanClusterer(speed=SPEED, min_body_fraction=0.0).fit(run.scans)
    assert (off.detect(run.scans).label == "parked").sum() == 1


def test_motorbike_and_van_are_vehicles():
    boxes = [
        # a motorbike: two wheels on the road, the body raised between them
        dict(s0=3.0, s1=3.6, depth=5.2, top=0.6, width=0.15, bottom=0.0),
        dict(s0=3.6, s1=4.4, depth=5.0, top=1.1, width=0.4, bottom=0.35),
        dict(s0=4.4, s1=5.0, depth=5.2, top=0.6, width=0.15, bottom=0.0),
        # a van taller than the region of interest (no roof seen), 6 m further
        dict(s0=11.0, s1=16.0, depth=4.5, top=2.6, width=1.9, bottom=0.3),
    ]
    run = make_run(boxes, ["parked", None, None, "parked"], n_scans=130, speed=SPEED)
    run.gt.loc[0, "last_scan"] = int(5.0 / SPEED * 75)
    det = ScanClusterer(speed=SPEED).fit(run.scans).detect(run.scans)
    s = street_scores(run.gt, det)["parked"]
    assert s["tp"] == 2 and s["fp"] == 0


def _occluded_run(hidden):
    """A sedan (2.0-6.4 m) partly hidden by a tall vehicle close to the sensor."""
    boxes = [dict(s0=2.0, s1=6.4, depth=4.6, top=sedan),
             dict(s0=hidden[0], s1=hidden[1], depth=1.5, top=2.6, width=1.8)]
    return make_run(boxes, ["parked", None], n_scans=110, speed=SPEED)


def test_car_cut_short_by_an_occluder_is_extended():
    run = _occluded_run((3.7, 9.0))  # only the first 1.7 m of the car are seen
    on = ScanClusterer(speed=SPEED).fit(run.scans).detect(run.scans)
    off = ScanClusterer(speed=SPEED, occluded_length=None).fit(run.scans)
    assert street_scores(run.gt, on)["parked"]["tp"] == 1
    assert street_scores(run.gt, on)["parked"]["fp"] == 0
    # without the extension the visible part alone does not match the car
    assert street_scores(run.gt, off.detect(run.scans))["parked"]["tp"] == 0


def test_occlusion_bridging_joins_one_car_but_not_two():
    run = _occluded_run((3.2, 5.0))  # the middle of the car is hidden
    on = ScanClusterer(speed=SPEED).fit(run.scans).detect(run.scans)
    off = ScanClusterer(speed=SPEED, bridge_occluded=False).fit(run.scans)
    assert street_scores(run.gt, on)["parked"]["tp"] == 1
    assert (off.detect(run.scans, all_objects=True).first_scan > 20).sum() >= 2
    # two cars nose to tail, their junction hidden: still two vehicles
    boxes = [dict(s0=2.0, s1=6.4, depth=4.6, top=sedan),
             dict(s0=6.5, s1=10.9, depth=4.6, top=sedan),
             dict(s0=5.6, s1=7.4, depth=1.5, top=2.6, width=1.8)]
    run2 = make_run(boxes, ["parked", "parked", None], n_scans=110, speed=SPEED)
    det = ScanClusterer(speed=SPEED).fit(run2.scans).detect(run2.scans)
    s = street_scores(run2.gt, det)["parked"]
    assert s["tp"] == 2 and s["fp"] == 0


def test_scans_without_speed_are_refused_not_guessed():
    run = make_street_scans(300, scenario="sparse", random_state=5)
    bare = ScanSequence([r.evolve(speed=float("nan")) for r in run.scans])
    with pytest.raises(ValueError, match=r"run '.*', scan 0: no ego speed.*speed=M/S"):
        ScanClusterer().fit(bare).detect(bare)
    # the paper's 40 km/h, asked for by name: the same as that speed given
    paper = ScanClusterer(speed="paper").fit(bare).detect(bare)
    given = ScanClusterer(speed=40 / 3.6).fit(bare).detect(bare)
    pd.testing.assert_frame_equal(paper, given)
    assert len(paper) > 0
    # the scans' own speed (the simulator's odometry) is read from their payload
    own = ScanClusterer().fit(run.scans).detect(run.scans)
    fixed = ScanClusterer(speed="paper").fit(run.scans).detect(run.scans)
    assert not np.allclose(own["length"], fixed["length"])
    # a speed appearing later in a run is no excuse for its first scans
    late = ScanSequence([r if i >= 10 else r.evolve(speed=float("nan"))
                         for i, r in enumerate(run.scans)])
    with pytest.raises(ValueError, match="scan 0: no ego speed"):
        ScanClusterer().fit(late).detect(late)
    with pytest.raises(ValueError, match="speed"):
        ScanClusterer(speed="fast").fit(bare)
