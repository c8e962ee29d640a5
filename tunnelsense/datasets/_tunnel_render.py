"""Painting in the simulated images: anti-aliased primitives (the optics' blur and
pixel integration) and the objects drawn with them (indicators, lamps, vehicles,
their warm shadows)."""

from __future__ import annotations

import math

import cv2
import numpy as np
from scipy.special import erf

from tunnelsense.datasets._tunnel_scene import (
    _INDICATOR_SIZE,
    _PSF_SIGMA,
    _Z_NEAR,
    _lining_x,
)

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


def _facing_box(cam, pose, ds, d, y):
    """The box of a flat rectangle facing the traffic ``ds`` ahead, spanning the
    lateral offsets ``d`` and the heights ``y`` (two each; None behind the camera)."""
    dd, yy = np.meshgrid(d, y)
    x3, z3, y3 = cam.to_camera(np.full(4, ds), dd.ravel(), yy.ravel())
    return _box_of(cam, pose, x3, z3, y3)


def _draw_indicator(img, cam, pose, ds, p, look):
    w, hgt = p.get("indicator_size_m", _INDICATOR_SIZE)
    yc = p["indicator_height_m"]
    if p.get("indicator_side", "left") == "left":
        x_out = _lining_x(yc, -1) + 0.05
        d = np.array([x_out, x_out + w])
    else:  # the right wall: the sign's outer edge 5 cm off the lining
        x_out = _lining_x(yc, 1) - 0.05
        d = np.array([x_out - w, x_out])
    y = np.array([yc - hgt / 2, yc + hgt / 2])
    box = _facing_box(cam, pose, ds, d, y)
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


#: lit panels other than the indicators (emergency-exit and escape-route signs):
#: width, height and centre height (m), landscape where the indicator is portrait
PANEL_SIZE_M, PANEL_HEIGHT_M = (0.8, 0.4), 2.0


def _draw_panel(img, cam, pose, ds, side, look):
    """A lit panel sign on the wall ``side`` (-1 left) facing the traffic, its outer
    edge 5 cm off the lining: a housing, a lit face, a darker pictograph (a running
    figure and an arrow). Returns its box (it is in no ground truth)."""
    w, hgt = PANEL_SIZE_M
    x_out = _lining_x(PANEL_HEIGHT_M, side) - side * 0.05
    d = np.array(sorted([x_out, x_out - side * w]))
    y = np.array([PANEL_HEIGHT_M - hgt / 2, PANEL_HEIGHT_M + hgt / 2])
    box = _facing_box(cam, pose, ds, d, y)
    if box is None:
        return None
    u0, v0, u1, v1, _ = box
    bw, bh = u1 - u0, v1 - v0
    frame, face, figure = look
    _paint(img, u0, u1, v0, v1, frame)
    _paint(img, u0 + 0.05 * bw, u1 - 0.05 * bw, v0 + 0.1 * bh, v1 - 0.1 * bh, face)
    if bw > 8:
        _paint(img, u0 + 0.15 * bw, u0 + 0.4 * bw, v0 + 0.2 * bh, v1 - 0.2 * bh, figure)
        _paint(img, u0 + 0.55 * bw, u1 - 0.15 * bw, v0 + 0.4 * bh, v1 - 0.4 * bh, figure)
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


def _draw_shadow(img, cam, pose, veh, f, ds, warming=0.0):
    """The warm road patch under and behind a vehicle (class 4), on a road
    ``warming`` grey levels warmer than usual (warm air)."""
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
    if warming:
        shadow = shadow + warming
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
