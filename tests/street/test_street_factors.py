"""The simulator's rain, long low passing vehicles and motorbikes at right angles to
the kerb: what the scanner sees of them is what the physics says."""

import numpy as np
import pytest

from tunnelsense.datasets import make_street_scans
from tunnelsense.datasets._street import _simulate
from tunnelsense.datasets._street_sensor import HIT_RAIN, RAIN_RANGE

QUIET = dict(passing_per_min=0.0, pedestrians_per_100m=0.0, bins_per_100m=0.0,
             bollard_rows_per_100m=0.0, trees_per_100m=0.0)


@pytest.mark.parametrize("factor", ["rain_echo_rate", "motorbike_across_fraction",
                                    "motorbike_footway_fraction",
                                    "passing_long_fraction"])
def test_factors_at_zero_leave_a_run_unchanged(factor):
    a = make_street_scans(300, scenario="dense", random_state=3)
    b = make_street_scans(300, scenario="dense", random_state=3, **{factor: 0.0})
    assert np.array_equal(np.stack([s.ranges for s in a.scans]),
                          np.stack([s.ranges for s in b.scans]), equal_nan=True)


def test_rain_echoes_are_near_single_beams_in_front_of_the_target():
    dry = _simulate(600, "sparse", 4)
    wet = _simulate(600, "sparse", 4, rain_echo_rate=0.03)
    echo = wet["hit"] == HIT_RAIN
    assert 0.015 < echo.mean() < 0.03  # 3 % of the beams, less those on near targets
    r = wet["ranges"][echo]
    assert RAIN_RANGE[0] <= r.min() and r.max() <= RAIN_RANGE[1]
    with np.errstate(invalid="ignore"):
        assert not np.any(dry["ranges"][echo] <= r)  # a drop is nearer than the target
    assert np.array_equal(wet["ranges"][~echo], dry["ranges"][~echo], equal_nan=True)
    # isolated: rarely two neighbouring beams of a scan, or one beam in two scans
    assert (echo[:, 1:] & echo[:, :-1]).mean() < 0.002
    assert (echo[1:] & echo[:-1]).mean() < 0.002


def test_motorbikes_at_right_angles_are_deep_and_short():
    sim = _simulate(2000, "sparse", 5, motorbike_fraction=0.8,
                    motorbike_across_fraction=1.0, motorbike_footway_fraction=0.5,
                    parked_cluster_size=3.0, **QUIET)
    where = {v["where"] for v in sim["info"]["vehicles"] if v["kind"] == "motorbike"}
    assert {"across-kerb", "across-footway"} <= where
    theta = sim["geometry"].angles(sim["ranges"].shape[1])[None, :] + sim["roll"][:, None]
    depth = sim["ranges"] * np.cos(theta)
    height = sim["height"][:, None] + sim["ranges"] * np.sin(theta)
    step = np.median(np.diff(sim["x"]))
    kerb, kh = sim["info"]["params"]["kerb_depth"], sim["info"]["params"]["kerb_height"]
    checked, deep, footway = 0, [], 0
    for i, o in enumerate(sim["objects"]):
        if not o.get("across"):
            continue
        on = (sim["hit"] == i) & np.isfinite(sim["ranges"])
        scans = np.flatnonzero(on.any(axis=1))
        if len(scans) < 3:
            continue
        checked += 1
        # 0.7-0.85 m along the street, about 2 m deep across it
        assert len(scans) * step <= 0.85 + 2 * step
        d, h = depth[on], height[on]
        deep.append(np.ptp(d))  # a screen facing the road hides what is behind it
        assert 1.05 <= h.max() <= 1.4  # the screen
        if o["where"] == "across-footway":  # the rear half stands on the footway
            assert o["depth_near"] < kerb < o["depth_near"] + o["width"]
            footway += int((d > kerb + 0.1).any())
            assert np.all(h[d > kerb + 0.1] >= kh - 0.02)
    assert checked >= 10
    assert min(deep) >= 0.4 and max(deep) >= 1.5  # turned round: the whole of it
    assert footway >= 3


@pytest.mark.parametrize("kerb", [5.2, 7.3])
def test_regions_follow_the_kerb(kerb):
    """A narrower or wider street: the regions move with the kerb step the scans
    show, so the parked row stays parked (regions fixed in metres lose it)."""
    from tunnelsense.datasets import make_street_scans
    from tunnelsense.metrics import street_scores
    from tunnelsense.street import ScanClusterer
    from tunnelsense.street._geometry import kerb_steps, roi_points
    from tunnelsense.street._history import History

    run = make_street_scans(600, scenario="sparse", random_state=5, kerb_depth=kerb)
    records = list(run.scans)
    ranges = np.stack([r.ranges for r in records])
    roi = roi_points(ranges, records[0].geometry, History())
    seen = roi.kerb[np.isfinite(roi.kerb)]
    assert len(seen) >= 50 and abs(np.median(seen) - kerb) < 0.1
    assert np.all(np.isnan(kerb_steps(np.full((2, 9), 5.0), np.full((2, 9), 0.5))))
    scores = [street_scores(run.gt, ScanClusterer(follow_kerb=f).fit(
        run.scans).detect(run.scans))["parked"] for f in (False, True)]
    assert scores[1]["recall"] >= 0.9 and scores[1]["precision"] >= 0.9
    assert scores[1]["tp"] >= scores[0]["tp"]
    if kerb < 6.0:  # the parked row's mean depth falls in region I of the fixed ones
        assert scores[0]["recall"] < 0.5 and scores[1]["tp"] > scores[0]["tp"]
