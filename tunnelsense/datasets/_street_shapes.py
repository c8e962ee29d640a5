"""Cross-sections of the street's objects: what the scan plane cuts, as boxes.

Every object the vertical scan plane cuts is, in that plane, a small set of
axis-aligned boxes ``(depth0, depth1, height0, height1, material)``: the body, glass
and tyres of a vehicle at the cut, a pedestrian's legs and torso, a post, a bin, a
hedge, a tree's trunk and crown.
"""

from __future__ import annotations

import numpy as np

__all__ = ["BODY", "FOLIAGE", "GLASS", "TYRE", "cross_sections"]

# surface materials of the boxes
_BODY, _GLASS, _TYRE, _FOLIAGE = 0, 1, 2, 3
BODY, GLASS, TYRE, FOLIAGE = _BODY, _GLASS, _TYRE, _FOLIAGE

_N_BOXES = 6  # boxes per object cross-section

def _empty_boxes(n):
    boxes = np.full((n, _N_BOXES, 5), np.inf)
    boxes[..., 4] = _BODY
    return boxes


def _set(boxes, j, mask, y0, y1, z0, z1, material=_BODY):
    """Fill box ``j`` where ``mask`` (and the box is not empty)."""
    y0, y1, z0, z1 = (np.broadcast_to(a, mask.shape) for a in (y0, y1, z0, z1))
    m = mask & (y1 > y0) & (z1 > z0)
    boxes[m, j, 0] = y0[m]
    boxes[m, j, 1] = y1[m]
    boxes[m, j, 2] = z0[m]
    boxes[m, j, 3] = z1[m]
    boxes[m, j, 4] = material


def _car_boxes(o, s):
    """Cross-section of a car or van at ``s`` metres behind its nose."""
    if "bay_angle" in o:
        return _angled_car_boxes(o, s)
    n = len(s)
    boxes = _empty_boxes(n)
    L, W, yn, zb, R = o["length"], o["width"], o["depth_near"], o["base"], o["wheel_radius"]
    f = s / L
    top = np.interp(f, o["top_f"], o["top_h"])
    # rounded corners in plan view
    rc = o["corner"]
    d_end = np.minimum(s, L - s)
    inset = np.where(d_end < rc, rc - np.sqrt(np.maximum(rc**2 - (rc - d_end) ** 2, 0)), 0)
    y0, y1 = yn + inset, yn + W - inset
    # underbody: bumpers/overhangs sit higher; arches over the wheels
    bot = np.full(n, o["clearance"])
    bot[(s < o["axles"][0] - R) | (s > o["axles"][1] + R)] = o["overhang_bottom"]
    belt = o["belt"]
    for axle in o["axles"]:
        d = np.abs(s - axle)
        on = d < R
        c = np.sqrt(np.maximum(R**2 - d**2, 0))
        arch = np.where(d < R + 0.05, R + np.sqrt(np.maximum((R + 0.05) ** 2 - d**2, 0)), 0)
        bot = np.maximum(bot, np.minimum(arch, belt - 0.1))
        _set(boxes, 3, on, yn + inset + 0.04, yn + inset + 0.26, zb + R - c, zb + R + c, _TYRE)
        _set(boxes, 4, on, yn + W - inset - 0.26, yn + W - inset - 0.04,
             zb + R - c, zb + R + c, _TYRE)
    # side panel, with the sill (rocker) tucked in below it
    sill = bot + 0.12
    _set(boxes, 0, np.ones(n, bool), y0, y1, zb + sill, zb + np.minimum(top, belt))
    _set(boxes, 5, np.ones(n, bool), y0 + 0.05, y1 - 0.05, zb + bot,
         zb + np.minimum(sill, np.minimum(top, belt)))
    cabin = top > belt + 0.1
    t = o["tumble"]
    glass = cabin & (f >= o["glass_f"][0]) & (f <= o["glass_f"][1])
    _set(boxes, 1, glass, y0 + t, y1 - t, zb + belt, zb + top - 0.08, _GLASS)
    _set(boxes, 1, cabin & ~glass, y0 + t, y1 - t, zb + belt, zb + top - 0.08)
    _set(boxes, 2, cabin, y0 + t + 0.03, y1 - t - 0.03, zb + top - 0.08, zb + top)
    return boxes


def _cut(dx, c, sn, a_lo, a_hi, w_lo, w_hi):
    """Depth interval ``(dy0, dy1)`` (from the footprint's centre) where the scan plane
    ``dx`` metres along the street from the centre crosses the part of a footprint
    turned ``atan2(sn, c)`` from the street lying between ``a_lo`` and ``a_hi`` along
    its axis and ``w_lo`` and ``w_hi`` across it (``dy0 >= dy1``: it misses)."""
    # along the axis: a = dx c + dy sn; across it: w = dy c - dx sn
    dy0 = (a_lo - dx * c) / sn
    dy1 = (a_hi - dx * c) / sn
    if c > 1e-9:
        dy0 = np.maximum(dy0, (w_lo + dx * sn) / c)
        dy1 = np.minimum(dy1, (w_hi + dx * sn) / c)
    else:  # at right angles: the plane is inside the width or misses it
        inside = (-dx * sn >= w_lo) & (-dx * sn <= w_hi)
        dy1 = np.where(inside, dy1, -np.inf)
    return dy0, dy1


_ANGLED_SEGMENTS = 10  # depth slices of a car in an angled bay


def _angled_car_boxes(o, s):
    """A car or van in an angled bay (``bay_angle`` rad from the street, nose toward
    the kerb when ``nose_in``): the scan plane cuts its footprint obliquely, so the
    depth it spans holds successive parts of its side profile (bumper, bonnet, cabin,
    boot) as slices of their own height, with the wheels the plane passes through.
    As on a car along the kerb, the cabin's top 8 cm is the roof panel (metal) over
    its windows (glass): seen end on, a car shows its roof from above."""
    n = len(s)
    k = _ANGLED_SEGMENTS
    boxes = np.full((n, 3 * k + 4, 5), np.inf)
    boxes[..., 4] = _BODY
    L, W, zb = o["car_length"], o["car_width"], o["base"]
    c, sn = np.cos(o["bay_angle"]), np.sin(o["bay_angle"])
    yc = o["depth_near"] + o["width"] / 2
    dx = (o["length"] - s) - o["length"] / 2  # the cut, from the footprint's centre
    sign = 1.0 if o["nose_in"] else -1.0

    def along(a):  # metres behind the nose of the axis coordinate a
        return L / 2 - sign * a

    dy0, dy1 = _cut(dx, c, sn, -L / 2, L / 2, -W / 2, W / 2)
    hit = dy1 > dy0
    edges = dy0[:, None] + (dy1 - dy0)[:, None] * np.linspace(0, 1, k + 1)[None, :]
    for j in range(k):
        mid = 0.5 * (edges[:, j] + edges[:, j + 1])
        sm = np.clip(along(dx * c + mid * sn), 0.0, L)
        f = sm / L
        top = np.interp(f, o["top_f"], o["top_h"])
        ends = (sm < o["axles"][0] - o["wheel_radius"]) | (sm > o["axles"][1] + o["wheel_radius"])
        bot = np.where(ends, o["overhang_bottom"], o["clearance"])
        y0, y1 = yc + edges[:, j], yc + edges[:, j + 1]
        _set(boxes, 3 * j, hit, y0, y1, zb + bot, zb + np.minimum(top, o["belt"]))
        glass = (f >= o["glass_f"][0]) & (f <= o["glass_f"][1])
        cabin = hit & (top > o["belt"] + 0.1)
        _set(boxes, 3 * j + 1, cabin & glass, y0, y1, zb + o["belt"], zb + top - 0.08,
             _GLASS)
        _set(boxes, 3 * j + 1, cabin & ~glass, y0, y1, zb + o["belt"], zb + top - 0.08)
        _set(boxes, 3 * j + 2, cabin, y0, y1, zb + top - 0.08, zb + top)
    R = o["wheel_radius"]
    j = 3 * k
    for axle in o["axles"]:
        a_lo, a_hi = sorted((sign * (L / 2 - axle - R), sign * (L / 2 - axle + R)))
        for w_lo, w_hi in ((-W / 2 + 0.04, -W / 2 + 0.26), (W / 2 - 0.26, W / 2 - 0.04)):
            t0, t1 = _cut(dx, c, sn, a_lo, a_hi, w_lo, w_hi)
            _set(boxes, j, t1 > t0, yc + t0, yc + t1, zb, zb + 2 * R, _TYRE)
            j += 1
    return boxes


def _motorbike_across_boxes(o, s, kerb, kerb_height):
    """A motorbike at right angles to the kerb, cut along its length: wheels at both
    ends of its depth, the engine and seat between them, the screen and handlebars
    across its whole width; parts beyond the kerb stand on the footway."""
    n = len(s)
    boxes = _empty_boxes(n)
    W, D, dn, zb = o["length"], o["width"], o["depth_near"], o["base"]
    c = np.abs(s - W / 2)  # from the bike's centre line along the street

    def q(a, b):  # depth interval from the front (or the rear, turned round)
        return (dn + D - b, dn + D - a) if o["rear_out"] else (dn + a, dn + b)

    parts = [(0, q(0.05, 0.65), c < 0.07, 0.0, 0.6, _TYRE),
             (1, q(D - 0.65, D - 0.05), c < 0.07, 0.0, 0.6, _TYRE),
             (2, q(0.55, D - 0.5), c < 0.2, 0.3, 0.9, _BODY),
             (3, q(0.6, D - 0.25), c < 0.15, 0.75, 0.9, _BODY),
             (4, q(0.35, 0.6), c < W / 2, 0.8, o["screen"], _BODY)]
    for j, (y0, y1), on, z0, z1, material in parts:
        step = kerb_height if (y0 + y1) / 2 > kerb else 0.0
        _set(boxes, j, on, y0, y1, zb + step + z0, zb + step + z1, material)
    return boxes


def _motorbike_boxes(o, s):
    if o.get("across"):
        return _motorbike_across_boxes(o, s, o["kerb"], o["kerb_height"])
    n = len(s)
    boxes = _empty_boxes(n)
    L, yc, zb, R = o["length"], o["depth_near"] + o["width"] / 2, o["base"], 0.3
    for j, axle in enumerate((0.35, L - 0.35)):
        d = np.abs(s - axle)
        c = np.sqrt(np.maximum(R**2 - d**2, 0))
        _set(boxes, j, d < R, yc - 0.07, yc + 0.07, zb + R - c, zb + R + c, _TYRE)
    _set(boxes, 2, (s > 0.45) & (s < L - 0.3), yc - 0.2, yc + 0.2, zb + 0.3, zb + 0.92)
    _set(boxes, 3, (s > 0.3) & (s < 0.55), yc - o["width"] / 2, yc + o["width"] / 2,
         zb + 0.8, zb + 1.15)
    if o["rider"]:
        _set(boxes, 4, (s > 0.7) & (s < 1.3), yc - 0.22, yc + 0.22, zb + 0.8, zb + 1.65)
    return boxes


def _pedestrian_boxes(o, s):
    n = len(s)
    boxes = _empty_boxes(n)
    yc, zb, h = o["depth_near"] + 0.22, o["base"], o["height"]
    on = np.ones(n, bool)
    legs = 0.47 * h
    _set(boxes, 0, on, yc - 0.18, yc - 0.04, zb, zb + legs)
    _set(boxes, 1, on, yc + 0.04, yc + 0.18, zb, zb + legs)
    _set(boxes, 2, on, yc - 0.22, yc + 0.22, zb + legs, zb + 0.82 * h)
    _set(boxes, 3, on, yc - 0.1, yc + 0.1, zb + 0.82 * h, zb + h)
    return boxes


def _post_boxes(o, s):
    """Bollards and lamp poles: one thin box."""
    boxes = _empty_boxes(len(s))
    _set(boxes, 0, np.ones(len(s), bool), o["depth_near"], o["depth_near"] + o["width"],
         o["base"], o["base"] + o["height"])
    return boxes


def _bin_boxes(o, s):
    boxes = _empty_boxes(len(s))
    on = np.ones(len(s), bool)
    yn, zb, h = o["depth_near"], o["base"], o["height"]
    _set(boxes, 0, on, yn, yn + o["width"], zb + 0.04, zb + h - 0.07)
    _set(boxes, 1, on, yn - 0.03, yn + o["width"] + 0.03, zb + h - 0.07, zb + h)
    return boxes


def _hedge_boxes(o, s):
    boxes = _empty_boxes(len(s))
    a, b, phase, lam = o["wiggle"]
    h = o["height"] + a * np.sin(2 * np.pi * s / lam + phase)
    yn = o["depth_near"] + b * (1 + np.sin(2 * np.pi * s / (0.6 * lam) + 2 * phase))
    _set(boxes, 0, np.ones(len(s), bool), yn, yn + o["width"], o["base"], o["base"] + h,
         _FOLIAGE)
    return boxes


def _tree_boxes(o, s):
    boxes = _empty_boxes(len(s))
    L, yc, zb = o["length"], o["depth_near"] + o["width"] / 2, o["base"]
    d = np.abs(s - L / 2)
    _set(boxes, 0, d < 0.15, yc - 0.15, yc + 0.15, zb, zb + 3.2)
    k = np.sqrt(np.maximum(1 - (d / (L / 2)) ** 2, 0))
    r = o["width"] / 2 * k
    mid = o["crown"]
    _set(boxes, 1, k > 0.05, yc - r, yc + r, zb + mid - 1.4 * k, zb + mid + 1.4 * k,
         _FOLIAGE)
    return boxes


def _bicycle_boxes(o, s):
    """A bicycle: tubes, rims and a saddle 2-8 cm thick, a handlebar 1.0 m high.
    Parallel to the kerb the plane cuts it across its length (``s`` behind its
    nose); at right angles (``across``) along it, ``s`` across its bar, and only the
    plane through its middle meets the wheels and the frame."""
    n = len(s)
    L, zb, bar = o["bike_length"], o["base"], o["bar"]
    R, rim = 0.34, 0.04
    if not o["across"]:
        boxes = np.full((n, 8, 5), np.inf)
        boxes[..., 4] = _BODY
        yc = o["depth_near"] + o["width"] / 2
        for j, axle in enumerate((0.36, L - 0.36)):
            d = np.abs(s - axle)
            c = np.sqrt(np.maximum(R**2 - d**2, 0))
            _set(boxes, 2 * j, d < R, yc - 0.02, yc + 0.02, zb + R - c,
                 zb + np.minimum(R - c + rim, R + c), _TYRE)
            _set(boxes, 2 * j + 1, d < R - rim, yc - 0.02, yc + 0.02,
                 zb + R + c - rim, zb + R + c, _TYRE)
        _set(boxes, 4, (s > 0.45) & (s < L - 0.62), yc - 0.02, yc + 0.02, zb + 0.76,
             zb + 0.80)
        h = 0.72 - (s - 0.5) / (0.55 * L - 0.5) * 0.42  # the down tube
        _set(boxes, 5, (s > 0.5) & (s < 0.55 * L), yc - 0.02, yc + 0.02, zb + h - 0.03,
             zb + h + 0.03)
        _set(boxes, 6, (s > L - 0.75) & (s < L - 0.5), yc - 0.08, yc + 0.08, zb + 0.92,
             zb + 0.98)
        _set(boxes, 7, (s > 0.28) & (s < 0.36), yc - bar / 2, yc + bar / 2, zb + 1.0,
             zb + 1.05)
        return boxes
    boxes = np.full((n, 12, 5), np.inf)
    boxes[..., 4] = _BODY
    t = np.abs(s - bar / 2)  # from the bicycle's middle plane
    y = o["depth_near"]  # its front, nearest the road
    _set(boxes, 0, t < bar / 2, y + 0.28, y + 0.36, zb + 1.0, zb + 1.05)
    _set(boxes, 1, t < 0.08, y + L - 0.75, y + L - 0.5, zb + 0.92, zb + 0.98)
    _set(boxes, 2, t < 0.17, y + 0.55 * L - 0.1, y + 0.55 * L + 0.1, zb + 0.2, zb + 0.35)
    mid = t < 0.025
    _set(boxes, 3, mid, y + 0.45, y + L - 0.62, zb + 0.76, zb + 0.80)
    for j, axle in enumerate((0.36, L - 0.36)):
        a = y + axle
        k = 4 + 4 * j
        _set(boxes, k, mid, a - 0.15, a + 0.15, zb, zb + rim, _TYRE)
        _set(boxes, k + 1, mid, a - 0.15, a + 0.15, zb + 2 * R - rim, zb + 2 * R, _TYRE)
        _set(boxes, k + 2, mid, a - R, a - R + rim, zb + 0.2, zb + 0.48, _TYRE)
        _set(boxes, k + 3, mid, a + R - rim, a + R, zb + 0.2, zb + 0.48, _TYRE)
    return boxes


_PROFILES = {
    "car": _car_boxes,
    "van": _car_boxes,
    "small": _car_boxes,
    "long": _car_boxes,
    "caravan": _car_boxes,
    "wall": _post_boxes,
    "motorbike": _motorbike_boxes,
    "pedestrian": _pedestrian_boxes,
    "bollard": _post_boxes,
    "pole": _post_boxes,
    "bin": _bin_boxes,
    "communal_bin": _bin_boxes,
    "hedge": _hedge_boxes,
    "tree": _tree_boxes,
    "bicycle": _bicycle_boxes,
}


# --------------------------------------------------------------------------------------
# Scene layout
# --------------------------------------------------------------------------------------


def cross_sections(objects, stamps, x_ego):
    """Rows ``(scan, object, y0, y1, z0, z1, material)`` of every box the scans cut."""
    scans, owners, boxes = [], [], []
    for i, o in enumerate(objects):
        L = o["length"]
        if o["speed"] == 0.0:
            a = np.searchsorted(x_ego, o["x0"], "left")
            b = np.searchsorted(x_ego, o["x0"] + L, "right")
            idx = np.arange(a, b)
            u = x_ego[idx] - o["x0"]
        else:
            u_all = x_ego - (o["x0"] + o["speed"] * stamps)
            idx = np.flatnonzero((u_all >= 0) & (u_all <= L))
            u = u_all[idx]
        if not len(idx):
            continue
        s = L - u if o["facing"] > 0 else u  # metres behind the nose
        b = _PROFILES[o["kind"]](o, s)
        keep = np.isfinite(b[..., 0])
        rows = np.nonzero(keep)
        scans.append(idx[rows[0]])
        owners.append(np.full(len(rows[0]), i))
        boxes.append(b[keep])
    if not scans:
        return np.empty(0, np.int64), np.empty(0, np.int64), np.empty((0, 5))
    scans, owners, boxes = np.concatenate(scans), np.concatenate(owners), np.concatenate(boxes)
    order = np.argsort(scans, kind="stable")
    return scans[order], owners[order], boxes[order]
