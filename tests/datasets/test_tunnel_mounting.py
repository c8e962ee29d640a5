"""Physics of the camera's mounting and lens and of the tunnel's sign side: roll about
the optical axis, frame rate, vignetting, signs on the right wall."""

import math

import numpy as np
import pytest

from tunnelsense.datasets import make_tunnel_tour

# no noise, no fixed pattern, nothing moving: the scene itself
QUIET = dict(first_indicator_m=40.0, lateral_jitter_m=0.0, pitch_jitter_deg=0.0,
             traffic_per_km=0.0, speed_kmh=80.0, noise_sigma=0.0, fpn_sigma=0.0,
             focal_length_px=700.0, mount_height_m=1.3)


def _additive_vignetting(h, w):  # the slight one every tour has, added to the image
    yy, xx = np.mgrid[0:h, 0:w]
    r2 = ((xx - w / 2) / (w / 2)) ** 2 + ((yy - h / 2) / (h / 2)) ** 2
    return 3.0 - 3.0 * r2


def _sign(tour, frame=1):
    gt = tour.gt
    rows = gt[(gt["class"] == 1) & (gt["frame"] == frame)]
    return rows.loc[rows["bb_height"].idxmax()]


def _centre(row):
    return np.array([row["bb_left"] + row["bb_width"] / 2,
                     row["bb_top"] + row["bb_height"] / 2])


def _turn(points, deg, centre):
    """Points turned ``deg`` counter-clockwise as displayed (rows downward)."""
    a = math.radians(deg)
    d = np.asarray(points, float) - centre
    return centre + np.stack([d[..., 0] * math.cos(a) + d[..., 1] * math.sin(a),
                              -d[..., 0] * math.sin(a) + d[..., 1] * math.cos(a)], -1)


def test_roll_turns_the_image_about_the_principal_point():
    roll = 4.0
    flat = make_tunnel_tour(2, random_state=5, **QUIET)
    tilted = make_tunnel_tour(2, random_state=5, roll_deg=roll, **QUIET)
    assert tilted.info["roll_deg"] == roll and "roll_deg" not in flat.info
    H, W = flat.image_shape
    centre = np.array([W / 2, H / 2])
    # the sign's box centre turns with the image (the box is the turned box's hull)
    a, b = _sign(flat), _sign(tilted)
    assert np.allclose(_centre(b), _turn(_centre(a), roll, centre), atol=1e-6)
    assert b["bb_height"] > a["bb_height"]  # the hull of a turned upright rectangle
    # the image: the flat one turned (nearest pixel), not turned the other way
    v = _additive_vignetting(H, W)
    img_a = flat.frames[1].image - v
    img_b = tilted.frames[1].image - v
    rows, cols = np.mgrid[H // 5 : 4 * H // 5, W // 5 : 4 * W // 5]
    pts = np.stack([cols + 0.0, rows + 0.0], -1)

    def error(deg):  # pixel of the tilted image vs the flat one, turned back
        src = np.rint(_turn(pts, -deg, centre)).astype(int)
        return np.abs(img_b[rows, cols] - img_a[src[..., 1], src[..., 0]])

    assert np.median(error(roll)) <= 1.0
    assert error(roll).mean() < 0.5 * error(-roll).mean()


def test_frame_rate_sets_the_motion_per_frame():
    slow = make_tunnel_tour(20, random_state=5, **QUIET)
    fast = make_tunnel_tour(40, random_state=5, frame_rate_hz=60.0, **QUIET)
    assert fast.frame_rate == 60.0 and slow.frame_rate == 30.0
    # the same road in twice the frames: half the displacement per frame
    ds_slow = np.diff(slow.kinematics.chainage)
    ds_fast = np.diff(fast.kinematics.chainage)
    assert np.allclose(ds_fast, 80.0 / 3.6 / 60.0)
    assert np.allclose(ds_slow, 2 * ds_fast[0])
    assert fast.info["distance_m"] == pytest.approx(slow.info["distance_m"], abs=1e-6)
    # frame 2k+1 at 60 fps shows what frame k+1 shows at 30 fps
    for k in (0, 9, 19):
        a, b = _sign(slow, k + 1), _sign(fast, 2 * k + 1)
        assert _centre(b) == pytest.approx(_centre(a), abs=1e-6)


def test_vignetting_scales_the_radiance_to_its_corner_value():
    plain = make_tunnel_tour(1, random_state=5, **QUIET)
    dim = make_tunnel_tour(1, random_state=5, vignetting=0.75, **QUIET)
    assert dim.info["vignetting"] == 0.75
    H, W = plain.image_shape
    v = _additive_vignetting(H, W)
    ratio = (dim.frames[0].image - v) / (plain.frames[0].image - v)
    assert np.median(ratio[H // 2 - 4 : H // 2 + 4, W // 2 - 4 : W // 2 + 4]) == (
        pytest.approx(1.0, abs=0.01))
    for corner in (ratio[:3, :3], ratio[:3, -3:], ratio[-3:, :3], ratio[-3:, -3:]):
        assert np.median(corner) == pytest.approx(0.75, abs=0.02)
    # halfway to a corner: the squared distance, a quarter of the fall
    assert np.median(ratio[H // 4 - 2 : H // 4 + 2, W // 4 - 2 : W // 4 + 2]) == (
        pytest.approx(1 - 0.25 / 4, abs=0.015))


def test_signs_on_the_right_wall_leave_the_image_on_the_right():
    left = make_tunnel_tour(60, random_state=5, **QUIET)
    right = make_tunnel_tour(60, random_state=5, indicator_side="right", **QUIET)
    assert right.info["indicator_side"] == "right"
    assert (right.kinematics.indicator_map()["side"] == "right").all()
    W = right.image_shape[1]
    for tour, sign in ((left, -1), (right, 1)):
        ind = tour.gt[tour.gt["class"] == 1]
        first = ind[ind["id"] == ind["id"].min()].sort_values("frame")
        u = first["bb_left"] + first["bb_width"] / 2 - W / 2
        assert (np.sign(u) == sign).all()
        assert (np.diff(np.abs(u.to_numpy())) > 0).all()  # away from the centre
    # the right wall is farther from the camera in the left lane: the same sign at
    # the same depth stands farther off the centre
    a, b = _sign(left), _sign(right)
    assert b["bb_height"] == pytest.approx(a["bb_height"], rel=0.02)  # same depth
    assert abs(_centre(b)[0] - W / 2) > abs(_centre(a)[0] - W / 2)


@pytest.mark.parametrize("bad", [dict(roll_deg=45.0), dict(frame_rate_hz=0.0),
                                 dict(vignetting=1.5), dict(indicator_side="top")])
def test_bad_mounting_parameters_are_refused(bad):
    name = next(iter(bad))
    with pytest.raises((ValueError, TypeError), match=name):
        make_tunnel_tour(1, random_state=0, **bad)
