"""The simulated far-infrared camera: pinhole projection along a (curving) tunnel,
and the rendered tunnel background (lining, joints, stains, road markings)."""

from __future__ import annotations

import math

import numpy as np

from tunnelsense.datasets._tunnel_scene import (
    _ARCH_R,
    _ARCH_X,
    _ARCH_Y,
    _LANE_WIDTH,
    _LINING_SPAN,
    _WALL_HEIGHT,
    _WALL_LEFT,
    _WALL_RIGHT,
    _Z_FAR,
)


# --------------------------------------------------------------------------------------
# camera and geometry
# --------------------------------------------------------------------------------------
class _Camera:
    """Pinhole camera; pose: lateral offset ``e``, height ``h``, pitch ``phi`` (up)."""

    def __init__(self, f, shape, kappa, kappa_v=0.0):
        self.f = float(f)
        self.height, self.width = shape
        self.cx = self.width / 2.0
        self.cy = self.height / 2.0
        self.kappa = float(kappa)
        self.kappa_v = float(kappa_v)  # vertical curvature: > 0 the road rises ahead

    def to_camera(self, ds, d, y):
        """Road coordinates (arc length ahead, lateral, height) -> straight frame."""
        ds = np.asarray(ds, dtype=np.float64)
        d = np.asarray(d, dtype=np.float64)
        if self.kappa_v != 0.0:  # a change of grade: the road ahead rises or falls
            y = y + 0.5 * self.kappa_v * ds * ds
        k = self.kappa
        if k == 0.0:
            return d + 0.0 * ds, ds + 0.0 * d, y
        theta = k * ds
        x = d * np.cos(theta) + ds * np.sin(theta / 2) * np.sinc(theta / (2 * np.pi))
        z = ds * np.sinc(theta / np.pi) - d * np.sin(theta)
        return x, z, y

    def project(self, x, z, y, pose):
        """Straight-frame points (x lateral, z ahead, y height) -> pixels, depth.

        ``pose`` is ``(e, h, phi)`` or ``(e, h, phi, psi)``: ``psi`` a yaw (radians,
        the camera turned to the right positive), applied before the pitch."""
        e, h, phi = pose[:3]
        xr = np.asarray(x) - e
        yr = np.asarray(y) - h
        psi = pose[3] if len(pose) > 3 else 0.0
        if psi:  # the camera turned about the vertical axis
            cy_, sy_ = math.cos(psi), math.sin(psi)
            xr, z = xr * cy_ - z * sy_, xr * sy_ + z * cy_
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
        e, h, phi = pose[:3]
        k = cam.kappa
        c, sn = math.cos(phi), math.sin(phi)
        dz = c - self.yc * sn
        psi = pose[3] if len(pose) > 3 else 0.0
        if psi:  # undo the yaw: the ray in the road's frame
            cy_, sy_ = math.cos(psi), math.sin(psi)
            dz_yawed = dz
            dz = dz_yawed * cy_ - self.xc * sy_
            dx = (self.xc * cy_ + dz_yawed * sy_) / dz
        else:
            dx = self.xc / dz
        dy = (self.yc * c + sn) / dz
        inf = np.float32(np.inf)
        kv = cam.kappa_v
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            if kv == 0.0:
                z_road = np.where(dy < 0, h / -dy, inf)
            else:  # the ray y = h + dy z meets the road y = kv z^2 / 2
                disc = dy * dy + 2.0 * kv * h
                root = np.sqrt(np.maximum(disc, 0))
                z_road = np.where(disc >= 0, 2.0 * h / (root - dy), inf)
                z_road = np.where(z_road > 0, z_road, inf)
            if k == 0.0:
                z_l = np.where(dx < 0, (_WALL_LEFT + e) / -dx, inf)
                z_r = np.where(dx > 0, (_WALL_RIGHT - e) / dx, inf)
            else:
                z_l = self._curved_wall(dx, -_WALL_LEFT - e, k)
                z_r = self._curved_wall(dx, _WALL_RIGHT - e, k)
            z_wall = np.minimum(z_l, z_r)
            y_wall = h + dy * z_wall - 0.5 * kv * np.minimum(z_wall, _Z_FAR) ** 2
            # circular arch, centre shifted by the curve at the hit depth
            a = dx * dx + dy * dy
            z_arch = None
            shift = 0.0
            lift = 0.0
            for _ in range(1 if k == 0.0 and kv == 0.0 else 3):
                cx = _ARCH_X - e + shift
                cy = _ARCH_Y - h + lift
                b = dx * cx + dy * cy
                cc = cx * cx + cy * cy - _ARCH_R**2
                disc = b * b - a * cc
                z_arch = (b + np.sqrt(np.maximum(disc, 0))) / a
                z_arch = np.where((disc >= 0) & (z_arch > 0), z_arch, _Z_FAR)
                shift = 0.5 * k * np.minimum(z_arch, _Z_FAR) ** 2
                lift = 0.5 * kv * np.minimum(z_arch, _Z_FAR) ** 2
        road = z_road <= z_wall
        arch = ~road & (y_wall > _WALL_HEIGHT)
        z = np.where(road, z_road, np.where(arch, z_arch, z_wall))
        z = np.minimum(z, _Z_FAR).astype(np.float32)
        y = h + dy * z - 0.5 * kv * z * z  # height of the hit point above the road
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


class _Agc:
    """A camera's automatic gain control, reacting to hot objects in view.

    It maps the frame's 1st and 99.5th percentiles (on a 1-in-8 grid, before the
    8-bit clip) to ``levels`` (what a default frame shows), following a change with
    time constant ``tau`` s: a hot truck or a near lamp raises the upper percentile
    and the gain drops, a cooler view raises it; every grey level moves, frame by
    frame.
    """

    def __init__(self, fps, tau, levels=(92.0, 240.0)):
        self.alpha = 1.0 - math.exp(-1.0 / (fps * tau))
        self.levels = levels
        self.gain, self.offset = None, None
        self.gains = []

    def apply(self, img):
        lo, hi = np.percentile(img[4::8, 4::8], [1.0, 99.5])
        hi = max(float(hi), float(lo) + 1.0)
        g = (self.levels[1] - self.levels[0]) / (hi - lo)
        o = self.levels[0] - g * float(lo)
        if self.gain is None:  # the camera starts settled
            self.gain, self.offset = g, o
        else:
            self.gain += self.alpha * (g - self.gain)
            self.offset += self.alpha * (o - self.offset)
        self.gains.append(self.gain)
        img *= np.float32(self.gain)
        img += np.float32(self.offset)


# --------------------------------------------------------------------------------------
# lens and mounting: roll about the optical axis, vignetting
# --------------------------------------------------------------------------------------
def _roll_matrix(roll_deg, shape):
    """2x3 affine map turning the image ``roll_deg`` counter-clockwise (as shown,
    rows downward) about the principal point (the image centre)."""
    import cv2  # noqa: PLC0415

    H, W = shape
    return cv2.getRotationMatrix2D((W / 2.0, H / 2.0), float(roll_deg), 1.0)


def _roll_image(img, M):
    """The radiance image seen by a camera rolled by ``M`` (scene beyond the rotated
    frame's corners continued by reflection)."""
    import cv2  # noqa: PLC0415

    H, W = img.shape
    return cv2.warpAffine(img, M, (W, H), flags=cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_REFLECT_101)


def _roll_box(box, M):
    """The axis-aligned box ``(u0, v0, u1, v1, depth)`` around the rolled corners."""
    u0, v0, u1, v1, z = box
    u = np.array([u0, u1, u0, u1])
    v = np.array([v0, v0, v1, v1])
    ru = M[0, 0] * u + M[0, 1] * v + M[0, 2]
    rv = M[1, 0] * u + M[1, 1] * v + M[1, 2]
    return (float(ru.min()), float(rv.min()), float(ru.max()), float(rv.max()), z)


def _vignette(shape, corner):
    """Relative lens response: 1 at the centre, falling with the squared distance to
    ``corner`` at the image corners (radiance is multiplied by it)."""
    H, W = shape
    yy, xx = np.mgrid[0:H, 0:W]
    r2 = ((xx + 0.5 - W / 2) ** 2 + (yy + 0.5 - H / 2) ** 2) / ((W / 2) ** 2 + (H / 2) ** 2)
    return (1.0 - (1.0 - corner) * r2).astype(np.float32)


# --------------------------------------------------------------------------------------
# the bolometer's thermal lag
# --------------------------------------------------------------------------------------
def _lag_samples(tau, fps, *, span=3.0, per_tau=2):
    """Ages and weights of the sub-frame samples that make a microbolometer's frame.

    A bolometer pixel follows the radiance ``x`` as a first-order low-pass of time
    constant ``tau``: its output at the readout is ``integral of x(t - a)
    exp(-a / tau) / tau da`` over the ages ``a >= 0``.  The integral is cut at
    ``span * tau`` and split into ``span * per_tau`` equal intervals; each sample
    (at the start of its interval) carries that interval's weight, and the last
    also the tail beyond ``span * tau`` (exp(-3) = 5 % for ``span=3``).

    Parameters
    ----------
    tau : float
        Time constant (s), > 0.
    fps : float
        Frame rate (Hz); only checked, the ages are in seconds.
    span : float, default=3.0
        How many time constants the samples cover.
    per_tau : int, default=2
        Samples per time constant.

    Returns
    -------
    ages : ndarray of shape (n,)
        Seconds before the readout, ``ages[0] = 0``.
    weights : ndarray of shape (n,)
        Summing to 1.

    Examples
    --------
    >>> ages, w = _lag_samples(0.01, 30.0)
    >>> ages.round(4).tolist()
    [0.0, 0.005, 0.01, 0.015, 0.02, 0.025]
    >>> w.round(3).tolist(), float(w.sum())
    ([0.393, 0.239, 0.145, 0.088, 0.053, 0.082], 1.0)
    """
    if not (tau > 0 and fps > 0):
        raise ValueError(f"tau and fps must be > 0; got {tau!r}, {fps!r}")
    n = int(round(span * per_tau))
    step = tau / per_tau
    ages = step * np.arange(n)
    edges = np.exp(-step * np.arange(n + 1) / tau)
    weights = edges[:-1] - edges[1:]
    weights[-1] += edges[-1]  # the tail
    return ages, weights / weights.sum()


def _at(values, q):
    """``values`` (one per frame) at the fractional frame index ``q``: linear
    interpolation, extrapolated from the first two frames before frame 0.

    Examples
    --------
    >>> _at(np.array([0.0, 2.0, 6.0]), 1.25), _at(np.array([0.0, 2.0, 6.0]), -0.5)
    (3.0, -1.0)
    """
    n = len(values)
    if n == 1:
        return float(values[0])
    i = min(max(int(math.floor(q)), 0), n - 2)
    return float(values[i] + (q - i) * (values[i + 1] - values[i]))
