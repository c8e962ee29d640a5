"""The side of the road as a cue: the wall a trajectory is seen on, and the lock-on
using it on maps whose indicators stand on both walls."""

import numpy as np
import pandas as pd
import pytest

from tunnelsense._cli import main
from tunnelsense.datasets import (
    make_tunnel_kinematics,
    make_tunnel_odometry,
    simulate_indicator_detections,
)
from tunnelsense.positioning import (
    TunnelPositioner,
    observed_side,
    position_errors,
    read_positions,
)
from tunnelsense.positioning._lock import LockOn
from tunnelsense.positioning._side import side_code, side_error_of

F, H = 800.0, 1.0  # focal length (px), sign height (m)


def _track(x_m, *, radius=np.inf, yaw_px=0.0, z=None, noise=0.0, seed=0):
    """Heights and centres of a sign ``x_m`` beside the camera (> 0 right)."""
    z = np.linspace(65.0, 10.0, 60) if z is None else z
    h = F * H / z
    x = 320.0 + yaw_px + F * x_m / z + F * z / (2.0 * radius)
    return h, x + np.random.default_rng(seed).normal(0.0, noise, len(z))


@pytest.mark.parametrize("radius", [np.inf, 250.0, -250.0, 120.0, -120.0])
@pytest.mark.parametrize("yaw_px", [0.0, -90.0, 90.0])
def test_the_side_is_the_drift_whatever_the_curve_and_the_yaw(radius, yaw_px):
    """A curve (the wall ahead bends: a term in 1/h) and a camera yawed off the axis
    (a constant) move the box as much as the side does, but not its drift with
    the growth."""
    for x_m, side in ((-3.7, "left"), (3.7, "right"), (-1.5, "left"), (6.0, "right")):
        h, x = _track(x_m, radius=radius, yaw_px=yaw_px, noise=1.0)
        assert observed_side(h, x) == side


def test_the_side_is_unknown_when_the_track_cannot_tell():
    h, x = _track(-3.7)
    assert observed_side(h[:7], x[:7]) == "unknown"  # too few boxes
    assert observed_side(h, np.full(len(h), np.nan)) == "unknown"  # no centres
    # a sign straight ahead (no drift) in the box jitter
    h, x = _track(0.0, noise=2.0)
    assert observed_side(h, x) == "unknown"
    # a short, far track: the heights barely change, the drift drowns in the noise
    h, x = _track(3.7, z=np.linspace(66.0, 60.0, 12), noise=2.0)
    assert observed_side(h, x) == "unknown"
    with pytest.raises(ValueError, match="same length"):
        observed_side(h, x[:-1])


def test_a_box_merged_with_a_lamp_does_not_turn_the_side():
    h, x = _track(3.7, noise=0.5, z=np.linspace(65.0, 30.0, 30))
    x[[5, 6]] -= 400.0  # two boxes far to the left
    assert observed_side(h, x) == "right"


def test_side_codes():
    assert side_code(["left", "RIGHT ", "", None, "nan", "centre"]).tolist() == [
        -1, 1, 0, 0, 0, 0]


def _passes(lock, dists, sides):
    return [lock.add(d, 0.01, tag=k, side=s) for k, (d, s) in
            enumerate(zip(dists, sides, strict=True))]


def test_the_side_term_is_a_likelihood_factor_not_a_veto():
    """A periodic map with sides: the side pattern of the passes singles out the
    place; a pass seen on the wrong wall costs log(e / (1 - e)) but still lets the
    right place win; one wall, or side_error 0.5: the side changes nothing."""
    chainage = np.arange(0.0, 4000.0, 200.0)
    sides = np.where(np.random.default_rng(6).random(len(chainage)) < 0.5, -1, 1)
    kw = dict(scale=1.0, scale_sigma=0.05, fix_sigma=0.3, gate=4.0, miss_rate=0.05,
              false_pass_rate=5e-4, margin=9.0, min_passes=3)
    at = np.arange(5, 15)
    dists = (chainage[at] - chainage[at[0]]) * 1.02
    lock = LockOn(chainage, sides=sides, **kw)
    done = next(g for g in _passes(lock, dists, sides[at]) if g is not None)
    assert done["indicator"] == at[len(done["passes"]) - 1]
    # one side misread: no lock elsewhere, and the right place is still the best
    misread = sides[at].copy()
    misread[1] *= -1
    lock = LockOn(chainage, sides=sides, **kw)
    got = [g for g in _passes(lock, dists, misread) if g is not None]
    assert all(g["indicator"] == at[len(g["passes"]) - 1] for g in got)
    best, _ = lock.ranking()
    assert lock._h["s"][best] == pytest.approx(chainage[at[-1]], abs=1.0)  # noqa: SLF001
    # the cost of the wrong wall, exactly
    lock = LockOn(chainage, sides=sides, side_error=0.05, **kw)
    lock.add(0.0, 0.01, side=1)
    score = lock._h["score"]  # noqa: SLF001
    np.testing.assert_allclose(score[sides == -1] - score[sides == 1],
                               np.log(0.05 / 0.95))
    for other in (LockOn(chainage, sides=np.ones(len(chainage), int), **kw),
                  LockOn(chainage, sides=sides, side_error=0.5, **kw)):
        assert all(g is None for g in _passes(other, dists, sides[at]))
        assert other.n_explaining() > 5


def _tour(seed, side, spacing=(150.0, 250.0), scale_error=0.03, **det):
    truth = make_tunnel_kinematics(2400.0, start_chainage_m=1000.0,
                                   indicator_spacing_m=spacing, indicator_side=side,
                                   random_state=seed)
    positions, odometry, indicators = make_tunnel_odometry(
        truth, scale_error=scale_error, random_state=seed)
    return truth, positions, odometry, indicators, simulate_indicator_detections(
        truth, random_state=seed, **det)


def test_the_simulator_draws_the_sides_and_the_boxes_follow(global_random_seed):
    """indicator_side="random": the same motion, map chainages and box heights, each
    sign on its own wall (in the map and in the image); "left" is the default."""
    left = _tour(global_random_seed, "left")
    both = _tour(global_random_seed, "random")
    for a, b in zip(left[1:3], both[1:3], strict=True):
        pd.testing.assert_frame_equal(a, b)
    pd.testing.assert_frame_equal(left[3].drop(columns="side"),
                                  both[3].drop(columns="side"))
    pd.testing.assert_series_equal(left[4]["bb_height"], both[4]["bb_height"])
    default = make_tunnel_kinematics(2400.0, start_chainage_m=1000.0,
                                     indicator_spacing_m=(150.0, 250.0),
                                     random_state=global_random_seed)
    pd.testing.assert_frame_equal(
        simulate_indicator_detections(default, random_state=global_random_seed),
        left[4])
    sides = both[3].set_index("id")["side"]
    assert set(sides) == {"left", "right"} and set(left[3]["side"]) == {"left"}
    seen = []
    for oid, g in both[4].groupby("id"):
        centre = (g["bb_left"] + g["bb_width"] / 2).to_numpy()
        assert (centre > 320.0).all() == (sides[oid] == "right")
        seen.append(observed_side(g["bb_height"], centre))
        assert seen[-1] in (sides[oid], "unknown")  # unknown: a short track
    assert seen.count("unknown") <= 1  # the first, cut short by the start
    with pytest.raises(ValueError, match="indicator_side"):
        make_tunnel_kinematics(100.0, indicator_side="both")


def test_a_periodic_map_with_both_walls_locks_and_one_wall_does_not(global_random_seed):
    """Every 200 m: the spacing says nothing, the walls do (never a wrong chainage;
    most tours lock); on one wall, without box positions or with side_error=None,
    nothing locks."""
    locks = 0
    for seed in range(global_random_seed, global_random_seed + 3):
        _, positions, odometry, indicators, det = _tour(seed, "random", spacing=200.0)
        s = positions["chainage"].to_numpy()
        est = TunnelPositioner(initial_chainage=None, side_error=0.01).fit(
            indicators).predict(det, odometry)
        locked = est["locked"].to_numpy()
        locks += bool(locked.any())
        if locked.any():
            assert np.abs(est["chainage"].to_numpy() - s)[locked].max() < 1.0
            assert position_errors(positions, est, odometry, indicators)["lock"]
    assert locks >= 2
    for imap, boxes, e in ((indicators.assign(side="left"), det, 0.01),
                           (indicators, det.drop(columns=["bb_left"]), 0.01),
                           (indicators, det, None)):
        est = TunnelPositioner(initial_chainage=None, side_error=e).fit(
            imap).predict(boxes, odometry)
        assert not est["locked"].any()


def test_one_wall_changes_nothing(global_random_seed):
    """On a map with one wall the side separates no place: the positions are those
    of a positioner that never uses it."""
    _, _, odometry, indicators, det = _tour(global_random_seed, "left",
                                            missed=[8], false_alarms=[1450.0])
    runs = [TunnelPositioner(initial_chainage=None, side_error=e).fit(
        indicators).predict(det, odometry) for e in (None, 0.05, 0.5, 1e-6)]
    for other in runs[1:]:
        pd.testing.assert_frame_equal(runs[0], other)


def test_cli_side_error(tmp_path, capsys):
    """--side-error reaches the positioner: a map every 200 m with both walls locks
    by default (0.05) and with 0.01, not with 'off'; a value outside (0, 0.5] is
    refused."""
    truth, positions, _, _, det = _tour(0, "random", spacing=200.0)
    tour = tmp_path / "tour"
    tour.mkdir()
    truth.write(tour)
    results = tmp_path / "r.txt"
    det.assign(x=-1, y=-1, z=-1).to_csv(results, header=False, index=False)
    base = ["position", str(tour), "--results", str(results), "--start-chainage",
            "unknown", "--quiet", "--out"]
    assert main([*base, str(tmp_path / "p.csv"), "--side-error", "0.01"]) == 0
    got = read_positions(tmp_path / "p.csv", sigma=True)
    locked = got["locked"].to_numpy()
    assert locked.any()
    s = positions.set_index("frame").loc[got["frame"], "chainage"].to_numpy()
    assert np.abs(got["chainage"].to_numpy() - s)[locked].max() < 1.0
    assert main([*base, str(tmp_path / "d.csv")]) == 0  # the default, 0.05
    assert read_positions(tmp_path / "d.csv", sigma=True)["locked"].any()
    assert main([*base, str(tmp_path / "q.csv"), "--side-error", "off"]) == 0
    assert not read_positions(tmp_path / "q.csv", sigma=True)["locked"].any()
    capsys.readouterr()
    for bad in ("0.6", "0", "x"):
        with pytest.raises(SystemExit):
            main([*base, str(tmp_path / "x.csv"), "--side-error", bad])
        err = capsys.readouterr().err
        assert "--side-error" in err and "probability above 0 and at most 0.5" in err


def _twin_stretches(eps):
    """A map whose stretch at 18 repeats the gaps of the stretch at 3 (each gap
    ``1 +- eps`` times), on the other walls; the passes of the stretch at 3 (seen on
    the walls of the stretch at 18 when ``seen_twin``)."""
    g = np.random.default_rng(3).uniform(150.0, 250.0, 30)
    g[18:24] = g[3:9] * (1.0 + eps * (-1.0) ** np.arange(6))
    chainage = np.cumsum(g)
    sides = np.ones(len(chainage), int)
    sides[::3] = -1
    sides[18:25] = -sides[3:10]
    return chainage, sides


def _lock_at(chainage, sides, dists, seen, **kw):
    kw = dict(scale=1.0, scale_sigma=0.05, fix_sigma=0.3, gate=4.0, miss_rate=0.4,
              false_pass_rate=5e-5, margin=9.0, min_passes=3, side_error=0.01) | kw
    lock = LockOn(chainage, sides=sides, **kw)
    got = [lock.add(d, 0.01, side=s) for d, s in zip(dists, seen, strict=True)]
    return next(((k + 1, g["indicator"]) for k, g in enumerate(got) if g is not None),
                (None, None))


def test_the_side_never_lifts_a_place_the_spacing_ranks_behind():
    """The passes fit the stretch at 3 a little better (its twin's gaps are 0.3 %
    off, alternately), but are seen on the twin's walls: with the side alone the
    twin wins by far (a lock there after 4 passes), with side_margin 0 no lock is
    taken there; where the gaps tie, the side settles it, but not before
    side_passes passes."""
    chainage, sides = _twin_stretches(0.003)
    dists = chainage[3:10] - chainage[3]
    seen = sides[18:25]
    n, where = _lock_at(chainage, sides, dists, seen, side_margin=-np.inf,
                        side_passes=2)
    assert (n, where) == (4, 21)
    lock = LockOn(chainage, sides=sides, scale=1.0, scale_sigma=0.05, fix_sigma=0.3,
                  gate=4.0, miss_rate=0.4, false_pass_rate=5e-5, margin=9.0,
                  min_passes=3, side_error=0.01)
    for d, s in zip(dists[:4], seen[:4], strict=True):
        assert lock.add(d, 0.01, side=s) is None
    best, margin = lock.ranking()
    assert margin > 9.0 and -9.0 < lock.lead_without_side(best) < 0.0
    assert _lock_at(chainage, sides, dists, seen) == (None, None)
    # without the side the seventh gap (not repeated) singles out the stretch at 3
    assert _lock_at(chainage, sides, dists, seen, side_error=None) == (7, 9)
    chainage, sides = _twin_stretches(0.0)
    dists = chainage[18:24] - chainage[18]
    assert _lock_at(chainage, sides, dists, sides[18:24]) == (4, 21)
    assert _lock_at(chainage, sides, dists, sides[18:24], side_passes=5) == (5, 22)
    assert _lock_at(chainage, sides, dists, sides[18:24], side_error=None) == (
        None, None)


def test_a_weak_drift_counts_less():
    """A side read from a drift of 3 to 5 standard errors costs less than one read
    surely; never more than side_error allows."""
    e = [side_error_of(t, 0.05) for t in (3.0, 4.0, 5.0, 8.0, np.inf, -3.0)]
    assert e[0] == pytest.approx(0.1587, abs=1e-4) and e[0] == e[5]
    assert e[0] > e[1] > e[2] >= 0.05 and e[3] == e[4] == 0.05
    assert side_error_of(20.0, 0.01) < 0.05 and side_error_of(20.0, 0.2) == 0.2
    chainage = np.arange(0.0, 4000.0, 200.0)
    sides = np.where(np.arange(len(chainage)) % 2, 1, -1)
    costs = []
    for t in (3.0, np.inf):
        lock = LockOn(chainage, sides=sides, scale=1.0, scale_sigma=0.05,
                      fix_sigma=0.3, gate=4.0, miss_rate=0.05, false_pass_rate=5e-4,
                      margin=9.0, min_passes=3, side_error=0.05)
        lock.add(0.0, 0.01, side=1, side_t=t)
        score = lock._h["score"]  # noqa: SLF001
        costs.append(float(np.unique(score[sides == -1] - score[sides == 1])[0]))
    np.testing.assert_allclose(costs, [np.log(0.1587 / 0.8413), np.log(0.05 / 0.95)],
                               atol=1e-3)
