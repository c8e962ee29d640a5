"""Physics of the camera's pointing and optics and of its output stage: yaw, shake
(vibration), defocus, a non-linear response, 14-bit counts."""

import math

import cv2
import numpy as np
import pytest

from tunnelsense.datasets import make_tunnel_tour

# no noise, no fixed pattern, nothing moving: the scene itself
QUIET = dict(first_indicator_m=40.0, lateral_jitter_m=0.0, pitch_jitter_deg=0.0,
             traffic_per_km=0.0, speed_kmh=80.0, noise_sigma=0.0, fpn_sigma=0.0,
             focal_length_px=700.0, mount_height_m=1.3)
F = 700.0


def _additive_vignetting(h, w):  # the slight one every tour has, added to the image
    yy, xx = np.mgrid[0:h, 0:w]
    r2 = ((xx - w / 2) / (w / 2)) ** 2 + ((yy - h / 2) / (h / 2)) ** 2
    return 3.0 - 3.0 * r2


def _signs(tour, frame=1):
    gt = tour.gt
    return gt[(gt["class"] == 1) & (gt["frame"] == frame)].set_index("id")


@pytest.mark.parametrize("yaw", [-4.0, 3.0])
def test_yaw_turns_the_view_about_the_vertical_axis(yaw):
    flat = make_tunnel_tour(2, random_state=5, **QUIET)
    turned = make_tunnel_tour(2, random_state=5, yaw_deg=yaw, **QUIET)
    assert turned.info["yaw_deg"] == yaw and "yaw_deg" not in flat.info
    H, W = flat.image_shape
    cx, cy = W / 2, H / 2
    psi = math.radians(yaw)
    # a sign's vertical edges: the ray's azimuth less the yaw (exact, a rotation)
    a, b = _signs(flat), _signs(turned)
    assert len(a) and list(a.index) == list(b.index)
    for edge in ("left", "right"):
        u = a["bb_left"] + (a["bb_width"] if edge == "right" else 0.0)
        want = cx + F * np.tan(np.arctan((u - cx) / F) - psi)
        got = b["bb_left"] + (b["bb_width"] if edge == "right" else 0.0)
        np.testing.assert_allclose(got, want, atol=1e-6)
    # the image: the flat one seen through the rotation (nearest pixel), not the
    # rotation the other way
    v = _additive_vignetting(H, W)
    img_a = flat.frames[1].image - v
    img_b = turned.frames[1].image - v
    rows, cols = np.mgrid[H // 5: 4 * H // 5, W // 5: 4 * W // 5]
    xc, yc = (cols + 0.5 - cx) / F, (cy - rows - 0.5) / F

    def error(deg):
        c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
        den = c - xc * s
        uf = cx + F * (xc * c + s) / den - 0.5
        vf = cy - F * yc / den - 0.5
        ok = (uf >= 0) & (uf <= W - 1) & (vf >= 0) & (vf <= H - 1)
        src = np.rint(np.stack([vf, uf])).astype(int)
        src[0] = src[0].clip(0, H - 1)
        src[1] = src[1].clip(0, W - 1)
        return np.abs(img_b[rows, cols] - img_a[src[0], src[1]])[ok]

    assert np.median(error(yaw)) <= 1.0
    assert error(yaw).mean() < 0.5 * error(-yaw).mean()
    # turned toward the signs' (left) wall, the signs leave the image later
    if yaw < 0:
        assert turned.gt["frame"][turned.gt["class"] == 1].max() >= flat.gt["frame"][
            flat.gt["class"] == 1].max()


def test_shake_jitters_the_view_from_frame_to_frame():
    n, sigma = 120, 0.3
    calm = make_tunnel_tour(n, random_state=5, **QUIET)
    shaken = make_tunnel_tour(n, random_state=5, shake_deg=sigma, **QUIET)
    assert shaken.info["shake_deg"] == sigma

    def wobble(tour):
        """Second differences of the farthest sign's centre (a smooth path: ~0)."""
        gt = tour.gt[tour.gt["class"] == 1]
        far = gt.groupby("id")["frame"].count().idxmax()
        g = gt[gt["id"] == far].sort_values("frame")
        g = g[g["bb_height"] < 20]  # far: its own motion is slow and smooth
        u = (g["bb_left"] + g["bb_width"] / 2).to_numpy()
        v = (g["bb_top"] + g["bb_height"] / 2).to_numpy()
        return np.diff(u, 2).std(), np.diff(v, 2).std()

    calm_u, calm_v = wobble(calm)
    got_u, got_v = wobble(shaken)
    # an independent jitter of sigma per frame: the second difference has
    # sqrt(6) sigma, f tan(sigma) px
    want = math.sqrt(6) * F * math.tan(math.radians(sigma))
    assert calm_u < 0.05 * want and calm_v < 0.05 * want
    for got in (got_u, got_v):
        assert 0.7 * want < got < 1.3 * want
    # the same tunnel, traffic and signs: the shake has a random stream of its own
    assert (calm.info["first_indicator_m"], calm.info["lamp_spacing_m"]) == (
        shaken.info["first_indicator_m"], shaken.info["lamp_spacing_m"])


def test_defocus_blurs_the_radiance():
    sharp = make_tunnel_tour(2, random_state=5, **QUIET)
    soft = make_tunnel_tour(2, random_state=5, defocus_px=1.5, **QUIET)
    assert soft.info["defocus_px"] == 1.5
    H, W = sharp.image_shape
    v = _additive_vignetting(H, W)
    a = sharp.frames[1].image - v
    want = cv2.GaussianBlur(a.astype(np.float32), (0, 0), 1.5,
                            borderType=cv2.BORDER_REFLECT)
    got = soft.frames[1].image - v
    # the rounding of the sharp frame, blurred, and of the soft one: within 1 (away
    # from the lamps, whose radiance the sharp frame clips at 255)
    clipped = cv2.dilate((sharp.frames[1].image >= 255).astype(np.uint8),
                         np.ones((15, 15), np.uint8)).astype(bool)
    inside = np.zeros((H, W), bool)
    inside[8:-8, 8:-8] = True
    assert (inside & ~clipped).mean() > 0.8
    assert np.abs(got - want)[inside & ~clipped].max() <= 1.0 + 1e-6
    # and a sign's peak over the wall falls: it is small
    s = _signs(sharp).sort_values("bb_height").iloc[0]
    r0, r1 = int(s["bb_top"]), int(math.ceil(s["bb_top"] + s["bb_height"]))
    c0, c1 = int(s["bb_left"]), int(math.ceil(s["bb_left"] + s["bb_width"]))
    assert got[r0:r1, c0:c1].max() < a[r0:r1, c0:c1].max()
    # the ground truth does not move
    assert sharp.gt.equals(soft.gt)


def test_fourteen_bits_are_the_grey_levels_in_finer_counts():
    eight = make_tunnel_tour(3, random_state=5, **QUIET)
    fourteen = make_tunnel_tour(3, random_state=5, bit_depth=14, **QUIET)
    assert fourteen.info["bit_depth"] == 14 and "bit_depth" not in eight.info
    for a, b in zip(eight.frames, fourteen.frames, strict=True):
        assert a.image.dtype == np.uint8 and b.image.dtype == np.uint16
        assert int(b.image.max()) <= 255 * 64
        # the same radiance in 64 counts per grey level, rounded in each
        assert np.abs(b.image / 64.0 - a.image).max() <= 0.5 + 0.5 / 64 + 1e-9
    assert eight.gt.equals(fourteen.gt)


@pytest.mark.parametrize("gamma", [0.7, 1.4])
def test_response_gamma_bends_the_grey_levels(gamma):
    linear = make_tunnel_tour(2, random_state=5, bit_depth=16, **QUIET)
    bent = make_tunnel_tour(2, random_state=5, response_gamma=gamma, **QUIET)
    assert bent.info["response_gamma"] == gamma
    level = linear.frames[1].image / 256.0  # the linear grey level, 1/256 steps
    want = 255.0 * (level / 255.0) ** gamma
    # within the 8-bit rounding (and the 16-bit one, through the curve's slope)
    assert np.abs(bent.frames[1].image - want).max() <= 0.5 + 0.01
    # the curve moves the mid-greys (a sign and the wall) apart or together: not
    # an affine map of the linear frame
    x, y = level.ravel(), bent.frames[1].image.ravel().astype(float)
    fit = np.polyval(np.polyfit(x, y, 1), x)
    assert np.abs(y - fit).max() > 3.0  # an affine map: within the rounding, 0.5


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(bit_depth=7), "bit_depth must be an int in"),
        (dict(bit_depth=True), "bit_depth must be an int in"),
        (dict(bit_depth=14.0), "bit_depth must be an int in"),
        (dict(response_gamma=0.0), "response_gamma"),
        (dict(yaw_deg=45.0), "yaw_deg"),
        (dict(shake_deg=-0.1), "shake_deg"),
        (dict(defocus_px=-1.0), "defocus_px"),
    ],
)
def test_pointing_and_output_parameters_are_checked(kw, match):
    with pytest.raises(ValueError, match=match):
        make_tunnel_tour(2, random_state=0, **kw)
