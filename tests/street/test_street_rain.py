"""Rain and spray: echoes from drops build no vehicle and hide nothing."""

import numpy as np

from tunnelsense import ScanSequence
from tunnelsense.datasets import make_street_scans
from tunnelsense.datasets._street import _simulate
from tunnelsense.datasets._street_sensor import HIT_RAIN
from tunnelsense.metrics import street_scores
from tunnelsense.street import ScanClusterer, make_parking_pipeline

RAIN = dict(dropout_rate=0.05, rain_echo_rate=0.06, passing_per_min=0.0)


def test_raindrops_build_no_passing_vehicle_and_parked_ones_stay():
    run = make_street_scans(1500, scenario="sparse", random_state=7, **RAIN)
    assert run.info["n_passing"] == 0
    for spray_beams, passing in ((2, 2), (0, 10)):
        model = make_parking_pipeline(spray_beams=spray_beams).fit(run.scans)
        det = model[-1].detect(run.scans)
        parked = street_scores(run.gt, det)["parked"]
        assert parked["recall"] >= 0.9 and parked["precision"] == 1.0
        # without the rule, drops link into "vehicles" near the sensor; with it, a
        # few drops beside a dropout (which says nothing) remain
        built = (det["label"] == "passing").sum()
        assert built >= passing if spray_beams == 0 else built <= passing


def test_the_echoes_dropped_are_the_drops():
    sim = _simulate(300, "sparse", 8, **RAIN)
    X = ScanSequence.from_arrays(sim["ranges"], sim["stamps"], sim["geometry"], run="r")
    X = ScanSequence([r.evolve(speed=float(v)) for r, v in
                      zip(X, sim["speed"], strict=True)])
    kept = ScanClusterer().fit(X).transform(X)
    every = ScanClusterer(spray_beams=0).fit(X).transform(X)
    dropped = drops = 0
    for a, b, hit in zip(kept, every, sim["hit"], strict=True):
        gone = np.setdiff1d(b.payload["beams"], a.payload["beams"])
        dropped += len(gone)
        drops += int((hit[gone] == HIT_RAIN).sum())
    assert dropped > 100
    assert drops / dropped >= 0.95  # nearly all of what goes is rain
    assert dropped >= 0.5 * int((sim["hit"] == HIT_RAIN).sum())  # most of the rain
