"""Far-infrared tunnel tours: a calibrated pinhole camera driving through a tunnel.

The scene is built in metres and projected through the camera; see
:func:`make_tunnel_tour` for the physical model. Section 1, 3 and 4 of Wang et al. (2013),
*Detection of emergency telephone indicators in a tunnel environment*, describe what the
images look like: emergency-telephone indicators every 200 m, ordinary lamps that look like
indicators at some range, other vehicles and their warm "shadows" whose intensities are
close to the indicators'.
"""

import math
from numbers import Integral

import numpy as np
import pandas as pd
from scipy.special import erf
from sklearn.utils import check_random_state

from tunnelsense._records import MOT_GT_COLUMNS, Tour
from tunnelsense.datasets._odometry import TourKinematics, with_kinematics

__all__ = ["TUNNEL_SCENARIOS", "make_tunnel_tour"]

TUNNEL_SCENARIOS = ("light", "heavy", "curved")

INDICATOR, LAMP, VEHICLE, SHADOW = 1, 2, 3, 4

# Documented physical parameters (the ``**overrides`` of make_tunnel_tour) and their
# defaults; the scenarios change some of them.
_DEFAULTS = {
    "speed_kmh": (60.0, 100.0),  # ego speed range
    "indicator_spacing_m": 200.0,
    "first_indicator_m": None,  # distance ahead of the start; None: random
    "indicator_height_m": 3.0,  # height of the sign's centre above the road
    "lamp_spacing_m": None,  # None: drawn in [10, 15] per tunnel
    "focal_length_px": 800.0,
    "mount_height_m": 1.9,  # camera height above the road (on the roof)
    "noise_sigma": 2.5,  # temporal sensor noise, grey levels
    "curve_radius_m": math.inf,  # signed: > 0 curves right, < 0 left
    "traffic_per_km": 6.0,  # vehicles per km and lane around the ego vehicle
    "truck_fraction": 0.1,
    "lateral_jitter_m": 0.1,  # lane-keeping wander amplitude
    "pitch_jitter_deg": 0.1,  # body pitch amplitude
    "image_shape": (480, 640),
}

_SCENARIOS = {
    "light": {},
    "heavy": {"traffic_per_km": 22.0, "truck_fraction": 0.45},
    "curved": {
        "focal_length_px": 620.0,
        "mount_height_m": 1.35,
        "noise_sigma": 4.0,
        "curve_radius_m": 1500.0,
        "traffic_per_km": 8.0,
        "truck_fraction": 0.25,
        "pitch_jitter_deg": 0.15,
    },
}

# Tunnel cross-section (metres, lateral x relative to the ego lane centre, positive to
# the right; y up from the road): two lanes of 3.5 m, the ego vehicle keeps left.
_LANE_WIDTH = 3.5
_WALL_LEFT = 4.0  # distance from the ego lane centre to the left wall
_WALL_RIGHT = 6.0  # ... to the right wall
_WALL_HEIGHT = 1.8  # vertical walls up to here, then a circular arch
_CROWN_HEIGHT = 7.0
_Z_FAR = 300.0  # nothing is drawn beyond this depth
_Z_NEAR = 1.0
_MIN_BOX_PX = 2.0  # ground truth holds boxes at least this tall
_PSF_SIGMA = 0.6  # optical blur, px
_LINING_SPAN = 10.5  # concrete lining segments
_INDICATOR_SIZE = (0.45, 1.0)  # width, height (m)


def _arch():
    half = (_WALL_LEFT + _WALL_RIGHT) / 2
    rise = _CROWN_HEIGHT - _WALL_HEIGHT
    radius = (half**2 + rise**2) / (2 * rise)
    return (_WALL_RIGHT - _WALL_LEFT) / 2, _CROWN_HEIGHT - radius, radius


_ARCH_X, _ARCH_Y, _ARCH_R = _arch()


def _lining_x(y, side):
    """Lateral position of the tunnel lining at height ``y`` on ``side`` (-1 left)."""
    if y <= _WALL_HEIGHT:
        return -_WALL_LEFT if side < 0 else _WALL_RIGHT
    return _ARCH_X + side * math.sqrt(max(_ARCH_R**2 - (y - _ARCH_Y) ** 2, 0.0))


# --------------------------------------------------------------------------------------
# parameters
# --------------------------------------------------------------------------------------
def _check_range(name, value, lo, hi=math.inf, *, closed_lo=True):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a number; got {value!r}") from None
    ok = (v >= lo if closed_lo else v > lo) and v <= hi
    if not ok or math.isnan(v):
        bound = "[" if closed_lo else "("
        raise ValueError(f"{name} must be in {bound}{lo}, {hi}]; got {value!r}")
    return v


def _resolve_params(scenario, overrides):
    if not isinstance(scenario, str) or scenario not in _SCENARIOS:
        raise ValueError(
            f"scenario must be one of {list(TUNNEL_SCENARIOS)}; got {scenario!r}"
        )
    unknown = sorted(set(overrides) - set(_DEFAULTS))
    if unknown:
        raise TypeError(
            f"make_tunnel_tour got unknown parameter(s) {unknown}; the physical "
            f"parameters are {sorted(_DEFAULTS)}"
        )
    p = dict(_DEFAULTS)
    p.update(_SCENARIOS[scenario])
    p.update(overrides)

    sp = p["speed_kmh"]
    if np.ndim(sp) == 0:
        sp = (sp, sp)
    if len(sp) != 2:
        raise ValueError(
            f"speed_kmh must be a number or a (low, high) pair; got {sp!r}"
        )
    lo = _check_range("speed_kmh", sp[0], 0.0, 300.0, closed_lo=False)
    hi = _check_range("speed_kmh", sp[1], lo, 300.0)
    p["speed_kmh"] = (lo, hi)
    p["indicator_spacing_m"] = _check_range(
        "indicator_spacing_m", p["indicator_spacing_m"], 20.0
    )
    if p["first_indicator_m"] is not None:
        p["first_indicator_m"] = _check_range(
            "first_indicator_m", p["first_indicator_m"], 0.0, _Z_FAR
        )
    p["indicator_height_m"] = _check_range(
        "indicator_height_m", p["indicator_height_m"], 0.6, _CROWN_HEIGHT - 1.5
    )
    if p["lamp_spacing_m"] is not None:
        p["lamp_spacing_m"] = _check_range("lamp_spacing_m", p["lamp_spacing_m"], 2.0)
    p["focal_length_px"] = _check_range(
        "focal_length_px", p["focal_length_px"], 50.0, 10000.0
    )
    p["mount_height_m"] = _check_range("mount_height_m", p["mount_height_m"], 0.3, 4.0)
    p["noise_sigma"] = _check_range("noise_sigma", p["noise_sigma"], 0.0, 50.0)
    radius = float(p["curve_radius_m"])
    if math.isnan(radius) or abs(radius) < 200.0:
        raise ValueError(
            "curve_radius_m must be a signed radius with |radius| >= 200 m "
            f"(inf for a straight tunnel); got {p['curve_radius_m']!r}"
        )
    p["curve_radius_m"] = radius
    p["traffic_per_km"] = _check_range("traffic_per_km", p["traffic_per_km"], 0.0, 60.0)
    p["truck_fraction"] = _check_range("truck_fraction", p["truck_fraction"], 0.0, 1.0)
    p["lateral_jitter_m"] = _check_range(
        "lateral_jitter_m", p["lateral_jitter_m"], 0.0, 1.0
    )
    p["pitch_jitter_deg"] = _check_range(
        "pitch_jitter_deg", p["pitch_jitter_deg"], 0.0, 3.0
    )
    shape = p["image_shape"]
    if (
        len(shape) != 2
        or not all(isinstance(s, Integral) for s in shape)
        or min(shape) < 16
    ):
        raise ValueError(
            f"image_shape must be a pair of ints (height, width) >= 16; got {shape!r}"
        )
    p["image_shape"] = (int(shape[0]), int(shape[1]))
    return p


# --------------------------------------------------------------------------------------
# camera and geometry
# --------------------------------------------------------------------------------------
class _Camera:
    """Pinhole camera; pose: lateral offset ``e``, height ``h``, pitch ``phi`` (up)."""

    def __init__(self, f, shape, kappa):
        self.f = float(f)
        self.height, self.width = shape
        self.cx = self.width / 2.0
        self.cy = self.height / 2.0
        self.kappa = float(kappa)

    def to_camera(self, ds, d, y):
        """Road coordinates (arc length ahead, lateral, height) -> straight frame."""
        ds = np.asarray(ds, dtype=np.float64)
        d = np.asarray(d, dtype=np.float64)
        k = self.kappa
        if k == 0.0:
            return d + 0.0 * ds, ds + 0.0 * d, y
        theta = k * ds
        x = d * np.cos(theta) + ds * np.sin(theta / 2) * np.sinc(theta / (2 * np.pi))
        z = ds * np.sinc(theta / np.pi) - d * np.sin(theta)
        return x, z, y

    def project(self, x, z, y, pose):
        """Straight-frame points (x lateral, z ahead, y height) -> pixels, depth."""
        e, h, phi = pose
        xr = np.asarray(x) - e
        yr = np.asarray(y) - h
        c, s = math.cos(phi), math.sin(phi)
        zc = z * c + yr * s
        yc = yr * c - z * s
        u = self.cx + self.f * xr / zc
        v = self.cy - self.f * yc / zc
        return u, v, zc


class _Background:
    """Per-pixel ray casting of the tunnel surfaces at half resolution."""

    def __init__(self, cam, s_lo, s_hi, rng):
        self.cam = cam
        hh, ww = cam.height // 2, cam.width // 2
        self.shape = (hh, ww)
        # half-resolution pixel centres in full-resolution coordinates
        u = (np.arange(ww, dtype=np.float32) * 2 + 1.0 - cam.cx) / cam.f
        v = (cam.cy - (np.arange(hh, dtype=np.float32) * 2 + 1.0)) / cam.f
        self.xc, self.yc = np.meshgrid(u, v)
        # textures along the tunnel (1-D tables, 5 cm steps)
        self.ds = 0.05
        self.s0 = s_lo - 10.0
        n = int((s_hi - self.s0) / self.ds) + 10
        s = self.s0 + self.ds * np.arange(n)
        self.tables = {
            "wall": self._stains(rng, n, 3.5) + self._joints(s, rng, -7.0),
            "arch": self._stains(rng, n, 3.0) + self._joints(s, rng, -5.0),
            "road": self._stains(rng, n, 2.5) + self._dashes(s),
        }
        self.lane_line = self._dashes(s) < -1.0
        self.base = {"wall": 112.0, "arch": 97.0, "road": 104.0}
        self.far_value = 101.0

    @staticmethod
    def _stains(rng, n, amp):
        """Smooth 1-D noise: sum of random sinusoids of 2-60 m period."""
        idx = np.arange(n) * 0.05
        out = np.zeros(n)
        for _ in range(6):
            period = rng.uniform(2.0, 60.0)
            out += np.sin(2 * np.pi * idx / period + rng.uniform(0, 2 * np.pi))
        return (amp / 2.5 * out).astype(np.float32)

    @staticmethod
    def _joints(s, rng, amp):
        phase = rng.uniform(0, _LINING_SPAN)
        d = np.abs(((s - phase) % _LINING_SPAN) - _LINING_SPAN / 2) - (
            _LINING_SPAN / 2 - 0.12
        )
        return (amp * np.clip(d / 0.12, 0, 1)).astype(np.float32)

    @staticmethod
    def _dashes(s):
        # lane-line dashes: 8 m painted, 12 m gap (paint is slightly cooler in FIR)
        return np.where((s % 20.0) < 8.0, -7.0, 0.0).astype(np.float32)

    def render(self, s_cam, pose):
        cam = self.cam
        e, h, phi = pose
        k = cam.kappa
        c, sn = math.cos(phi), math.sin(phi)
        dz = c - self.yc * sn
        dx = self.xc / dz
        dy = (self.yc * c + sn) / dz
        inf = np.float32(np.inf)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            z_road = np.where(dy < 0, h / -dy, inf)
            if k == 0.0:
                z_l = np.where(dx < 0, (_WALL_LEFT + e) / -dx, inf)
                z_r = np.where(dx > 0, (_WALL_RIGHT - e) / dx, inf)
            else:
                z_l = self._curved_wall(dx, -_WALL_LEFT - e, k)
                z_r = self._curved_wall(dx, _WALL_RIGHT - e, k)
            z_wall = np.minimum(z_l, z_r)
            y_wall = h + dy * z_wall
            # circular arch, centre shifted by the curve at the hit depth
            a = dx * dx + dy * dy
            cy = _ARCH_Y - h
            z_arch = None
            shift = 0.0
            for _ in range(1 if k == 0.0 else 3):
                cx = _ARCH_X - e + shift
                b = dx * cx + dy * cy
                cc = cx * cx + cy * cy - _ARCH_R**2
                disc = b * b - a * cc
                z_arch = (b + np.sqrt(np.maximum(disc, 0))) / a
                z_arch = np.where((disc >= 0) & (z_arch > 0), z_arch, _Z_FAR)
                shift = 0.5 * k * np.minimum(z_arch, _Z_FAR) ** 2
        road = z_road <= z_wall
        arch = ~road & (y_wall > _WALL_HEIGHT)
        z = np.where(road, z_road, np.where(arch, z_arch, z_wall))
        z = np.minimum(z, _Z_FAR).astype(np.float32)
        y = h + dy * z  # height of the hit point
        x = e + dx * z - 0.5 * k * z * z  # lateral, relative to the ego lane centre
        idx = np.clip(((s_cam + z - self.s0) / self.ds).astype(np.int32), 0, None)
        idx = np.minimum(idx, len(self.lane_line) - 1)
        fade = np.exp(-z / 70.0)  # texture averages out at long range

        t = self.tables
        # road: warm wheel paths, lane lines
        wheel = np.zeros_like(x)
        for lane in (0.0, _LANE_WIDTH):
            for side in (-0.8, 0.8):
                wheel += np.exp(-(((x - lane - side) / 0.35) ** 2))
        road_i = (
            self.base["road"]
            + 7.0 * wheel
            + t["road"][idx] * 0.4
            + np.where(np.abs(x - _LANE_WIDTH / 2) < 0.08, 1.0, 0.0)
            * np.where(self.lane_line[idx], -7.0, 0.0)
            + np.where(
                (np.abs(x + _LANE_WIDTH / 2) < 0.1)
                | (np.abs(x - 1.5 * _LANE_WIDTH) < 0.1),
                -6.0,
                0.0,
            )
        )
        # lower wall panels (warmer, up to 3 m), concrete arch above
        wall_i = self.base["wall"] + t["wall"][idx] + np.where(y < 0.3, 4.0, 0.0)
        arch_i = (
            self.base["arch"]
            + t["arch"][idx]
            + 6.0 * np.clip((3.0 - y) / 1.0, 0, 1)
            + 3.0 * np.clip((y - 5.5) / 1.5, 0, 1)
        )
        surf = np.where(road, road_i, np.where(arch, arch_i, wall_i))
        out = self.far_value + (surf - self.far_value) * (0.35 + 0.65 * fade)
        return out.astype(np.float32)

    @staticmethod
    def _curved_wall(dx, w, k):
        """Depth where the ray ``x = dx z`` meets the wall ``x = w + k z^2 / 2``."""
        disc = dx * dx - 2.0 * k * w
        root = np.sqrt(np.maximum(disc, 0))
        # the two roots; keep the smallest positive
        den1 = dx + np.where(dx >= 0, root, -root)
        z1 = 2.0 * w / den1
        z2 = np.where(np.abs(k) > 0, den1 / k, np.inf)
        z1 = np.where((z1 > 0) & (disc >= 0), z1, np.inf)
        z2 = np.where((z2 > 0) & (disc >= 0), z2, np.inf)
        return np.minimum(z1, z2)


# --------------------------------------------------------------------------------------
# drawing primitives (work only in the bounding region)
# --------------------------------------------------------------------------------------
_SQ2 = math.sqrt(2.0)
_SIG = math.sqrt(_PSF_SIGMA**2 + 1 / 12)  # PSF and pixel integration


def _cover_1d(lo, hi, n, sigma=_SIG):
    """Fraction of each pixel of [0, n) covered by [lo, hi] blurred by the PSF."""
    pad = 3.0 * sigma + 1.0
    i0 = max(int(math.floor(lo - pad)), 0)
    i1 = min(int(math.ceil(hi + pad)), n)
    if i1 <= i0:
        return i0, None
    centres = np.arange(i0, i1, dtype=np.float64) + 0.5
    k = 1.0 / (_SQ2 * sigma)
    return i0, 0.5 * (erf((centres - lo) * k) - erf((centres - hi) * k))


def _paint(img, x0, x1, y0, y1, value, alpha=1.0, sigma=_SIG):
    """Alpha-blend a blurred rectangle of intensity ``value`` into ``img``."""
    H, W = img.shape
    j0, cx = _cover_1d(x0, x1, W, sigma)
    i0, cy = _cover_1d(y0, y1, H, sigma)
    if cx is None or cy is None:
        return
    a = (alpha * np.outer(cy, cx)).astype(np.float32)
    win = img[i0 : i0 + a.shape[0], j0 : j0 + a.shape[1]]
    win += a * (np.float32(value) - win)


def _paint_poly(img, u, v, value):
    """Fill the convex hull of the points ``(u, v)`` (anti-aliased) with ``value``."""
    import cv2  # noqa: PLC0415

    H, W = img.shape
    j0, j1 = max(int(math.floor(u.min())) - 1, 0), min(int(math.ceil(u.max())) + 2, W)
    i0, i1 = max(int(math.floor(v.min())) - 1, 0), min(int(math.ceil(v.max())) + 2, H)
    if j1 <= j0 or i1 <= i0:
        return
    # 1/8 px precision; pixel centres at +0.5
    pts = np.round((np.stack([u - j0 - 0.5, v - i0 - 0.5], axis=1)) * 8).astype(
        np.int32
    )
    hull = cv2.convexHull(pts)
    mask = np.zeros((i1 - i0, j1 - j0), np.uint8)
    cv2.fillConvexPoly(mask, hull, 255, lineType=cv2.LINE_AA, shift=3)
    a = mask.astype(np.float32) * np.float32(1 / 255)
    win = img[i0:i1, j0:j1]
    win += a * (np.float32(value) - win)


def _glow(img, xc, yc, sigma, amp):
    """Add an isotropic blooming halo (Gaussian) around a hot source."""
    if amp < 0.5:
        return
    H, W = img.shape
    r = 3.0 * sigma
    j0, j1 = max(int(xc - r), 0), min(int(xc + r) + 2, W)
    i0, i1 = max(int(yc - r), 0), min(int(yc + r) + 2, H)
    if j1 <= j0 or i1 <= i0:
        return
    gx = np.exp(-0.5 * ((np.arange(j0, j1) + 0.5 - xc) / sigma) ** 2)
    gy = np.exp(-0.5 * ((np.arange(i0, i1) + 0.5 - yc) / sigma) ** 2)
    img[i0:i1, j0:j1] += (amp * np.outer(gy, gx)).astype(np.float32)


# --------------------------------------------------------------------------------------
# scene objects
# --------------------------------------------------------------------------------------
def _smooth_noise(rng, t, amplitude, periods):
    """A smooth random signal: sum of sinusoids with the given periods (s)."""
    out = np.zeros_like(t)
    for p in periods:
        out += np.sin(
            2 * np.pi * t / (p * rng.uniform(0.8, 1.25)) + rng.uniform(0, 6.3)
        )
    return amplitude * out / math.sqrt(len(periods) / 2)


def _ego_motion(rng, n, fps, p):
    lo, hi = p["speed_kmh"]
    t = np.arange(n) / fps
    base = rng.uniform(lo, hi)
    speed = base + _smooth_noise(rng, t, min(4.0, (hi - lo) / 2), (20.0, 45.0))
    speed = np.clip(speed, lo, hi) / 3.6  # m/s
    s = np.concatenate([[0.0], np.cumsum(speed[:-1] / fps)])
    e = _smooth_noise(rng, t, p["lateral_jitter_m"], (6.0, 11.0))
    pitch = np.deg2rad(_smooth_noise(rng, t, p["pitch_jitter_deg"], (0.7, 1.3, 2.1)))
    bounce = _smooth_noise(rng, t, 0.01, (0.5, 0.9))
    h = p["mount_height_m"] + bounce
    return t, speed, s, e, h, pitch


def _make_vehicles(rng, t, s_ego, speed, p):
    """Traffic around the ego vehicle: per vehicle, gap (m ahead) and lateral per frame.

    Vehicles in the ego lane follow at a varying gap (they look almost still, drift,
    approach or recede); vehicles in the right lane move at their own speed, so they
    overtake or are overtaken; some change lanes.
    """
    n = len(t)
    duration = t[-1] + 1.0 / 30.0
    density = p["traffic_per_km"] / 1000.0
    vehicles = []
    # ego lane: followers ahead within 150 m
    n_follow = rng.poisson(density * 150.0)
    for _ in range(n_follow):
        gap0 = rng.uniform(15.0, 150.0)
        drift = rng.normal(0.0, 0.8)  # m/s relative speed
        wobble = _smooth_noise(rng, t, rng.uniform(0.5, 4.0), (15.0, 30.0))
        gap = np.maximum(gap0 + drift * t + wobble, 12.0)
        vehicles.append({"gap": gap, "x": np.zeros(n)})
    # right lane: own speeds; spawn enough to cover the tour
    v_mean = speed.mean()
    span = 300.0 + 12.0 * duration  # relative-motion reach over the tour
    n_right = rng.poisson(density * span)
    for _ in range(n_right):
        rel = rng.normal(0.0, 4.0)  # m/s relative to the ego vehicle's mean speed
        v = v_mean + rel
        gap0 = rng.uniform(-span / 2, 150.0 + span / 2) if rel != 0 else 50.0
        gap = gap0 + v * t - (s_ego - s_ego[0])
        vehicles.append({"gap": gap, "x": np.full(n, _LANE_WIDTH)})
    # lane changes
    for veh in vehicles:
        if rng.random() < 0.25:
            tc = rng.uniform(0, duration)
            dur = rng.uniform(3.0, 6.0)
            frac = np.clip((t - tc) / dur, 0, 1)
            frac = frac * frac * (3 - 2 * frac)
            start = veh["x"][0]
            target = _LANE_WIDTH - start
            # cutting into the ego lane: only with room ahead
            if target == 0.0 and np.interp(tc, t, veh["gap"]) < 25.0:
                continue
            veh["x"] = start + (target - start) * frac
            if target == 0.0:
                veh["gap"] = np.where(
                    frac > 0, np.maximum(veh["gap"], 12.0), veh["gap"]
                )
    for veh in vehicles:
        truck = rng.random() < p["truck_fraction"]
        veh["truck"] = truck
        veh["width"] = rng.uniform(2.3, 2.5) if truck else rng.uniform(1.65, 1.85)
        veh["height"] = rng.uniform(3.2, 3.8) if truck else rng.uniform(1.35, 1.55)
        veh["length"] = rng.uniform(8.0, 12.0) if truck else rng.uniform(4.2, 4.8)
        j = lambda: rng.uniform(-6, 6)  # noqa: E731
        veh["I"] = {
            "body": (rng.uniform(112, 128) if truck else rng.uniform(128, 148)),
            "window": 104 + j(),
            "bumper": 158 + j(),
            "tyre": 174 + j(),
            "under": 181 + j(),
            "exhaust": rng.uniform(225, 270),
            "side": rng.uniform(115, 132),
            "shadow": rng.uniform(166, 182),
        }
        veh["exhaust_side"] = rng.choice([-1.0, 1.0])
    return vehicles


def _indicator_positions(rng, s_end, p, exit_depth):
    spacing = p["indicator_spacing_m"]
    first = p["first_indicator_m"]
    if first is None:
        # in the first 200 m ahead, past the depth where a sign leaves the frame
        first = rng.uniform(exit_depth + 5.0, exit_depth + 5.0 + spacing)
    n = int(math.floor((s_end + _Z_FAR - first) / spacing)) + 1
    return first + spacing * np.arange(max(n, 0))


# --------------------------------------------------------------------------------------
# rendering of objects (each returns the 2-D box and draws into img)
# --------------------------------------------------------------------------------------
def _box_of(cam, pose, xs, zs, ys):
    u, v, zc = cam.project(xs, zs, ys, pose)
    if np.any(zc < _Z_NEAR):
        return None
    return (
        float(u.min()),
        float(v.min()),
        float(u.max()),
        float(v.max()),
        float(zc.min()),
    )


def _draw_indicator(img, cam, pose, ds, p, look):
    w, hgt = _INDICATOR_SIZE
    yc = p["indicator_height_m"]
    x_out = _lining_x(yc, -1) + 0.05
    d = np.array([x_out, x_out + w])
    y = np.array([yc - hgt / 2, yc + hgt / 2])
    dd, yy = np.meshgrid(d, y)
    x3, z3, y3 = cam.to_camera(np.full(4, ds), dd.ravel(), yy.ravel())
    box = _box_of(cam, pose, x3, z3, y3)
    if box is None:
        return None
    u0, v0, u1, v1, z = box
    bw, bh = u1 - u0, v1 - v0
    frame, face, text, grad = look
    # housing, lit face (warmer at the top, where the lamp is), pictograph and text
    _paint(img, u0, u1, v0, v1, frame)
    _paint(
        img, u0 + 0.08 * bw, u1 - 0.08 * bw, v0 + 0.05 * bh, v0 + 0.5 * bh, face + grad
    )
    _paint(
        img, u0 + 0.08 * bw, u1 - 0.08 * bw, v0 + 0.5 * bh, v1 - 0.05 * bh, face - grad
    )
    if bh > 8:
        _paint(img, u0 + 0.25 * bw, u1 - 0.25 * bw, v0 + 0.1 * bh, v0 + 0.3 * bh, text)
        for k in range(4):  # four characters written vertically
            top = v0 + (0.38 + 0.14 * k) * bh
            _paint(img, u0 + 0.3 * bw, u1 - 0.3 * bw, top, top + 0.09 * bh, text)
    return box


_LAMP_GLASS_Y = 4.9  # height of the glass (bottom face of the luminaire)
_LAMP_LENGTH = 1.2  # along the tunnel
_LAMP_DEPTH = 0.25  # housing height above the glass


def _lamp_boxes(cam, pose, ds, side):
    """Projected boxes of the glass and housing of lamps at ``ds`` (n,) on ``side``.

    A luminaire on the upper wall: a warm housing, a hot glass on its underside. Seen
    from afar the glass is foreshortened to a sub-pixel sliver. Returns two (n, 5)
    arrays ``(u0, v0, u1, v1, depth)``; depth < _Z_NEAR marks lamps not to draw.
    """
    x_in = _lining_x(_LAMP_GLASS_Y, side)
    d = (
        np.array([x_in + 0.1, x_in + 0.6])
        if side < 0
        else np.array([x_in - 0.6, x_in - 0.1])
    )
    ds = np.asarray(ds, dtype=np.float64)[:, None]
    dd = np.repeat(d, 2)[None, :]
    ss = ds + np.array([0.0, _LAMP_LENGTH, 0.0, _LAMP_LENGTH])[None, :]
    x3, z3, y3 = cam.to_camera(ss, dd + 0 * ss, _LAMP_GLASS_Y)
    u, v, zc = cam.project(x3, z3, y3, pose)
    glass = np.stack([u.min(1), v.min(1), u.max(1), v.max(1), zc.min(1)], axis=1)
    yy = np.array([_LAMP_GLASS_Y, _LAMP_GLASS_Y + _LAMP_DEPTH] * 2)[None, :]
    x3, z3, y3 = cam.to_camera(ds + 0 * dd, dd + 0 * ds, yy)
    u, v, zc = cam.project(x3, z3, y3, pose)
    housing = np.stack([u.min(1), v.min(1), u.max(1), v.max(1), zc.min(1)], axis=1)
    return glass, housing


def _draw_lamp(img, glass, housing, look):
    housing_i, hot, bloom = look
    gu0, gv0, gu1, gv1, _ = glass
    if housing[3] - housing[1] > 1.0:
        _paint(img, housing[0], housing[2], housing[1], housing[3], housing_i)
    _paint(img, gu0, gu1, gv0, gv1, hot)
    area = (gu1 - gu0) * (gv1 - gv0)
    _glow(
        img,
        (gu0 + gu1) / 2,
        (gv0 + gv1) / 2,
        1.5 + 0.35 * max(gu1 - gu0, gv1 - gv0),
        bloom * min(1.0, area / 40.0),
    )
    return (
        min(housing[0], gu0),
        min(housing[1], gv0),
        max(housing[2], gu1),
        max(housing[3], gv1),
        min(housing[4], glass[4]),
    )


def _draw_shadow(img, cam, pose, veh, f, ds):
    """The warm road patch under and behind a vehicle (class 4)."""
    half = veh["width"] / 2 - 0.1
    x = veh["x"][f]
    d = np.array([x - half, x + half, x - half, x + half])
    ss = np.array([ds + 1.0, ds + 1.0, ds - 2.5, ds - 2.5])
    x3, z3, y3 = cam.to_camera(ss, d, np.zeros(4))
    box = _box_of(cam, pose, x3, z3, y3)
    if box is None:
        return None
    u0, v0, u1, v1, _ = box
    hgt = v1 - v0
    # warmest next to the vehicle, fading toward the camera
    shadow = veh["I"]["shadow"]
    soft = math.hypot(_SIG, 0.08 * (u1 - u0))  # heat spreads: soft edges
    _paint(img, u0, u1, v0, v0 + 0.5 * hgt, shadow, 0.9, soft)
    _paint(img, u0, u1, v0 + 0.5 * hgt, v1, shadow - 12, 0.5, soft)
    return box


def _draw_vehicle(img, cam, pose, veh, f, ds):
    x = veh["x"][f]
    w, hgt, length = veh["width"], veh["height"], veh["length"]
    d = np.array([x - w / 2, x + w / 2] * 4)
    yy = np.array([0, 0, hgt, hgt] * 2)
    ss = np.array([ds] * 4 + [ds + length] * 4)
    x3, z3, y3 = cam.to_camera(ss, d, yy)
    box = _box_of(cam, pose, x3, z3, y3)
    if box is None:
        return None
    u, v, _ = cam.project(x3, z3, y3, pose)
    I = veh["I"]
    # side and roof seen obliquely: fill the silhouette, then the rear face on top
    _paint_poly(img, u, v, I["side"])
    ru0, ru1 = u[:4].min(), u[:4].max()
    rv0, rv1 = v[:4].min(), v[:4].max()
    rw, rh = ru1 - ru0, rv1 - rv0

    def rect(fx0, fx1, fy0, fy1, value):  # fractions of the rear face (y from top)
        _paint(
            img, ru0 + fx0 * rw, ru0 + fx1 * rw, rv0 + fy0 * rh, rv0 + fy1 * rh, value
        )

    if veh["truck"]:
        rect(0.0, 1.0, 0.0, 0.7, I["body"])  # cargo box
        rect(0.05, 0.95, 0.7, 0.83, I["bumper"])  # chassis / bumper
        rect(0.1, 0.9, 0.83, 0.97, I["under"])  # engine and exhaust heat underneath
        for a in (0.05, 0.7):
            rect(a, a + 0.25, 0.75, 1.0, I["tyre"])  # twin tyres
    else:
        rect(0.0, 1.0, 0.0, 0.85, I["body"])
        rect(0.12, 0.88, 0.05, 0.35, I["window"])  # glass reflects the cool ceiling
        rect(0.0, 1.0, 0.6, 0.8, I["bumper"])
        rect(0.15, 0.85, 0.8, 0.93, I["under"])
        for a in (0.03, 0.79):
            rect(a, a + 0.18, 0.78, 1.0, I["tyre"])
        ex = 0.8 if veh["exhaust_side"] > 0 else 0.12
        rect(ex, ex + 0.08, 0.78, 0.86, I["exhaust"])
    return box


# --------------------------------------------------------------------------------------
# the generator
# --------------------------------------------------------------------------------------
def make_tunnel_tour(
    n_frames=1500,
    *,
    scenario="light",
    random_state=None,
    name=None,
    progress=None,
    **overrides,
):
    """Simulate a far-infrared camera driving through a motorway tunnel.

    A calibrated pinhole camera (640x480, 8-bit, 30 fps by default) rides on the roof of
    a vehicle in the left lane of a two-lane tunnel. The scene is built in metres and
    projected through the camera:

    * **Emergency-telephone indicators** every ``indicator_spacing_m`` (200 m) on the
      left wall: lit signs 0.45 m x 1.0 m facing the traffic, centred
      ``indicator_height_m`` above the road, FIR intensity about 175 with a slight
      internal structure (housing, lit face, pictograph, four characters), so nearly all
      of their pixels lie in [160, 190]. An indicator grows to about 80 px before it
      leaves the frame, moving along a straight image line away from the vanishing point
      (in the straight tunnel). The first one stands ``first_indicator_m`` ahead of the
      start, so short tours contain one too.
    * **Lamps** every 10-15 m on both upper walls: a warm housing and a hot glass on the
      underside, saturated near the camera. Seen from afar the glass is foreshortened to
      a sub-pixel sliver, so the lamp fades through the [160, 190] band; near, the
      blooming halo's ring passes through the band.
    * **Vehicles** (cars and trucks) with warm rear bumpers and tyres, a hot underbody and
      exhaust, cool rear windows, and the warm road patch under and behind them
      (**shadows**); followers in the ego lane stay almost still in the image, drift,
      approach or recede; right-lane traffic overtakes or is overtaken; some change
      lanes.
    * Walls, arch and road at 80-125 grey levels with gradients, lining joints, stains,
      warm wheel paths and cool lane paint; optical blur; sensor noise (temporal and
      fixed-pattern); ego speed in ``speed_kmh`` with lateral wander and body pitch.

    Parameters
    ----------
    n_frames : int, default=1500
        Number of frames (>= 1).
    scenario : {"light", "heavy", "curved"}, default="light"
        ``"light"``: light traffic. ``"heavy"``: heavy traffic with many trucks.
        ``"curved"``: another camera (focal length 620 px, mounted 1.35 m high, noise
        sigma 4) in a tunnel curving with a 1500 m radius.
    random_state : int, RandomState instance or None, default=None
        Seed; the same seed gives byte-identical images and ground truth.
    name : str, default=None
        Tour name; default ``"tunnel-<scenario>-<seed>"``.
    progress : callable or None, default=None
        Called as ``progress(n_done, n_frames)`` after each rendered frame (the
        command line shows a progress bar with it).
    **overrides
        Physical parameters replacing the scenario's: ``speed_kmh`` (low, high) or one
        number; ``indicator_spacing_m`` (200); ``first_indicator_m`` (None = random,
        metres ahead of the start); ``indicator_height_m`` (3.0); ``lamp_spacing_m``
        (None = random in [10, 15]); ``focal_length_px`` (800); ``mount_height_m``
        (1.9); ``noise_sigma`` (2.5); ``curve_radius_m`` (inf; signed, > 0 curves
        right); ``traffic_per_km`` (vehicles per km and lane, 6); ``truck_fraction``
        (0.1); ``lateral_jitter_m`` (0.1); ``pitch_jitter_deg`` (0.1); ``image_shape``
        ((480, 640)).

    Returns
    -------
    tour : Tour
        uint8 frames ``(n_frames, height, width)``; ground truth of every object at least
        2 px tall and within 300 m, per frame: box (unclipped, may extend beyond the
        image), class (1 indicator, 2 lamp, 3 vehicle, 4 shadow), persistent id,
        ``conf=1`` and ``visibility`` (fraction of the box inside the image and not
        hidden by a nearer vehicle). ``info`` holds the scenario, seed, camera
        parameters, ``distance_m`` driven, ``n_indicators`` (distinct indicator ids in
        the ground truth) and ``n_indicators_passed`` (indicators whose sign left the
        image during the tour: one per ``indicator_spacing_m`` driven, so it differs
        from ``distance_m / indicator_spacing_m`` by less than one). The ground truth
        also holds up to ``300 / indicator_spacing_m`` indicators still ahead at the
        end of the tour.

    Examples
    --------
    >>> from tunnelsense.datasets import make_tunnel_tour
    >>> tour = make_tunnel_tour(30, random_state=0)
    >>> len(tour), tour.image_shape, tour.frames[0].image.dtype
    (30, (480, 640), dtype('uint8'))
    >>> sorted(tour.gt["class"].unique().tolist())[:2]
    [1, 2]
    """
    if isinstance(n_frames, bool) or not isinstance(n_frames, Integral) or n_frames < 1:
        raise ValueError(f"n_frames must be an int >= 1; got {n_frames!r}")
    n_frames = int(n_frames)
    p = _resolve_params(scenario, overrides)
    if isinstance(random_state, Integral) and not isinstance(random_state, bool):
        seed = int(random_state)
        if seed < 0:
            raise ValueError(f"random_state must be >= 0; got {random_state!r}")
    else:
        seed = int(check_random_state(random_state).randint(0, 2**31 - 1))
    rng = np.random.default_rng(seed)
    if name is None:
        name = f"tunnel-{scenario}-{seed}"
    fps = 30.0
    H, W = p["image_shape"]
    kappa = 0.0 if math.isinf(p["curve_radius_m"]) else 1.0 / p["curve_radius_m"]
    cam = _Camera(p["focal_length_px"], (H, W), kappa)

    t, speed, s_ego, lat, hgt, pitch = _ego_motion(rng, n_frames, fps, p)
    distance = float(s_ego[-1] + speed[-1] / fps)
    # an indicator's outer edge leaves the image at this depth
    x_edge = abs(_lining_x(p["indicator_height_m"], -1)) - 0.05
    exit_depth = cam.f * x_edge / cam.cx
    indicators = _indicator_positions(rng, s_ego[-1], p, exit_depth)
    lamp_spacing = p["lamp_spacing_m"] or rng.uniform(10.0, 15.0)
    lamp_phase = rng.uniform(0, lamp_spacing)
    n_lamps = int((s_ego[-1] + _Z_FAR + 10) / lamp_spacing) + 2
    lamp_s = lamp_phase + lamp_spacing * np.arange(-1, n_lamps)
    lamp_look = [
        (rng.uniform(130, 150), rng.uniform(300, 380), rng.uniform(90, 140))
        for _ in range(len(lamp_s))
    ]
    ind_look = [
        (
            rng.uniform(169, 174),  # housing
            rng.uniform(174, 180),  # lit face
            rng.uniform(165, 169),  # characters
            rng.uniform(1.0, 3.0),  # top-bottom gradient of the face
        )
        for _ in range(len(indicators))
    ]
    vehicles = _make_vehicles(rng, t, s_ego, speed, p)
    bg = _Background(cam, -20.0, s_ego[-1] + _Z_FAR + 20.0, rng)

    # ids: indicators, lamps (two rows), vehicles, shadows
    ind_ids = 1 + np.arange(len(indicators))
    lamp_ids = 1 + len(indicators) + np.arange(2 * len(lamp_s)).reshape(2, -1)
    veh_ids = 1 + len(indicators) + lamp_ids.size + np.arange(len(vehicles))
    shadow_ids = veh_ids + len(vehicles)

    # sensor: temporal noise bank (random windows), fixed-pattern noise, vignetting
    pad = 24
    bank = rng.standard_normal((2, H + pad, W + pad), dtype=np.float32)
    bank *= np.float32(p["noise_sigma"])
    fpn = (rng.normal(0, 0.8, W)[None, :] + rng.normal(0, 0.4, (H, W))).astype(
        np.float32
    )
    yy, xx = np.mgrid[0:H, 0:W]
    r2 = ((xx - W / 2) / (W / 2)) ** 2 + ((yy - H / 2) / (H / 2)) ** 2
    fpn += (3.0 - 3.0 * r2).astype(np.float32)  # slight vignetting
    noise_pick = rng.integers(0, [2, pad + 1, pad + 1], size=(n_frames, 3))

    images = np.empty((n_frames, H, W), dtype=np.uint8)
    rows = []
    import cv2  # noqa: PLC0415

    for f in range(n_frames):
        pose = (float(lat[f]), float(hgt[f]), float(pitch[f]))
        sc = float(s_ego[f])
        half = bg.render(sc, pose)
        img = cv2.resize(half, (W, H), interpolation=cv2.INTER_LINEAR)
        drawn = []  # (depth, class, id, box, occluder?)
        todo = []
        lo, hi = np.searchsorted(indicators, [sc + _Z_NEAR, sc + _Z_FAR])
        for k in range(lo, hi):
            todo.append((indicators[k] - sc, INDICATOR, k))
        for row, side in enumerate((-1, 1)):
            offset = 0.5 * lamp_spacing * row  # the two rows are staggered
            lo, hi = np.searchsorted(lamp_s + offset, [sc + _Z_NEAR, sc + _Z_FAR])
            if hi > lo:
                glass, housing = _lamp_boxes(
                    cam, pose, lamp_s[lo:hi] + offset - sc, side
                )
                for k in range(lo, hi):
                    gl, ho = glass[k - lo], housing[k - lo]
                    if min(gl[4], ho[4]) > _Z_NEAR:
                        todo.append((lamp_s[k] + offset - sc, LAMP, (row, k, gl, ho)))
        for k, veh in enumerate(vehicles):
            ds = veh["gap"][f]
            if 2.0 < ds < _Z_FAR:
                todo.append((ds, VEHICLE, k))
        todo.sort(key=lambda item: -item[0])  # painter's order: far to near
        for ds, cls, key in todo:
            if cls == INDICATOR:
                box = _draw_indicator(img, cam, pose, ds, p, ind_look[key])
                oid = ind_ids[key]
            elif cls == LAMP:
                row, k, gl, ho = key
                box = _draw_lamp(img, gl, ho, lamp_look[k])
                oid = lamp_ids[row, k]
            else:
                veh = vehicles[key]
                sbox = _draw_shadow(img, cam, pose, veh, f, ds)
                if sbox is not None:
                    drawn.append((sbox[4], SHADOW, shadow_ids[key], sbox, False))
                box = _draw_vehicle(img, cam, pose, veh, f, ds)
                oid = veh_ids[key]
            if box is not None:
                drawn.append((box[4], cls, oid, box, cls == VEHICLE))
        j, di, dj = noise_pick[f]
        img += bank[j, di : di + H, dj : dj + W]
        img += fpn
        np.clip(img, 0, 255, out=img)
        np.rint(img, out=img)
        images[f] = img
        rows.extend(_gt_rows(f + 1, drawn, W, H))
        if progress is not None:
            progress(f + 1, n_frames)

    gt = pd.DataFrame(rows, columns=list(MOT_GT_COLUMNS))
    gt = gt.astype(
        {
            "frame": "int64",
            "id": "int64",
            "class": "int64",
            **{c: "float64" for c in ("bb_left", "bb_top", "bb_width", "bb_height")},
            "conf": "float64",
            "visibility": "float64",
        }
    )
    n_ind = int(gt.loc[gt["class"] == INDICATOR, "id"].nunique())
    # indicators driven past: their sign left the image within the tour
    passed = (indicators - exit_depth >= 0.0) & (indicators - exit_depth <= s_ego[-1])
    info = {
        "scenario": scenario,
        "seed": seed,
        "generator": "tunnelsense.datasets.make_tunnel_tour",
        "focal_length_px": float(cam.f),
        "principal_point_px": f"{cam.cx:g},{cam.cy:g}",
        "mount_height_m": float(p["mount_height_m"]),
        "noise_sigma": float(p["noise_sigma"]),
        "curve_radius_m": float(p["curve_radius_m"]),
        "speed_kmh_min": float(speed.min() * 3.6),
        "speed_kmh_max": float(speed.max() * 3.6),
        "distance_m": round(distance, 3),
        "indicator_spacing_m": float(p["indicator_spacing_m"]),
        "first_indicator_m": float(indicators[0]) if len(indicators) else -1.0,
        "n_indicators": n_ind,
        "n_indicators_passed": int(passed.sum()),
        "lamp_spacing_m": round(float(lamp_spacing), 4),
        "traffic_per_km": float(p["traffic_per_km"]),
        "truck_fraction": float(p["truck_fraction"]),
    }
    tour = Tour.from_array(name, images, gt, frame_rate=fps, info=info)
    # where the camera was (positions, odometry, indicator map): no random draws here
    kin = TourKinematics(t, s_ego, speed, kappa, indicators, ind_ids, seed)
    return with_kinematics(tour, kin)


def _gt_rows(frame, drawn, W, H):
    """Ground-truth rows of one frame: boxes, visibility after occlusion by vehicles."""
    occluders = [(z, b) for z, cls, _, b, occ in drawn if occ]
    rows = []
    for z, cls, oid, b, _ in drawn:
        u0, v0, u1, v1 = b[:4]
        bw, bh = u1 - u0, v1 - v0
        if bh < _MIN_BOX_PX or bw <= 0:
            continue
        area = bw * bh
        inside = max(0.0, min(u1, W) - max(u0, 0)) * max(0.0, min(v1, H) - max(v0, 0))
        vis = inside / area
        hidden = 0.0
        for zo, o in occluders:
            if zo < z - 1e-6:
                ow = max(0.0, min(u1, o[2]) - max(u0, o[0]))
                oh = max(0.0, min(v1, o[3]) - max(v0, o[1]))
                hidden = max(hidden, ow * oh / area)
        vis *= 1.0 - hidden
        if vis <= 0.0:
            continue
        rows.append((frame, int(oid), u0, v0, bw, bh, 1.0, cls, round(vis, 4)))
    return rows
