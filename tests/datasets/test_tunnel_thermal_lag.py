"""Physics of the simulated microbolometer's thermal lag: a frame is the radiance of
the instants before it, weighted by exp(-age / tau)."""

import math

import numpy as np
import pytest

from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.datasets._tunnel_camera import _lag_samples

# no noise and no fixed pattern (the slight additive vignetting stays); traffic moves
QUIET = dict(first_indicator_m=25.0, lateral_jitter_m=0.0, pitch_jitter_deg=0.0,
             traffic_per_km=22.0, speed_kmh=90.0, noise_sigma=0.0, fpn_sigma=0.0,
             focal_length_px=700.0, mount_height_m=1.3)


def test_lag_weights_are_the_first_order_response():
    tau = 0.01
    ages, w = _lag_samples(tau, 30.0, span=3.0, per_tau=4)
    assert ages[0] == 0.0 and w.sum() == pytest.approx(1.0)
    # each interval's weight: the exponential's mass over it; the last adds the tail
    assert w[0] == pytest.approx(1 - math.exp(-0.25), rel=1e-9)
    assert np.allclose(w[1:-1] / w[:-2], math.exp(-0.25))
    assert w[-1] == pytest.approx(math.exp(-2.75), rel=1e-9)
    # the mean age of the samples approaches tau as they get finer
    ages, w = _lag_samples(tau, 30.0, span=8.0, per_tau=50)
    assert float(ages @ w) == pytest.approx(tau, rel=0.02)


def test_lagged_frame_is_the_weighted_sum_of_earlier_frames():
    # tau = 2 frame intervals, two samples per tau: the samples are the frames
    # f, f-1, ..., f-5 of the same tour without lag
    tau = 2 / 30
    plain = make_tunnel_tour(12, random_state=7, **QUIET)
    lagged = make_tunnel_tour(12, random_state=7, thermal_time_constant_s=tau, **QUIET)
    assert lagged.info["thermal_time_constant_s"] == tau
    assert "thermal_time_constant_s" not in plain.info
    # the ground truth is every object at the frame's instant
    assert lagged.gt.equals(plain.gt)
    _, w = _lag_samples(tau, 30.0)
    stack = np.stack([fr.image for fr in plain.frames]).astype(np.float64)
    moved = 0
    for f in range(len(w) - 1, 12):
        expected = sum(wj * stack[f - j] for j, wj in enumerate(w))
        got = lagged.frames[f].image.astype(np.float64)
        unclipped = stack[f - len(w) + 1 : f + 1].max(axis=0) < 250
        # each plain frame is rounded (half a grey level), and the lagged one too
        assert np.abs(got - expected)[unclipped].max() <= 1.0
        moved += int((np.abs(got - stack[f])[unclipped] > 8).sum())
    assert moved > 100  # the smear is there: the nearest objects moved


def test_lag_smears_a_near_sign_behind_it():
    # a sign 12 m ahead moves about 23 px a frame (0.7 px a millisecond): the pixels
    # it has just reached are not yet warm (its leading edge is dimmer) and those it
    # has just left are still warm (a tail behind it, toward the vanishing point)
    tau = 0.012
    kw = dict(QUIET, traffic_per_km=0.0, first_indicator_m=12.0)
    plain = make_tunnel_tour(4, random_state=7, **kw)
    lagged = make_tunnel_tour(4, random_state=7, thermal_time_constant_s=tau, **kw)
    assert lagged.gt.equals(plain.gt)
    signs = plain.gt[(plain.gt["class"] == 1) & (plain.gt["frame"] == 4)]
    gt = signs.loc[signs["bb_height"].idxmax()]
    left, top = int(gt["bb_left"]), int(gt["bb_top"])
    w, h = int(gt["bb_width"]), int(gt["bb_height"])
    a = plain.frames[3].image.astype(float)
    b = lagged.frames[3].image.astype(float)
    row = slice(top + h // 4, top + 3 * h // 4)
    # signs on the left wall move left: the left edge leads, the right one trails
    leading = slice(left + 1, left + w // 4)
    beyond = slice(left + w + 1, left + w + 5)
    far_beyond = slice(left + w + 30, left + w + 40)  # farther than 3 tau of motion
    assert (b[row, leading] - a[row, leading]).mean() < -10.0
    assert (b[row, beyond] - a[row, beyond]).mean() > 10.0
    assert np.abs(b[row, far_beyond] - a[row, far_beyond]).mean() < 1.0


@pytest.mark.parametrize("bad", [-0.001, 0.5, "fast"])
def test_bad_time_constant_is_refused(bad):
    with pytest.raises((ValueError, TypeError), match="thermal_time_constant_s"):
        make_tunnel_tour(1, random_state=0, thermal_time_constant_s=bad)
