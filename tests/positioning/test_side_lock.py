"""The side of the road inside the position stream: what each pass gives the
lock-on (its wall and how surely), at a relock too, and the positioner's rules on
when the side may settle a lock."""

import numpy as np
import pandas as pd
import pytest

from tunnelsense.datasets import (
    make_tunnel_kinematics,
    make_tunnel_odometry,
    simulate_indicator_detections,
)
from tunnelsense.positioning import TunnelPositioner
from tunnelsense.positioning._lock import LockOn


def _tour(seed, side, spacing=(150.0, 250.0), **det):
    truth = make_tunnel_kinematics(2400.0, start_chainage_m=1000.0,
                                   indicator_spacing_m=spacing, indicator_side=side,
                                   random_state=seed)
    positions, odometry, indicators = make_tunnel_odometry(
        truth, scale_error=0.03, random_state=seed)
    return positions, odometry, indicators, simulate_indicator_detections(
        truth, random_state=seed, **det)


@pytest.fixture
def given(monkeypatch):
    """Every pass given to a lock-on: ``(side, side_t, pass frame)``."""
    seen = []
    add = LockOn.add

    def spy(self, *args, **kwargs):
        row = kwargs["tag"][3]
        seen.append((kwargs.get("side", 0), kwargs.get("side_t", np.inf),
                     row["pass_frame"]))
        return add(self, *args, **kwargs)

    monkeypatch.setattr(LockOn, "add", spy)
    return seen


def _passes_to_lock(fixes):
    return int(fixes["reason"].str.contains("lock").sum())


def test_each_pass_gives_its_wall_and_how_surely(given, global_random_seed):
    """The lock-on gets the drift's own t statistic with the wall (a weak drift
    counts less), not a side taken as sure."""
    _, odometry, indicators, det = _tour(global_random_seed, "random")
    TunnelPositioner(initial_chainage=None).fit(indicators).predict(det, odometry)
    known = [(s, t) for s, t, _ in given if s]
    assert len(known) >= 3
    for side, t in known:
        assert np.isfinite(t) and abs(t) >= 3.0 and np.sign(t) == side


def test_a_relock_uses_the_side_of_the_passes_it_replays(given, global_random_seed):
    """Told the tour starts at 0 when it starts 1 km in, on a map with both walls:
    the passes the gate rejected are replayed into a new lock-on with the walls
    they were seen on (they came while the position was taken as known), and the
    position is found again; on one wall nothing about the side is used."""
    positions, odometry, indicators, det = _tour(global_random_seed, "random")
    est, fixes = TunnelPositioner().fit(indicators).predict(det, odometry,
                                                             return_fixes=True)
    assert "locked on to the map" in fixes.attrs["lock_status"]
    # the first passes the new lock-on got: those the gate rejected in a row
    assert len(given) >= 3
    walls = indicators.set_index("id")["side"]
    truth = positions.set_index("frame")["chainage"]
    chainage = indicators.set_index("id")["chainage"]
    for side, _, frame in given[:3]:
        # the indicator truly passed at that frame, and its wall
        nearest = (chainage - truth[frame]).abs().idxmin()
        assert side == (1 if walls[nearest] == "right" else -1)
    relock = int(fixes.attrs["lock_status"].rsplit(" ", 1)[1])
    after = est["frame"].to_numpy() >= relock
    err = np.abs(est["chainage"].to_numpy() - positions["chainage"].to_numpy())
    assert est["locked"].to_numpy()[after].all() and err[after].max() < 1.0
    one_wall = indicators.assign(side="left")
    runs = [TunnelPositioner(side_error=e).fit(one_wall).predict(det, odometry)
            for e in (None, 0.05)]
    pd.testing.assert_frame_equal(*runs)


def test_side_passes_and_side_margin_reach_the_lock_on(global_random_seed):
    """On a map every 200 m with both walls only the side can lock, so the rules on
    a lock that needs it hold: side_passes delays it, a side_margin the spacing
    cannot give prevents it, and the status says why."""
    done = []
    for seed in range(global_random_seed, global_random_seed + 4):
        _, odometry, indicators, det = _tour(seed, "random", spacing=200.0)
        est, fixes = TunnelPositioner(initial_chainage=None, side_error=0.01).fit(
            indicators).predict(det, odometry, return_fixes=True)
        if est["locked"].any():
            done.append((seed, _passes_to_lock(fixes)))
    assert done
    for seed, n in done[:2]:
        _, odometry, indicators, det = _tour(seed, "random", spacing=200.0)
        est, fixes = TunnelPositioner(
            initial_chainage=None, side_error=0.01, side_passes=n + 1).fit(
            indicators).predict(det, odometry, return_fixes=True)
        assert not est["locked"].any() or _passes_to_lock(fixes) > n
        est, fixes = TunnelPositioner(
            initial_chainage=None, side_error=0.01, side_margin=1.0).fit(
            indicators).predict(det, odometry, return_fixes=True)
        assert not est["locked"].any()
        assert "(side_margin)" in fixes.attrs["lock_status"]


def test_the_status_says_a_lock_waits_for_side_passes():
    """The side singles out a place after three passes; side_passes=5 withholds it
    and the status says so."""
    g = np.random.default_rng(3).uniform(150.0, 250.0, 30)
    g[18:24] = g[3:9]  # the stretch at 18 repeats the gaps of the stretch at 3
    chainage = np.cumsum(g)
    sides = np.ones(len(chainage), int)
    sides[::3] = -1
    sides[18:25] = -sides[3:10]
    lock = LockOn(chainage, sides=sides, scale=1.0, scale_sigma=0.05, fix_sigma=0.3,
                  gate=4.0, miss_rate=0.4, false_pass_rate=5e-5, margin=9.0,
                  min_passes=3, side_error=0.01, side_passes=5)
    dists = chainage[18:22] - chainage[18]
    got = [lock.add(d, 0.01, side=s) for d, s in zip(dists, sides[18:22],
                                                     strict=True)]
    assert got == [None] * 4 and lock.side_withheld == "side_passes"
    assert lock.add(chainage[22] - chainage[18], 0.01, side=sides[22]) is not None
    assert lock.side_withheld is None
