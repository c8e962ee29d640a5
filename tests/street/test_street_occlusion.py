"""Occlusion from the geometry of each beam: parked cars seen over a passing roof.

A long, low passing vehicle (a flatbed lorry or car transporter, 1.4-1.6 m high)
drives between the scanner (2 m up) and rows of parked cars: for a few seconds it
stands in every scan in front of them, and the beams over its roof reach only their
upper bodies.  Behind is not hidden: those cars are counted.
"""

import functools

import numpy as np
from _street_scenes import make_run, sedan

from tunnelsense import Run, ScanSequence
from tunnelsense.datasets._street import _simulate
from tunnelsense.metrics import street_scores
from tunnelsense.street import ScanClusterer, make_parking_pipeline

BEHIND = dict(passing_long_fraction=1.0, passing_van_fraction=0.0,
              passing_motorbike_fraction=0.0, passing_per_min=12.0,
              parked_cluster_size=3.0, parked_gap_m=8.0,
              pedestrians_per_100m=0.0, bins_per_100m=0.0, bollard_rows_per_100m=0.0,
              trees_per_100m=0.0)


@functools.lru_cache(maxsize=4)
def simulated(seed):
    sim = _simulate(2000, "sparse", seed, **BEHIND)
    run = Run.from_arrays("behind", sim["ranges"], sim["stamps"], sim["geometry"],
                          sim["gt"], info=sim["info"])
    run = Run(run.name, ScanSequence([r.evolve(speed=float(v)) for r, v in
                                      zip(run.scans, sim["speed"], strict=True)]),
              run.gt, run.info)
    return sim, run


def covered(sim):
    """Parked cars with a passing vehicle in every scan of theirs, seen above it."""
    hit, objects = sim["hit"], sim["objects"]
    passing = [i for i, o in enumerate(objects) if o.get("label") == "passing"]
    out = []
    for i, o in enumerate(objects):
        if o.get("label") != "parked" or "id" not in o:
            continue
        row = sim["gt"][sim["gt"]["id"] == o["id"]].iloc[0]
        scans = np.arange(row["first_scan"], row["last_scan"] + 1)
        in_front = np.isin(hit[scans], passing)
        if in_front.any(axis=1).all():
            out.append((o["id"], scans, in_front, hit[scans] == i))
    return out


def test_a_long_low_vehicle_passes_in_front_of_parked_cars_seen_over_its_roof():
    sim, _ = simulated(202)
    kinds = {o["kind"] for o in sim["objects"] if o.get("label") == "passing"}
    assert kinds == {"long"}
    cars = covered(sim)
    assert len(cars) >= 5
    for _, _, in_front, on_car in cars:
        # every beam reaching the car passes above the passing vehicle: in every scan
        # of the car, the beams that hit it are higher up the fan than those that end
        # on the passing vehicle (beams fan from the bottom up)
        beams = np.arange(in_front.shape[1])
        seen = on_car.any(axis=1)
        assert seen.mean() >= 0.3  # its roof at least
        low_car = np.where(on_car, beams, in_front.shape[1]).min(axis=1)
        high_front = np.where(in_front, beams, -1).max(axis=1)
        assert np.all(low_car[seen] > high_front[seen])


def test_parked_cars_seen_over_a_passing_roof_are_found():
    found = total = 0
    for seed in (202, 203):
        sim, run = simulated(seed)
        model = make_parking_pipeline().fit(run.scans)
        det = model[-1].detect(run.scans)
        parked = det[det["label"] == "parked"]
        for _, scans, _, _ in covered(sim):
            total += 1
            inter = (np.minimum(parked["last_scan"], scans[-1])
                     - np.maximum(parked["first_scan"], scans[0]) + 1).clip(lower=0)
            union = (np.maximum(parked["last_scan"], scans[-1])
                     - np.minimum(parked["first_scan"], scans[0]) + 1)
            found += bool((inter / union >= 0.5).any())
        scores = street_scores(run.gt, det)["parked"]
        assert scores["precision"] >= 0.9
    assert total >= 10
    assert found / total >= 0.8


def test_two_cars_hidden_over_a_longer_stretch_than_a_car_stay_two():
    speed = 11.0
    # a tall vehicle close to the sensor hides 8 m: the front of the first car and
    # the back of the second are seen, a whole car could stand in between
    boxes = [dict(s0=2.0, s1=6.4, depth=4.6, top=sedan),
             dict(s0=7.4, s1=11.8, depth=4.6, top=sedan),
             dict(s0=3.2, s1=11.0, depth=1.5, top=2.6, width=1.8)]
    run = make_run(boxes, ["parked", "parked", None], n_scans=130, speed=speed)
    det = ScanClusterer(speed=speed).fit(run.scans).detect(run.scans)
    s = street_scores(run.gt, det)["parked"]
    assert s["tp"] == 2 and s["fp"] == 0
    # bridging that gap takes them for one vehicle
    det = ScanClusterer(speed=speed, occluded_length=20.0).fit(run.scans).detect(
        run.scans)
    assert street_scores(run.gt, det)["parked"]["tp"] < 2


def test_a_car_seen_end_on_is_not_stretched_into_hidden_scans():
    speed = 11.0
    # a car in a bay at right angles, seen end on (1.8 m along the street, 4.3 m
    # across it, reaching from the lane into the parking lane); a van standing in
    # the lane hid its first 0.2 m and 2.8 m before it
    boxes = [dict(s0=3.0, s1=4.8, depth=2.6, width=4.3, top=1.45),
             dict(s0=0.0, s1=3.2, depth=1.0, width=1.0, top=2.6)]
    run = make_run(boxes, ["parked", None], n_scans=90, speed=speed)
    est = ScanClusterer(speed=speed, regions=(3.0, 7.5), region_depth="across")
    det = est.fit(run.scans).detect(run.scans)
    assert street_scores(run.gt, det)["parked"]["tp"] == 1
    car = det[det["label"] == "parked"]
    assert len(car) == 1
    # extended into the hidden scans no longer than the shortest car (its width
    # is what shows along the street), not to occluded_length (4 m)
    assert 1.8 <= car["length"].iloc[0] <= est.min_car_length + 0.2


def motorbike(s0, depth, *, length=2.0, seat=0.9, screen=1.25, forward=True):
    """A motorbike along the kerb: its body raised between the wheels, the seat
    behind, the screen and handlebars in front (``forward``: along the track)."""
    def top(off):
        front = off >= 0.6 * length if forward else off <= 0.4 * length
        return screen if front else seat

    return dict(s0=s0, s1=s0 + length, depth=depth, width=0.7, bottom=0.35, top=top)


def test_a_motorbike_cut_by_the_runs_end_is_reported():
    speed = 11.0
    # the run ends 0.9 m into a motorbike: only its raised rear and seat are seen
    # (lower than a motorbike across the kerb reaches), the rest lies beyond
    run = make_run([motorbike(4.0, 5.0)], ["parked"], n_scans=33, speed=speed)
    assert run.gt["last_scan"].iloc[0] == 32
    est = ScanClusterer(speed=speed).fit(run.scans)
    det = est.detect(run.scans)
    assert street_scores(run.gt, det)["parked"]["tp"] == 1
    assert det[det["label"] == "parked"]["vehicle_class"].tolist() == ["motorbike"]
    # the same at the run's start: it starts 0.9 m before the motorbike's end
    run = make_run([motorbike(-1.1, 5.0, forward=False)], ["parked"], n_scans=40,
                   speed=speed)
    run = Run(run.name, run.scans, run.gt.assign(first_scan=0), run.info)
    det = est.detect(run.scans)
    assert street_scores(run.gt, det)["parked"]["tp"] == 1
    # a low box standing on the ground (a planter) cut there is still no vehicle
    low = make_run([dict(s0=4.0, s1=6.0, depth=5.0, width=0.7, top=0.4)], ["parked"],
                   n_scans=33, speed=speed)
    assert (est.detect(low.scans)["label"] == "parked").sum() == 0


def test_a_flat_face_cut_by_the_runs_start_is_no_vehicle():
    speed = 11.0
    fit = make_run([dict(s0=4.0, s1=8.4, depth=5.0, width=1.8, top=sedan)], ["parked"],
                   n_scans=80, speed=speed)
    est = ScanClusterer(speed=speed).fit(fit.scans)

    def cut(box):
        run = make_run([box], ["parked"], n_scans=40, speed=speed)
        return Run(run.name, run.scans, run.gt.assign(first_scan=0), run.info)

    # a wall or hedge face 2.2 m high standing on the footway, of which the run's
    # first scans see its last 0.6-1.5 m: no roof, nothing raised or hanging
    for seen in (0.6, 1.0, 1.5):
        det = est.detect(cut(dict(s0=-5.0, s1=seen, depth=5.5, width=0.2,
                                  bottom=0.0, top=2.2)).scans)
        assert (det["label"] == "parked").sum() == 0
    # a car and a van cut there the same way are still found
    for seen in (0.6, 1.5):
        for box in (dict(s0=seen - 4.4, s1=seen, depth=5.0, width=1.8, top=sedan),
                    dict(s0=seen - 5.0, s1=seen, depth=5.0, width=1.9, bottom=0.3,
                         top=2.3)):
            run = cut(box)
            assert street_scores(run.gt, est.detect(run.scans))["parked"]["tp"] == 1


def test_a_car_with_scans_dropped_is_one_car_not_two_cut_ones():
    # a recorder that loses a scan or two inside a parked car: the parts on either
    # side of the gap are not cut by the run, so none is completed into a vehicle
    # of its own (one found car, no false object)
    speed = 11.0
    fit = make_run([dict(s0=4.0, s1=8.4, depth=5.0, width=1.8, top=sedan)], ["parked"],
                   n_scans=80, speed=speed)
    est = ScanClusterer(speed=speed).fit(fit.scans)
    run = make_run([dict(s0=2.0, s1=6.4, depth=5.0, width=1.8, top=sedan)], ["parked"],
                   n_scans=70, speed=speed)
    scans = list(run.scans)
    for dropped in (1, 2):
        det = est.detect(scans[:25] + scans[25 + dropped:])
        assert (det["label"] == "parked").sum() == 1


def test_a_motorbike_is_not_stretched_where_beams_pass_over_the_occluder():
    speed = 11.0
    # a low passing car (1.3 m high, 1.0-2.8 m deep) hides the road for 4 m before a
    # motorbike across the kerb (0.75 m along the street); the beams over its roof
    # cross the motorbike's depth near the road and reach the kerb line behind:
    # the motorbike is not in those scans
    boxes = [dict(s0=4.0, s1=4.75, depth=4.6, width=1.9, bottom=0.35, top=1.25),
             dict(s0=0.0, s1=4.3, depth=1.0, width=1.8, top=1.3)]
    run = make_run(boxes, ["parked", None], n_scans=70, speed=speed, mount_height=2.4)
    est = ScanClusterer(speed=speed, regions=(3.0, 7.5))
    det = est.fit(run.scans).detect(run.scans)
    parked = det[det["label"] == "parked"]
    assert street_scores(run.gt, det)["parked"]["tp"] == 1
    assert len(parked) == 1
    assert parked["length"].iloc[0] <= 0.75 + 0.3


def test_a_wet_road_under_a_passing_van_proves_nothing_behind_it():
    speed = 11.0
    # a van passing close (its body 0.35 m above the road) hides the first 3 m of a
    # parked car; the beams under the van meet a wet road and return nothing: they
    # did not pass the car's depth, so the car is hidden there, not absent
    boxes = [dict(s0=2.0, s1=6.4, depth=4.6, top=sedan),
             dict(s0=-1.0, s1=5.0, depth=1.2, width=1.8, top=2.3, bottom=0.35)]
    for wet in ((), ((-2.0, 12.0),)):
        run = make_run(boxes, ["parked", None], n_scans=70, speed=speed, wet=wet)
        det = ScanClusterer(speed=speed).fit(run.scans).detect(run.scans)
        assert street_scores(run.gt, det)["parked"]["tp"] == 1, wet
