"""Scans lost by a recorder or a network link: a missing stretch is no evidence.

The parts of an object on either side of a stretch of missing scans are linked when
the stretch (its metres: the ego speed times the time it lasted) is at most
``max_missing_length``; across a longer one objects end, and neither part is
completed as if the data cut it.
"""

import dataclasses
import functools

import numpy as np
import pytest
from _street_scenes import make_run, sedan

from tunnelsense.datasets import make_street_scans
from tunnelsense.metrics import street_scores
from tunnelsense.street import ScanClusterer

SPEED = 11.0  # m/s; 75 scans/s: 0.147 m a scan
CAR = dict(s0=2.0, s1=6.4, depth=5.0, width=1.8, top=sedan)  # scans 14-43


@functools.lru_cache(maxsize=1)
def car_run():
    return make_run([CAR], ["parked"], n_scans=70, speed=SPEED)


def fitted(**params):
    fit = make_run([dict(CAR, s0=4.0, s1=8.4)], ["parked"], n_scans=80, speed=SPEED)
    return ScanClusterer(speed=SPEED, **params).fit(fit.scans)


def without(scans, start, n):
    return scans[:start] + scans[start + n:]


@pytest.mark.parametrize("lost", [3, 5, 10])
def test_a_car_with_scans_lost_inside_is_one_car_as_long_as_without(lost):
    run = car_run()
    est = fitted()
    whole = est.detect(run.scans)
    det = est.detect(without(list(run.scans), 25, lost))
    parked = det[det["label"] == "parked"]
    assert len(parked) == 1
    assert street_scores(run.gt, det)["parked"]["tp"] == 1
    # the missing metres count to its length: as long as seen whole
    ref = whole.loc[whole["label"] == "parked", "length"].iloc[0]
    assert parked["length"].iloc[0] == pytest.approx(ref, abs=0.05)
    assert parked["vehicle_class"].iloc[0] == "car"


def test_scans_lost_where_only_the_stamps_show_it():
    # a recorder that numbers the scans it received: the numbers run on, the
    # stamps jump by 11 periods; the same car as with the numbers jumping
    run = car_run()
    est = fitted()
    kept = without(list(run.scans), 25, 10)
    renumbered = [dataclasses.replace(r, scan=i) for i, r in enumerate(kept)]
    det = est.detect(renumbered)
    parked = det[det["label"] == "parked"]
    assert len(parked) == 1
    assert parked["length"].iloc[0] > 4.0


def test_a_stretch_longer_than_the_bound_ends_the_objects_there():
    # 10 scans lost are 1.47 m: linked under the default bound of 1.5 m, two
    # objects ending at the stretch under a bound of 1.0 m (metres, not scans)
    run = car_run()
    scans = without(list(run.scans), 25, 10)
    for bound, n_objects in ((1.5, 1), (1.0, 2), (None, 2)):
        det = fitted(max_missing_length=bound).detect(scans, all_objects=True)
        near = det[(det["mean_depth"] > 4.0) & (det["mean_depth"] < 6.0)]
        assert len(near) == n_objects
        if n_objects == 2:  # one part ends before the stretch, one starts after it
            assert sorted(near["last_scan"])[0] == 24
            assert sorted(near["first_scan"])[1] == 35
            # neither is completed as if the data cut it: at 1.6 m and 1.3 m seen,
            # with no scans of the car's ends beside the stretch, no parked car
            assert (near["length"] < 2.0).all()


def test_the_bound_is_in_metres_not_scans():
    # 5 scans lost at 25 scans/s are 2.2 m: beyond the bound, objects end there;
    # at 75 scans/s (0.73 m) they are linked
    slow = make_run([CAR], ["parked"], n_scans=30, speed=SPEED, rate=25.0)
    est = ScanClusterer(speed=SPEED).fit(slow.scans)
    det = est.detect(without(list(slow.scans), 8, 5), all_objects=True)
    near = det[(det["mean_depth"] > 4.0) & (det["mean_depth"] < 6.0)]
    assert len(near) == 2
    det = fitted().detect(without(list(car_run().scans), 25, 5), all_objects=True)
    near = det[(det["mean_depth"] > 4.0) & (det["mean_depth"] < 6.0)]
    assert len(near) == 1


def test_a_stretch_lost_while_the_car_stands_is_no_length():
    # the probe car stands (0 m/s before and after the stretch) while 150 scans
    # are lost: 0 m, linked
    run = car_run()
    scans = list(run.scans)
    stand = [dataclasses.replace(r, stamp=r.stamp + (2.0 if i >= 30 else 0.0),
                                 scan=r.scan + (150 if i >= 30 else 0))
             for i, r in enumerate(scans)]
    stand = [r.evolve(speed=0.0) if 25 <= i < 35 else r for i, r in enumerate(stand)]
    est = ScanClusterer().fit(car_run().scans)
    det = est.detect(stand)
    assert (det["label"] == "parked").sum() == 1


def started_during_the_stretch(extra):
    """A 7.4 m body; the probe car reports 0 m/s in the 5 scans before scans 30 ..
    48 are lost, and 11 m/s after them, whose numbers and stamps run on by
    ``extra`` scans more (it started from a standstill while they were lost)."""
    run = make_run([dict(CAR, s1=9.4)], ["parked"], n_scans=90, speed=SPEED)
    kept = without(list(run.scans), 30, 19)
    out = []
    for i, r in enumerate(kept):
        if i >= 30:
            r = dataclasses.replace(r, scan=r.scan + extra,
                                    stamp=r.stamp + extra / 75.0)
        out.append(r.evolve(speed=0.0) if 25 <= i < 30 else r)
    return out


def test_a_stretch_over_a_start_from_a_standstill_is_as_long_as_driven():
    # 38 scan periods (0.5 s) between the last scan before and the first after:
    # from 0 to 11 m/s that is 0.5 s at 5.5 m/s, 2.7 m, beyond the 1.5 m bound:
    # the objects end there.  The median of the recent speeds (4 of 0 m/s and
    # one of 11) read it as 0 m and linked the two parts into one
    est = ScanClusterer().fit(car_run().scans)  # the speeds the scans report
    det = est.detect(started_during_the_stretch(18), all_objects=True)
    near = det[(det["mean_depth"] > 4.0) & (det["mean_depth"] < 6.0)]
    assert len(near) == 2
    assert sorted(near["last_scan"])[0] == 29
    # 14 scan periods more (0.32 s at 5.5 m/s, 1.75 m): still beyond
    det = est.detect(started_during_the_stretch(5), all_objects=True)
    near = det[(det["mean_depth"] > 4.0) & (det["mean_depth"] < 6.0)]
    assert len(near) == 2
    # with a fixed speed the stretch is 19 scans at 11 m/s (2.8 m): ends there too;
    # 9 scans (1.3 m) are linked
    fixed = fitted().set_params(speed=SPEED)
    assert len(fixed.detect(without(list(car_run().scans), 25, 9), all_objects=True)
               .query("4.0 < mean_depth < 6.0")) == 1


@pytest.mark.parametrize("where", ["before", "after"])
def test_an_object_beside_a_stretch_gets_none_of_its_metres(where):
    # 9 scans (1.3 m) lost right before the car's first scan (14) or right after
    # its last (43): nothing of the car was seen there, so it is as long as seen
    # whole.  The stretch's metres went to the scan after it, and so to a car
    # starting there (5.7 m for 4.4 m; a 2.5 m stub could pass a length test)
    run = car_run()
    est = fitted()
    whole = est.detect(run.scans)
    ref = whole.loc[whole["label"] == "parked", "length"].iloc[0]
    det = est.detect(without(list(run.scans), 5 if where == "before" else 44, 9))
    parked = det[det["label"] == "parked"]
    assert len(parked) == 1
    assert parked["length"].iloc[0] == pytest.approx(ref, abs=0.05)


def test_a_stub_after_a_stretch_is_not_lengthened_into_a_vehicle():
    # a 1.0 m body right after 10 lost scans (1.47 m): 1.0 m seen, shorter than
    # the shortest vehicle (1.5 m); with the stretch's metres it was 2.5 m
    stub = make_run([dict(CAR, s0=2.0, s1=3.0)], ["parked"], n_scans=40, speed=SPEED)
    est = fitted()
    det = est.detect(without(list(stub.scans), 4, 10), all_objects=True)
    near = det[(det["mean_depth"] > 4.0) & (det["mean_depth"] < 6.0)]
    assert len(near) == 1
    assert near["length"].iloc[0] < 1.5
    assert (det["label"] != "parked").all()


@functools.lru_cache(maxsize=1)
def simulated():
    fit = make_street_scans(600, scenario="sparse", random_state=3)
    run = make_street_scans(1500, scenario="dense", random_state=14)
    return ScanClusterer().fit(fit.scans), run


def test_five_percent_of_scans_lost_over_a_run_loses_no_car():
    est, run = simulated()
    rng = np.random.default_rng(0)
    scans = list(run.scans)
    kept = [s for s in scans if rng.random() >= 0.05]
    assert len(kept) < 0.97 * len(scans)
    whole = street_scores(run.gt, est.detect(run.scans))["parked"]
    lost = street_scores(run.gt, est.detect(kept))["parked"]
    unlinked = street_scores(
        run.gt, est.set_params(max_missing_length=None).detect(kept))["parked"]
    est.set_params(max_missing_length=1.5)
    assert whole["tp"] >= 10
    assert lost["tp"] >= whole["tp"]
    assert lost["fp"] <= whole["fp"]
    # without the links the drops cut cars apart: cars lost, parts left over
    assert unlinked["tp"] < whole["tp"]
    assert unlinked["fp"] > whole["fp"]


def test_lost_scans_any_chunking_equals_batch():
    est, run = simulated()
    rng = np.random.default_rng(1)
    scans = list(run.scans)
    keep = np.ones(len(scans), dtype=bool)
    for i in np.flatnonzero(rng.random(len(scans)) < 0.02):
        keep[i:i + int(rng.integers(1, 16))] = False  # some beyond the bound
    kept = [s for s, k in zip(scans, keep, strict=True) if k]
    table = est.detect(kept, all_objects=True)
    rows = [tuple(r) for r in table.itertuples(index=False)]
    for chunk in (1, 13, 10_000):
        state = est.start_stream()
        out = []
        for i in range(0, len(kept), chunk):
            out.extend(state.push_many(kept[i:i + chunk]))
        out.extend(state.close())
        assert [r.scan for r in out] == [r.scan for r in kept]
        assert [row for r in out for row in r.payload["finished_objects"]] == rows


@pytest.mark.parametrize("jitter, clock", [(0.45, None), (None, 0.01), (0.45, 0.01),
                                           (None, 0.03), (None, 0.04), (None, 0.05)])
def test_stamps_that_jitter_or_come_from_a_coarse_clock_lose_no_scan(jitter, clock):
    # host-time stamps up to 0.45 periods early or late (differences up to 1.9
    # periods), and/or on a 10 ms clock (differences of 0.75 and 1.5 periods; 0 to
    # 2.25 with the jitter), or on a clock of several periods (30-50 ms: differences
    # of 0 and 2.25-3.75 periods); no scan is lost, so the detections are those of
    # exact stamps: the same vehicles, as long within 2 % (a median of the stamp
    # differences read the 10 ms clock as the period: every length 24 % short; a
    # 40 ms clock's differences were all read as lost scans and nothing was found)
    est, run = simulated()
    rng = np.random.default_rng(2)
    period = 1.0 / 75.0
    scans = list(run.scans)
    stamps = np.array([r.stamp for r in scans])
    if jitter is not None:
        stamps = stamps + period * rng.uniform(-jitter, jitter, len(stamps))
    if clock is not None:
        stamps = np.round(stamps / clock) * clock
    shaken = [dataclasses.replace(r, stamp=float(t))
              for r, t in zip(scans, stamps, strict=True)]
    exact = est.detect(scans)
    noisy = est.detect(shaken)
    assert street_scores(run.gt, noisy)["parked"] == street_scores(run.gt, exact)["parked"]
    parked = [d.loc[d["label"] == "parked", "length"].sum() for d in (exact, noisy)]
    assert parked[1] == pytest.approx(parked[0], rel=0.02)


def test_an_occluded_car_after_lost_scans_is_extended_by_its_own_metres():
    # a car partly hidden behind a 2.6 m tall occluder, with 9 scans lost right
    # before the car's first seen scan: the extension into the hidden scans counts
    # the car's own metres, not the lost stretch's, so it is as long as without the
    # loss (it read 2.79 m: the stretch's metres made it look long enough already)
    speed = 11.0
    car = dict(s0=2.0, s1=6.4, depth=5.0, width=1.8, top=sedan)
    occluder = dict(s0=4.2, s1=8.0, depth=2.5, width=0.5, top=2.6)
    fit = make_run([dict(car, s0=4.0, s1=8.4)], ["parked"], n_scans=80, speed=speed)
    est = ScanClusterer(speed=speed).fit(fit.scans)
    scans = list(make_run([car, occluder], ["parked", None], n_scans=80,
                          speed=speed).scans)
    whole = est.detect(scans)
    lost = est.detect(scans[:5] + scans[14:])
    assert len(whole) == len(lost) == 2
    assert whole["length"].iloc[0] >= est.occluded_length
    assert lost["length"].iloc[0] == pytest.approx(whole["length"].iloc[0], abs=0.05)
