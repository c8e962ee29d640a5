"""The probe car's driving: it stops (a light, a bus ahead) and crawls.  Lengths
follow every scan's own speed, so a parked vehicle seen while the car stands is as
long as it is, and a stream equals the batch across stops."""

import numpy as np
import pytest

from tunnelsense.datasets import make_street_scans
from tunnelsense.metrics import street_scores
from tunnelsense.street import ScanClusterer
from tunnelsense.street._classes import class_features, vehicle_class

QUIET = dict(passing_per_min=0.0, pedestrians_per_100m=0.0, bins_per_100m=0.0,
             bollard_rows_per_100m=0.0)
STOPS = dict(stops_per_min=4.0, stop_duration_s=4.0)


def _rows(table):
    return [tuple(r) for r in table.itertuples(index=False)]


def test_a_vehicle_passed_while_standing_keeps_its_length():
    beside = 0
    for seed in (2, 4, 5, 14):
        run = make_street_scans(1500, scenario="dense", random_state=seed, **QUIET,
                                **STOPS)
        speed = np.array([r.payload["speed"] for r in run.scans])
        standing = speed == 0
        assert standing.sum() > 150  # at least 2 s standing
        truth = {v["id"]: v["length"] for v in run.info["vehicles"]}
        table = ScanClusterer().fit(run.scans).detect(run.scans)
        assert street_scores(run.gt, table)["parked"]["recall"] == 1.0
        parked = table[table["label"] == "parked"]
        for g in run.gt[run.gt["label"] == "parked"].itertuples():
            if (standing[g.first_scan:g.last_scan + 1].sum() < 100 or g.first_scan == 0
                    or g.last_scan == len(speed) - 1):  # (cut by the run's ends)
                continue
            overlap = (np.minimum(parked["last_scan"], g.last_scan)
                       - np.maximum(parked["first_scan"], g.first_scan))
            found = parked.iloc[int(np.argmax(overlap))]
            # the car stood beside it for over a second: still its own length
            assert abs(found["length"] - truth[g.id]) < 0.6, (seed, g, found["length"])
            beside += 1
    assert beside >= 3

@pytest.mark.parametrize("chunk", [1, 7, 64])
def test_stream_equals_batch_across_stops(chunk):
    run = make_street_scans(900, scenario="dense", random_state=5, stops_per_min=6.0,
                            stop_duration_s=3.0)
    X = list(run.scans)
    assert any(r.payload["speed"] == 0 for r in X)
    est = ScanClusterer(max_pending_length=8.0).fit(X)
    table = est.detect(X, all_objects=True)
    state = est.start_stream()
    out = []
    for i in range(0, len(X), chunk):
        out.extend(state.push_many(X[i:i + chunk]))
    out.extend(state.close())
    rows = [row for r in out for row in r.payload["finished_objects"]]
    assert rows == _rows(table) and len(rows) > 5



def test_class_features_are_shares_of_length_not_of_scans():
    # a van's 6 scans at full speed, then 60 scans of its low tail lift standing
    flags = np.array([2] * 6 + [0] * 60)  # the wall above the region of interest
    top = np.array([2.0] * 6 + [0.9] * 60)
    seen = np.arange(66)
    metres = np.r_[np.full(6, 0.8), np.zeros(60)]
    scan = seen.copy()
    side, far = np.full(66, 5.0), np.r_[np.full(6, 7.0), np.full(60, 5.4)]
    by_scan = class_features(flags, top, scan, side, far, 4.8)
    by_length = class_features(flags, top, scan, side, far, 4.8, seen=seen,
                               metres=metres)
    assert vehicle_class(by_scan) != "van"  # the stand decides by its scan count
    assert by_length["wall"] == pytest.approx(1.0) and by_length["top"] == 2.0
    assert by_length["extent"] == 2.0 and vehicle_class(by_length) == "van"
