"""TunnelPositioner on long tours with the detector's output simulated statistically.

Rendering 2 km of video takes minutes, so these tours have their detections drawn
from the pinhole model (``simulate_indicator_detections``); ``test_end_to_end.py``
runs the real detector on a rendered tour.
"""

import numpy as np
import pandas as pd
import pytest

from tunnelsense import FrameRecord
from tunnelsense.datasets import (
    make_tunnel_kinematics,
    make_tunnel_odometry,
    simulate_indicator_detections,
)
from tunnelsense.exceptions import InputFormatError
from tunnelsense.positioning import (
    TunnelPositioner,
    dead_reckoning,
    detection_table,
    estimate_pass,
    forward,
    position_errors,
    rts_smooth,
)
from tunnelsense.utils import sklearn_api_checks


def _tour(seed, distance=2000.0, scale_error=0.03, **detections):
    truth = make_tunnel_kinematics(distance, random_state=seed)
    positions, odometry, indicators = make_tunnel_odometry(
        truth, scale_error=scale_error, random_state=seed)
    det = simulate_indicator_detections(truth, random_state=seed, **detections)
    return truth, positions, odometry, indicators, det


@pytest.mark.parametrize("smooth", [False, True])
def test_two_km_with_three_percent_scale_error(global_random_seed, smooth):
    truth, positions, odometry, indicators, det = _tour(global_random_seed)
    est, fixes = TunnelPositioner(smooth=smooth).fit(indicators).predict(
        det, odometry, return_fixes=True)
    errors = position_errors(positions, est, odometry, indicators)
    dr = errors["dead_reckoning"]
    assert dr["max"] > 50.0  # 3 % of 2 km
    passes = [abs(p["error"]) for p in errors["passes"]]
    assert len(passes) >= 9
    assert fixes["accepted"].sum() >= len(passes)
    err = np.abs(est["chainage"] - positions["chainage"]).to_numpy()
    if smooth:
        # offline: every fix known; < 1 m at each pass, 10x better than dead reckoning
        assert max(passes) < 1.0
        assert errors["max"] * 10 <= dr["max"]
    else:
        # online: before the second sign the scale error is not observable yet, so
        # the error is the odometry's drift over that stretch; once two signs have
        # been passed, < 1 m at every pass and everywhere
        second = fixes.loc[fixes["accepted"], "pass_frame"].iloc[1]
        after = est["frame"].to_numpy() > second
        assert max(passes[2:]) < 1.0
        assert err[after].max() < 1.0
        first = truth.indicator_chainage[1]
        assert errors["max"] <= 0.035 * first + 1.0
    assert errors["within_2_sigma"] > 0.9


def test_missed_sign_and_false_alarm(global_random_seed):
    truth = make_tunnel_kinematics(2000.0, random_state=global_random_seed)
    c = truth.indicator_chainage
    false_at = c[6] + 57.0
    _, positions, odometry, indicators, det = _tour(
        global_random_seed, missed=[int(truth.indicator_ids[4])], false_alarms=[false_at])
    est, fixes = TunnelPositioner(smooth=True).fit(indicators).predict(
        det, odometry, return_fixes=True)
    false_id = int(truth.indicator_ids.max()) + 1
    row = fixes[fixes["track_id"] == false_id].iloc[0]
    assert not row["accepted"] and "gate" in row["reason"]
    assert row["mahalanobis"] > 10
    assert int(truth.indicator_ids[4]) not in set(fixes.loc[fixes["accepted"],
                                                           "indicator_id"])
    errors = position_errors(positions, est, odometry, indicators)
    assert errors["max"] * 10 <= errors["dead_reckoning"]["max"]
    # across the missed sign the error grows only with the (calibrated) odometry
    s = positions["chainage"].to_numpy()
    gap = (s > c[3]) & (s < c[5])
    assert np.abs(est["chainage"].to_numpy() - s)[gap].max() < 1.0
    online = TunnelPositioner().fit(indicators).predict(det, odometry)
    assert np.abs(online["chainage"].to_numpy() - s)[gap].max() < 2.0


@pytest.mark.slow
def test_streaming_equals_batch_and_is_immediate(global_random_seed):
    _, _, odometry, indicators, det = _tour(global_random_seed, distance=800.0,
                                            false_alarms=[500.0])
    for smooth in (False, True):
        pos = TunnelPositioner(smooth=smooth).fit(indicators)
        batch = pos.predict(det, odometry)
        stream = pos.start_stream()
        by_frame = dict(iter(det.groupby("frame")))
        online = []
        for f, t, v, w in odometry.itertuples(index=False):
            out = stream.push(f, t, v, w, by_frame.get(f))
            assert out[0] == f  # this frame's position, at once
            online.append(out)
        got = stream.close()
        # with smooth: the stream's fixed-lag smoother (its window holds this tour)
        # against the whole-tour smoother, the same estimate to rounding
        pd.testing.assert_frame_equal(got, batch, rtol=0, atol=0 if not smooth
                                      else 1e-4)
        if not smooth:
            pd.testing.assert_frame_equal(pd.DataFrame(online, columns=got.columns),
                                          batch)


@pytest.mark.slow
def test_late_detections_are_delayed_measurements(global_random_seed):
    """Detections released late correct the past; the final smoothed answer is equal."""
    _, positions, odometry, indicators, det = _tour(global_random_seed, distance=800.0)
    pos = TunnelPositioner(smooth=True).fit(indicators)
    batch = pos.predict(det, odometry)
    stream = pos.start_stream()
    lag = 40  # the detector releases frames 40 frames late
    frames = odometry["frame"].to_numpy()
    for i, (f, t, v, w) in enumerate(odometry.itertuples(index=False)):
        late = det[det["frame"] == f - lag] if i >= lag else None
        stream.push(f, t, v, w, late, until=f - lag)
    stream.add_detections(det[det["frame"] > frames[-1] - lag])
    # a fix known after its pass (here) or before it (in the batch: the sign left
    # the image a few metres ahead) is applied at another frame: the process noise
    # over those metres is left out, a fraction of a millimetre
    pd.testing.assert_frame_equal(stream.close(), batch, rtol=0, atol=1e-3)
    fixed = stream.fixes["accepted"].sum()
    assert fixed >= 3


def test_without_scale_estimation_the_drift_stays():
    _, positions, odometry, indicators, det = _tour(0)
    s = positions["chainage"].to_numpy()
    fixed = TunnelPositioner(estimate_scale=False, relock_after=0).fit(
        indicators).predict(det, odometry)
    scaled = TunnelPositioner().fit(indicators).predict(det, odometry)
    tail = s > 1000
    e_fixed = np.abs(fixed["chainage"].to_numpy() - s)[tail].max()
    e_scaled = np.abs(scaled["chainage"].to_numpy() - s)[tail].max()
    assert e_fixed > 3.0 > 1.0 > e_scaled  # 3 % of 200 m between signs
    # the gate rejects the fixes of the drifting filter; after three in a row it
    # drops its position rather than write a drifting one (the map is periodic:
    # there is nothing to lock on to again)
    relock = TunnelPositioner(estimate_scale=False).fit(indicators)
    got, fixes = relock.predict(det, odometry, return_fixes=True)
    assert fixes["reason"].str.startswith("outside the gate").sum() >= 3
    assert got["locked"].iloc[0] and not got["locked"].iloc[-1]
    assert got.loc[~got["locked"], "chainage"].isna().all()


def test_estimate_pass_is_exact_on_the_pinhole_model():
    d = np.linspace(0.0, 80.0, 60)
    h = 800.0 / (100.0 - d)
    got, var = estimate_pass(d, h)
    assert got == pytest.approx(100.0, abs=1e-9)
    assert var < 1e-12
    got, _ = estimate_pass(d, h, slope=-1 / 800.0)
    assert got == pytest.approx(100.0, abs=1e-9)
    # outlier boxes (merged with a lamp), a fifth of them, are left out
    h2 = h.copy()
    h2[::5] *= 2.3
    assert estimate_pass(d, h2)[0] == pytest.approx(100.0, abs=1e-6)
    # a receding object has no pass
    assert np.isnan(estimate_pass(d, h[::-1])[0])
    assert np.isnan(estimate_pass(d[:2], h[:2])[0])


def test_a_short_trajectory_gets_at_least_the_detectors_box_noise():
    """A dozen boxes, far from the pass: their residuals can be small by chance; with
    the noise known from other trajectories the pass's variance is that noise's."""
    rng = np.random.default_rng(0)
    d = np.linspace(0.0, 6.0, 12)
    truth = 800.0 / (17.0 - d)
    passes, own, floored = [], [], []
    for _ in range(400):
        h = truth * (1.0 + 0.03 * rng.standard_normal(12))
        got, var = estimate_pass(d, h)
        passes.append(got)
        own.append(var)
        floored.append(estimate_pass(d, h, noise=0.03)[1])
    err2 = (np.asarray(passes) - 17.0) ** 2
    own, floored = np.asarray(own), np.asarray(floored)
    assert np.all(floored >= own)
    # its own residuals: a pass 3 sigma off in 2-4 % of the trajectories (ten times
    # a normal variable's 0.3 %); with the noise as a floor, about 0.3 %
    assert np.mean(err2 > 9 * own) > 0.015
    assert np.mean(err2 > 9 * floored) < 0.02
    # the floor only raises: a noisier trajectory keeps its own
    h = truth * (1.0 + 0.1 * rng.standard_normal(12))
    assert estimate_pass(d, h, noise=0.01) == estimate_pass(d, h)


def test_rts_smoother_matches_a_least_squares_line():
    """No process noise: the smoother's states all lie on the line through the fixes."""
    inc = np.full(100, 1.03)
    fixes = {10: [(0.0, 10.0, 1e-4)], 90: [(0.0, 90.0, 1e-4)]}
    prior, post, pc, qc = forward([0.0, 1.0], np.diag([100.0, 0.01]), inc,
                                  np.zeros(100), np.zeros(100), fixes)
    x, _ = rts_smooth(inc, prior, post, pc, qc)
    np.testing.assert_allclose(x[:, 0], np.arange(101.0), atol=1e-3)
    np.testing.assert_allclose(x[:, 1], 1 / 1.03, atol=1e-5)


def test_records_and_results_tables_are_the_same_input():
    img = np.zeros((4, 4), np.uint8)
    records = [FrameRecord("t", f, img, {"detections": np.array(
        [[1.0, 2.0, 3.0, 10.0 + f, 7, 1.0]])}) for f in (1, 2, 3)]
    table = pd.DataFrame({"frame": [1, 2, 3], "id": [7, 7, 7], "bb_left": 1.0,
                          "bb_width": 3.0, "bb_height": [11.0, 12.0, 13.0]})
    pd.testing.assert_frame_equal(detection_table(records), detection_table(table))
    # the box's horizontal centre (the side it is seen on); without bb_left and
    # bb_width, a table has none
    assert detection_table(table)["bb_centre_x"].tolist() == [2.5] * 3
    assert "bb_centre_x" not in detection_table(table.drop(columns="bb_left"))


def test_bad_inputs_are_named():
    imap = pd.DataFrame({"id": [1, 2], "chainage": [100.0, 300.0]})
    pos = TunnelPositioner().fit(imap)
    odo = pd.DataFrame({"frame": [1, 2, 3], "stamp": [0.0, 0.1, 0.2],
                        "speed": [20.0] * 3, "yaw_rate": 0.0})
    with pytest.raises(InputFormatError, match="frames must increase"):
        pos.predict(pd.DataFrame(columns=["frame", "id", "bb_height"]),
                    odo.iloc[[0, 2, 1]])
    with pytest.raises(InputFormatError, match="bb_height"):
        pos.predict(pd.DataFrame({"frame": [1], "id": [1]}), odo)
    with pytest.raises(InputFormatError, match="frame 9"):
        pos.predict(pd.DataFrame({"frame": [9], "id": [1], "bb_height": [5.0]}), odo)
    with pytest.raises(InputFormatError, match="distinct"):
        TunnelPositioner().fit(pd.DataFrame({"id": [1, 1], "chainage": [1.0, 2.0]}))
    with pytest.raises(InputFormatError, match="chainage"):
        TunnelPositioner().fit(pd.DataFrame({"id": [1]}))
    with pytest.raises(ValueError, match="gate"):
        TunnelPositioner(gate=-1).fit(imap)


def test_dead_reckoning_and_errors():
    _, positions, odometry, indicators, _ = _tour(1, distance=500.0, scale_error=0.0)
    dr = dead_reckoning(odometry)
    # no scale error: the speed bias (0.05 m/s) over the tour's time, and noise
    duration = positions["stamp"].iloc[-1]
    assert dr[-1] - positions["chainage"].iloc[-1] == pytest.approx(0.05 * duration,
                                                                   abs=0.3)
    est = positions.assign(chainage=positions["chainage"] + 2.0, sigma=1.0)
    errors = position_errors(positions, est, odometry, indicators)
    assert errors["max"] == pytest.approx(2.0) and errors["within_2_sigma"] == 1.0
    assert all(p["error"] == pytest.approx(2.0) for p in errors["passes"])


@pytest.mark.parametrize("name, check", list(sklearn_api_checks(TunnelPositioner())))
def test_sklearn_api_checks(name, check):
    check()


def test_a_fitted_positioner_round_trips_through_a_safe_model_file(tmp_path):
    from tunnelsense.io import load_model, save_model

    _, _, odometry, indicators, det = _tour(2, distance=600.0)
    pos = TunnelPositioner(smooth=True, gate=3.5).fit(indicators)
    save_model(pos, tmp_path / "p.skops")
    back = load_model(tmp_path / "p.skops")
    assert back.get_params() == pos.get_params()
    pd.testing.assert_frame_equal(back.predict(det, odometry), pos.predict(det, odometry))


def test_scale_from_slope_is_calibrated(global_random_seed):
    """The scale each trajectory's box growth gives, over many signs: centred on
    the truth, its errors as large as its standard deviation says; too few boxes
    give NaN."""
    from tunnelsense.positioning import dead_reckoning, scale_from_slope

    z = []
    for seed in range(global_random_seed, global_random_seed + 3):
        truth = make_tunnel_kinematics(4000.0, random_state=seed)
        positions, odometry, _ = make_tunnel_odometry(truth, scale_error=-0.03,
                                                      speed_bias=0.0,
                                                      random_state=seed)
        det = simulate_indicator_detections(truth, focal_length_px=700.0,
                                            sign_height_m=1.2, random_state=seed)
        d = dead_reckoning(odometry)
        frames = odometry["frame"].to_numpy()
        for _, g in det.groupby("id"):
            dist = np.interp(g["frame"].to_numpy(), frames, d)
            c, var = scale_from_slope(dist, g["bb_height"].to_numpy(), 700.0 * 1.2)
            if np.isfinite(c):
                z.append((c - 1.0 / 0.97) / np.sqrt(var))
    z = np.asarray(z)
    assert len(z) > 40
    assert abs(z.mean()) < 0.5 and 0.7 < z.std() < 1.3
    c, var = scale_from_slope([0.0, 1.0, 2.0], [10.0, 11.0, 12.0], 800.0)
    assert np.isnan(c) and np.isnan(var)
