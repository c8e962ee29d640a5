"""Vehicles in echelon (bays at an angle to the kerb) joined into one object and split
by their near side."""

import numpy as np
import pytest
from _street_scenes import make_run, oblique_car, sedan

from tunnelsense.metrics import street_scores
from tunnelsense.street import ScanClusterer
from tunnelsense.street._splitting import split_echelon, split_near_side

SPEED = 11.0
#: along-track pitch of bays 2.5 m wide at 45 degrees
PITCH = 2.5 / np.sin(np.deg2rad(45.0))


@pytest.fixture(scope="module")
def echelon():
    # three cars in bays 2.5 m wide at 45 degrees: 4.4 m along the track each,
    # overlapping their neighbours by 0.8 m (a scan there cuts two), the middle one
    # pulled 0.8 m less far in: its end starts where the first one's flank ends
    boxes = [oblique_car(3.0 + k * PITCH, 3.4 + 0.8 * (k % 2)) for k in range(3)]
    return make_run(boxes, ["parked"] * 3, n_scans=150, speed=SPEED)


def test_oblique_cars_overlap_along_the_track(echelon):
    gt = echelon.gt.sort_values("first_scan")
    assert (gt.first_scan.to_numpy()[1:] < gt.last_scan.to_numpy()[:-1]).all()


@pytest.mark.parametrize("off", [dict(split_merged=False), dict(region_depth="near")])
def test_cars_in_echelon_are_split_into_one_object_each(echelon, off):
    on = ScanClusterer(speed=SPEED, regions=(3.0, 6.6), region_depth="across").fit(
        echelon.scans)
    off = ScanClusterer(speed=SPEED, regions=(3.0, 6.6), **{
        "region_depth": "across", **off}).fit(echelon.scans)
    d_on, d_off = on.detect(echelon.scans), off.detect(echelon.scans)
    s_on = street_scores(echelon.gt, d_on)["parked"]
    assert s_on["tp"] == 3 and s_on["fp"] == 0
    assert (d_on.label == "parked").sum() == 3 and d_on.length.max() < 5.0
    # without splitting (region_depth="near" never splits so),
    # neighbours joined where a scan cuts both
    assert street_scores(echelon.gt, d_off)["parked"]["tp"] < 3
    assert d_off.length.max() > 7.0


def test_split_near_side_needs_a_ridge_between_two_valleys():
    along = np.arange(41) * 0.2
    # one car at 45 degrees: its end comes forward 1.2 m, its flank steps back 3 m
    car = np.r_[np.linspace(4.6, 3.4, 7), np.linspace(3.6, 6.4, 15)]
    assert split_near_side(car, along[:23], min_length=2.4, travel=1.0) == []
    two = np.r_[car[:-2], car[:-2]]
    assert split_near_side(two, along, min_length=2.4, travel=1.0) == [20]
    # a ridge lower than travel (a bumper's rounded corner) is no split
    assert split_near_side(two, along, min_length=2.4, travel=3.5) == []
    # ... nor one leaving a part shorter than min_length
    assert split_near_side(two, along, min_length=4.2, travel=1.0) == []
    # a car parked along the kerb keeps its near side; unseen scans are skipped
    flat = np.full(40, 4.6)
    flat[18:21] = np.nan
    assert split_near_side(flat, along, min_length=2.4, travel=0.5) == []


def test_split_echelon_leaves_shallow_objects_alone():
    # near sides of cars at 45 degrees, 0.2 m apart along the track: the end comes
    # forward, the flank steps back; on a body 0.4 m deep (a hedge) no split
    car = np.r_[np.linspace(4.6, 3.4, 7), np.linspace(3.6, 6.4, 15)]
    side = np.r_[car[:-2], car[:-2], car[:-2]]
    n = len(side)
    position = np.arange(n)
    objects = np.zeros(n, dtype=np.int64)
    cum = np.arange(n + 2) * 0.2
    args = dict(min_length=2.4, depth=0.8)
    assert (split_echelon(objects, position, side, side + 0.4, np.r_[0], np.r_[n - 1],
                          cum, **args) == 0).all()
    # the same near side on a body 2 m deep is split, one object per car
    new = split_echelon(objects, position, side, side + 2.0, np.r_[0], np.r_[n - 1],
                        cum, **args)
    assert len(np.unique(new)) == 3


def test_a_face_between_two_vehicles_is_no_ridge():
    along = np.arange(61) * 0.15
    # motorbikes or cars 1.8 m long in front of a hedge 6.6 m deep, 0.9 m of hedge
    # face seen between them: the near side steps back to the face and forward
    # again (no flank falls away from the ridge)
    unit = np.r_[np.full(12, 5.3), np.full(6, 6.6)]
    side = np.r_[unit, unit, unit, np.full(6, 5.3)]
    assert split_near_side(side, along, min_length=1.5, travel=0.6) == []
    # a ridge as sharp as a car's corner (a flank falling away from it) is one
    ridge = side.copy()
    ridge[12:18] = np.linspace(5.6, 6.6, 6)
    assert split_near_side(ridge, along, min_length=1.5, travel=0.6) == [18]
    # ... but not with its top flat for travel / 2 along the track (a face)
    ridge[15:18] = 6.6
    assert split_near_side(ridge, along, min_length=1.5, travel=0.6) == []


def test_cars_along_the_kerb_are_not_split():
    boxes = [dict(s0=2.0 + k * 4.5, s1=6.4 + k * 4.5, depth=4.6, top=sedan)
             for k in range(3)]
    run = make_run(boxes, ["parked"] * 3, n_scans=150, speed=SPEED)
    on = ScanClusterer(speed=SPEED, regions=(3.0, 6.6), region_depth="across").fit(
        run.scans)
    assert street_scores(run.gt, on.detect(run.scans))["parked"]["tp"] == 3


def test_lost_metres_before_an_object_are_not_its_own_when_splitting():
    # two cars at 45 degrees, 2.0 m each along the track (0.1 m a scan); the first
    # up to its ridge 1.9 m, shorter than a part may be (1.95 m): no split.  Scans
    # lost right before the object (1.0 m, counted to its first scan's stretch)
    # are not seen metres of it: with them the first car read 2.9 m, split off
    car = np.r_[np.linspace(4.6, 3.4, 7), np.linspace(3.6, 6.4, 15)]
    side = np.r_[car[:-2], car[:-2]]
    n = len(side)
    position, objects = np.arange(n), np.zeros(n, dtype=np.int64)
    gap = np.zeros(n)
    gap[0] = 1.0
    cum = np.r_[0.0, np.cumsum(0.1 + gap)]
    args = dict(min_length=1.95, depth=0.8)
    new = split_echelon(objects, position, side, side + 2.0, np.r_[0], np.r_[n - 1],
                        cum, gap=gap, **args)
    assert (new == 0).all()
    # the same object with the 1.0 m seen (no scan lost) is split
    seen = np.r_[0.0, np.cumsum(np.r_[1.1, np.full(n - 1, 0.1)])]
    new = split_echelon(objects, position, side, side + 2.0, np.r_[0], np.r_[n - 1],
                        seen, **args)
    assert len(np.unique(new)) == 2


def test_a_van_taller_than_the_sensor_in_a_45_degree_bay_is_parked():
    # its roof above the sensor is never seen: every cross-section is its face
    # (0.1 m deep, in the traffic lane at the near corner), but the near side
    # recedes along its flank from 2.5 m to 6.3 m, into the parking lane (4.0 m)
    van = oblique_car(3.0, 2.5, length=5.4, width=2.0, top=2.6)
    run = make_run([van], ["parked"], n_scans=90, speed=SPEED)
    est = ScanClusterer(speed=SPEED, regions=(4.0, 6.6), region_depth="across").fit(
        run.scans)
    det = est.detect(run.scans)
    assert det["label"].tolist() == ["parked"]
    assert det["mean_depth"].iloc[0] < 4.0  # its mean depth alone: passing
    # a van as tall driving along the street, as near: its near side keeps still
    along = dict(s0=3.0, s1=8.4, depth=2.5, width=2.0, top=lambda off: 2.6)
    run = make_run([along], ["passing"], n_scans=90, speed=SPEED)
    labels = est.detect(run.scans)["label"].tolist()
    assert labels == ["passing"]
