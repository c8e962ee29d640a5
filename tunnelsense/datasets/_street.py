"""Laser street runs: a vertically scanning laser range finder passing parked vehicles.

The scene is built in metres in a street frame: ``x`` along the street (the direction
the measurement vehicle drives), ``depth`` horizontally across the street from the
sensor toward the kerb, ``height`` up from the road at the vehicle.  The scanner sweeps
the vertical ``(depth, height)`` plane at the vehicle's position; every object that the
plane cuts is a small set of axis-aligned boxes in that plane (its cross-section at the
cut), and the beams are ray-cast against those boxes and against the road, kerb and
sidewalk, all scans and beams at once.
"""

from __future__ import annotations

import math
import numbers

import numpy as np
import pandas as pd
from sklearn.utils import check_random_state

from tunnelsense._records import RUN_GT_COLUMNS, LaserGeometry, Run

__all__ = ["STREET_SCENARIOS", "make_street_scans"]

#: Names of the street scenarios of :func:`make_street_scans`.
STREET_SCENARIOS = ("sparse", "dense", "tilted", "crowded")

#: Range the paper's sensor reports for no return or an object beyond 8.0 m (m).
MAX_RANGE = 8.191
#: Farthest range the sensor measures (m).
MEASURE_LIMIT = 8.0

# surface materials of the boxes
_BODY, _GLASS, _TYRE, _FOLIAGE = 0, 1, 2, 3
# codes of what a beam hit, besides object indices (>= 0)
HIT_NONE, HIT_ROAD, HIT_KERB = -1, -2, -3

# Physical parameters (the documented ``**overrides``): default, lower and upper bound.
# ``None`` as a scenario value means "drawn at random for every run".
_PARAMS = {
    "speed_kmh": (40.0, 5.0, 120.0),
    "speed_variation_kmh": (3.0, 0.0, 15.0),
    "scan_rate_hz": (75.0, 1.0, 1000.0),
    "mount_height": (2.0, 0.5, 4.0),
    "roll_deg": (0.0, -15.0, 15.0),
    "roll_drift_deg": (0.0, 0.0, 10.0),
    "angle_min_deg": (-80.0, -89.0, 0.0),
    "angle_max_deg": (40.0, 0.0, 89.0),
    "angle_increment_deg": (0.5, 0.05, 5.0),
    "range_noise": (0.01, 0.0, 0.2),
    "range_noise_per_m": (0.0025, 0.0, 0.05),
    "dropout_rate": (0.003, 0.0, 0.5),
    "kerb_depth": (6.45, 5.0, 7.5),
    "kerb_height": (0.13, 0.0, 0.3),
    "camber_drop": (0.04, 0.0, 0.1),
    "parked_cluster_size": (1.6, 1.0, 50.0),
    "parked_gap_m": (25.0, 0.5, 1000.0),
    "touching_fraction": (0.0, 0.0, 1.0),
    "van_fraction": (0.1, 0.0, 1.0),
    "motorbike_fraction": (0.05, 0.0, 1.0),
    "boundary_fraction": (0.0, 0.0, 1.0),
    "passing_per_min": (4.0, 0.0, 60.0),
    "passing_van_fraction": (0.15, 0.0, 1.0),
    "passing_motorbike_fraction": (0.1, 0.0, 1.0),
    "pedestrians_per_100m": (2.0, 0.0, 100.0),
    "bins_per_100m": (0.5, 0.0, 50.0),
    "bollard_rows_per_100m": (0.3, 0.0, 20.0),
    "hedge_fraction": (0.5, 0.0, 1.0),
    "trees_per_100m": (3.0, 0.0, 30.0),
}

_SCENARIO_PARAMS = {
    "sparse": {},
    "dense": {
        "parked_cluster_size": 9.0,
        "parked_gap_m": 6.0,
        "touching_fraction": 0.08,
        "van_fraction": 0.15,
        "passing_per_min": 10.0,
        "pedestrians_per_100m": 3.0,
    },
    "tilted": {
        "mount_height": 2.4,
        "roll_deg": None,  # 2-4 degrees either way, unknown to the detector
        "roll_drift_deg": 1.0,
        "parked_cluster_size": 4.0,
        "parked_gap_m": 12.0,
        "passing_per_min": 5.0,
    },
    "crowded": {
        "roll_deg": None,
        "roll_drift_deg": 0.6,
        "parked_cluster_size": 10.0,
        "parked_gap_m": 5.0,
        "touching_fraction": 0.15,
        "van_fraction": 0.25,
        "motorbike_fraction": 0.12,
        "boundary_fraction": 0.15,
        "passing_per_min": 14.0,
        "pedestrians_per_100m": 20.0,
        "bins_per_100m": 4.0,
        "bollard_rows_per_100m": 2.0,
        "hedge_fraction": 0.7,
        "trees_per_100m": 5.0,
    },
}

# range of a random unknown roll per scenario (deg, either sign)
_RANDOM_ROLL = {"tilted": (2.0, 4.0), "crowded": (1.0, 2.0)}

_N_BOXES = 6  # boxes per object cross-section
_CHUNK = 256  # scans ray-cast at once


# --------------------------------------------------------------------------------------
# Parameters
# --------------------------------------------------------------------------------------
def _resolve_params(scenario, overrides, rng):
    for key in overrides:
        if key not in _PARAMS:
            raise TypeError(
                f"make_street_scans got an unknown parameter {key!r}; the physical "
                f"parameters are: {', '.join(sorted(_PARAMS))}"
            )
    params = {k: v[0] for k, v in _PARAMS.items()}
    params.update(_SCENARIO_PARAMS[scenario])
    for key, value in overrides.items():
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise TypeError(f"{key} must be a real number; got {type(value).__name__}")
        params[key] = float(value)
    # draw the random ones (always draw, so overriding one keeps the rest of the run)
    lo, hi = _RANDOM_ROLL.get(scenario, (0.0, 0.0))
    roll = float(rng.uniform(lo, hi) * rng.choice([-1.0, 1.0]))
    if params["roll_deg"] is None:
        params["roll_deg"] = roll
    for key, value in params.items():
        _, vlo, vhi = _PARAMS[key]
        if not (math.isfinite(value) and vlo <= value <= vhi):
            raise ValueError(f"{key} must lie in [{vlo}, {vhi}]; got {value!r}")
    if params["angle_max_deg"] <= params["angle_min_deg"]:
        raise ValueError(
            f"angle_max_deg ({params['angle_max_deg']}) must exceed angle_min_deg "
            f"({params['angle_min_deg']})"
        )
    if abs(params["roll_deg"]) + params["roll_drift_deg"] + max(
        abs(params["angle_min_deg"]), abs(params["angle_max_deg"])
    ) >= 89.5:
        raise ValueError("roll_deg, roll_drift_deg and the beam angles reach vertical")
    return params


# --------------------------------------------------------------------------------------
# Ego motion and sensor attitude
# --------------------------------------------------------------------------------------
def _smooth(rng, t, periods, amplitude):
    """A smooth random signal of ``t``: sinusoids of the given periods, peak ~amplitude."""
    out = np.zeros_like(t)
    weights = rng.uniform(0.5, 1.0, len(periods))
    weights /= weights.sum()
    for w, (plo, phi) in zip(weights, periods, strict=True):
        period = rng.uniform(plo, phi)
        out += w * np.sin(2 * np.pi * t / period + rng.uniform(0, 2 * np.pi))
    return amplitude * out


def _ego(p, n_scans, rng):
    dt = 1.0 / p["scan_rate_hz"]
    stamps = np.arange(n_scans) * dt + rng.uniform(-0.02, 0.02, n_scans) * dt
    v0 = p["speed_kmh"] / 3.6
    speed = v0 + _smooth(rng, stamps, [(8.0, 20.0), (25.0, 60.0)], p["speed_variation_kmh"] / 3.6)
    speed = np.maximum(speed, 0.5 * v0)
    # distance travelled: trapezoidal integration over the stamps
    steps = np.diff(stamps) * 0.5 * (speed[1:] + speed[:-1])
    x = np.concatenate([[0.0], np.cumsum(steps)])
    roll = np.deg2rad(
        p["roll_deg"]
        + _smooth(rng, stamps, [(15.0, 40.0), (40.0, 120.0)], p["roll_drift_deg"])
        + _smooth(rng, stamps, [(0.3, 0.8), (1.0, 3.0)], 0.03)  # body sway
    )
    height = p["mount_height"] + _smooth(rng, stamps, [(0.4, 0.9), (1.0, 2.5)], 0.006)
    return stamps, speed, x, roll, height


# --------------------------------------------------------------------------------------
# Objects: cross-sections as boxes (depth0, depth1, height0, height1, material)
# --------------------------------------------------------------------------------------
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


def _motorbike_boxes(o, s):
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


_PROFILES = {
    "car": _car_boxes,
    "van": _car_boxes,
    "motorbike": _motorbike_boxes,
    "pedestrian": _pedestrian_boxes,
    "bollard": _post_boxes,
    "pole": _post_boxes,
    "bin": _bin_boxes,
    "hedge": _hedge_boxes,
    "tree": _tree_boxes,
}


# --------------------------------------------------------------------------------------
# Scene layout
# --------------------------------------------------------------------------------------
def _new_vehicle(rng, kind, *, rider=False):
    """Body dimensions of a car, van or motorbike (metres; side profile knots)."""
    if kind == "motorbike":
        return {"kind": kind, "length": rng.uniform(1.9, 2.2), "width": rng.uniform(0.7, 0.85),
                "rider": rider}
    if kind == "van":
        L, W, H = rng.uniform(4.4, 5.6), rng.uniform(1.85, 2.0), rng.uniform(2.05, 2.6)
        belt = rng.uniform(1.0, 1.15)
        top_f = [0.0, 0.03, 0.1, 0.24, 0.97, 1.0]
        top_h = [0.65, 0.95, belt + 0.15, H, H, H - 0.15]
        glass = (0.12, 0.35)
        tumble, R = 0.03, rng.uniform(0.3, 0.34)
    else:
        L, W, H = rng.uniform(3.4, 4.9), rng.uniform(1.6, 1.85), rng.uniform(1.4, 1.6)
        belt = rng.uniform(0.88, 1.0)
        roof_end = rng.uniform(0.7, 0.9)  # saloon ... hatchback
        tail = 0.05 if roof_end > 0.8 else 0.13
        top_f = [0.0, 0.04, 0.2, 0.3, 0.45, roof_end, 1 - tail, 1.0]
        top_h = [0.6, 0.8, belt, belt + 0.06, H, H, belt + 0.05 + (0.2 if tail < 0.1 else 0),
                 0.7]
        glass = (0.3, roof_end + 0.05)
        tumble, R = rng.uniform(0.1, 0.18), rng.uniform(0.29, 0.33)
    overhang = rng.uniform(0.6, 0.95), rng.uniform(0.55, 0.9)
    return {
        "kind": kind, "length": L, "width": W, "top_f": top_f, "top_h": top_h,
        "belt": belt, "glass_f": glass, "tumble": tumble, "wheel_radius": R,
        "axles": (overhang[0] + R, L - overhang[1] - R), "clearance": rng.uniform(0.14, 0.2),
        "overhang_bottom": rng.uniform(0.25, 0.35), "corner": rng.uniform(0.25, 0.45),
    }


def _vehicle_kind(rng, van, motorbike):
    u = rng.random()
    return "van" if u < van else "motorbike" if u < van + motorbike else "car"


def _layout(p, x_lo, x_hi, t_of_x, rng):
    """All objects of the street.  Static objects have ``speed`` 0."""
    kerb, kh = p["kerb_depth"], p["kerb_height"]
    objects, free = [], []
    x = x_lo
    # parked vehicles in nose-to-tail clusters separated by free kerb
    while x < x_hi:
        gap = rng.exponential(p["parked_gap_m"])
        free.append((x, x + gap))
        x += gap
        n = rng.geometric(1.0 / p["parked_cluster_size"])
        for k in range(n):
            kind = _vehicle_kind(rng, p["van_fraction"], p["motorbike_fraction"])
            o = _new_vehicle(rng, kind)
            W = o["width"]
            where = "kerb"
            base = 0.0
            if kind == "motorbike":
                y_near = kerb - rng.uniform(0.3, 1.0) - W
            elif rng.random() < p["boundary_fraction"]:
                if rng.random() < 0.5:  # badly parked, far from the kerb
                    where, y_near = "boundary-near", rng.uniform(4.0, 4.1)
                else:  # half up on the sidewalk
                    where, y_near, base = "boundary-far", rng.uniform(6.0, 6.15), kh / 2
            else:
                y_near = kerb - rng.uniform(0.1, 0.35) - W
            o.update(label="parked", x0=x, speed=0.0, facing=1.0 if rng.random() < 0.9 else -1.0,
                     depth_near=y_near, base=base, where=where)
            objects.append(o)
            x += o["length"]
            if k < n - 1:
                touching = rng.random() < p["touching_fraction"]
                x += rng.uniform(0.0, 0.02) if touching else rng.uniform(0.3, 1.5)
    free = [(a, b) for a, b in free if b - a > 1.0]
    length = x_hi - x_lo

    def in_free(width):
        """A random x in the free kerb with room for ``width``, or None."""
        room = np.array([max(b - a - width - 0.4, 0.0) for a, b in free])
        if room.sum() <= 0:
            return None
        i = rng.choice(len(free), p=room / room.sum())
        return free[i][0] + 0.2 + rng.uniform(0, room[i])

    def static(kind, x0, L, y_near, W, base, h, **extra):
        objects.append({"kind": kind, "label": None, "x0": x0, "length": L, "speed": 0.0,
                        "facing": 1.0, "depth_near": y_near, "width": W, "base": base,
                        "height": h, **extra})

    # pedestrians: standing at the kerb, walking along the road edge or on the sidewalk
    for _ in range(rng.poisson(p["pedestrians_per_100m"] * length / 100)):
        h, L = rng.uniform(1.5, 1.9), rng.uniform(0.25, 0.4)
        u = rng.random()
        if u < 0.4:
            xp = in_free(L)
            if xp is not None:
                static("pedestrian", xp, L, kerb - rng.uniform(-0.2, 0.8), 0.44, 0.0, h)
            continue
        v = rng.uniform(1.0, 1.8) * rng.choice([-1.0, 1.0])
        if u < 0.7:  # on the road edge, crossing the plane in a free stretch
            xc, y_near, base = in_free(L), kerb - rng.uniform(0.5, 1.2), 0.0
            if xc is None:
                continue
        else:  # on the sidewalk
            xc, y_near, base = rng.uniform(x_lo, x_hi), kerb + rng.uniform(0.3, 1.3), kh
        objects.append({"kind": "pedestrian", "label": None, "x0": xc - v * t_of_x(xc),
                        "length": L, "speed": v, "facing": 1.0, "depth_near": y_near,
                        "width": 0.44, "base": base, "height": h})
    for _ in range(rng.poisson(p["bins_per_100m"] * length / 100)):
        xb = in_free(0.74)
        if xb is not None:
            static("bin", xb, 0.74, kerb - rng.uniform(0.1, 0.7), 0.58, 0.0,
                   rng.uniform(1.0, 1.1))
    for _ in range(rng.poisson(p["bollard_rows_per_100m"] * length / 100)):
        spacing, n = rng.uniform(1.2, 2.0), rng.integers(3, 9)
        xb = in_free(spacing * (n - 1) + 0.15)
        if xb is None:
            continue
        y_near = kerb + rng.uniform(0.02, 0.1)
        for k in range(n):
            static("bollard", xb + k * spacing, 0.15, y_near, 0.15, kh, rng.uniform(0.8, 1.0))
    # sidewalk edge: lamp poles, trees, hedges (kept clear of cars up on the sidewalk)
    blocked = [(o["x0"] - 0.5, o["x0"] + o["length"] + 0.5) for o in objects
               if o.get("where") == "boundary-far"]

    def clear(a, b):
        return all(b < c or a > d for c, d in blocked)

    for xp in np.arange(x_lo + rng.uniform(0, 30), x_hi, 30.0):
        xp = xp + rng.uniform(-3, 3)
        if clear(xp, xp + 0.15):
            static("pole", xp, 0.15, kerb + rng.uniform(0.3, 0.5), 0.14, kh, 6.5)
    for _ in range(rng.poisson(p["trees_per_100m"] * length / 100)):
        L, xt = rng.uniform(3.0, 6.0), rng.uniform(x_lo, x_hi)
        if clear(xt, xt + L):
            static("tree", xt, L, kerb + rng.uniform(0.3, 0.8), rng.uniform(2.5, 4.0), kh,
                   0.0, crown=rng.uniform(3.6, 4.6))
    x = x_lo
    while x < x_hi:
        L = rng.uniform(3.0, 20.0)
        if rng.random() < p["hedge_fraction"] and clear(x, x + L):
            static("hedge", x, L, kerb + rng.uniform(0.4, 0.9), rng.uniform(0.8, 1.5), kh,
                   rng.uniform(0.8, 2.0),
                   wiggle=(rng.uniform(0.05, 0.25), rng.uniform(0.02, 0.1),
                           rng.uniform(0, 2 * np.pi), rng.uniform(1.5, 5.0)))
        x += L + rng.uniform(0.0, 4.0)
    return objects


def _passing(p, stamps, v_ego, rng):
    """Vehicles in the lane between the scanner and the parked ones, at other speeds."""
    objects = []
    rate = p["passing_per_min"] / 60.0
    t = stamps[0] - 1.0
    while rate > 0:
        t += rng.exponential(1.0 / rate)
        if t > stamps[-1] + 1.0:
            break
        kind = _vehicle_kind(rng, p["passing_van_fraction"], p["passing_motorbike_fraction"])
        o = _new_vehicle(rng, kind, rider=True)
        # relative speed of at least 3.5 m/s, both ways; slower ones still move (>= 2.5 m/s)
        rel = rng.uniform(3.5, 8.0)
        slower_ok = v_ego - rel >= 2.5
        sign = 1.0 if (slower_ok and rng.random() < 0.5) else -1.0
        speed = v_ego - sign * rel
        if kind == "motorbike":
            y_near = rng.uniform(1.8, 3.0)
        else:
            y_near = rng.uniform(1.5, max(1.5, 3.45 - o["width"]))
        o.update(label="passing", speed=speed, facing=1.0, depth_near=y_near, base=0.0,
                 cross_time=t)
        objects.append(o)
        # a later one must not overlap this one in the lane: leave it time to clear
        t += (o["length"] + 2.0) / rel
    return objects


# --------------------------------------------------------------------------------------
# Ray casting
# --------------------------------------------------------------------------------------
def _cross_sections(objects, stamps, x_ego):
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


def _cast_ground(p, height, cos, sin):
    """Range to the road (with camber), the kerb face or the sidewalk; and which."""
    kerb, kh = p["kerb_depth"], p["kerb_height"]
    H = height[:, None]
    tan = sin / cos
    down = tan < -1e-9
    # road: z = -q * y**2 (level at the vehicle, dropping camber_drop at the kerb)
    q = p["camber_drop"] / kerb**2
    disc = tan**2 - 4 * q * H
    with np.errstate(invalid="ignore", divide="ignore"):
        y_road = np.where(down & (disc >= 0), 2 * H / (-tan + np.sqrt(np.maximum(disc, 0))),
                          np.inf)
        z_at_kerb = H + kerb * tan
        past = y_road > kerb
        y_walk = np.where(down, (H - kh) / -tan, np.inf)
    face = past & (z_at_kerb <= kh) & (z_at_kerb > -q * kerb**2)
    y = np.where(~past, y_road, np.where(face, kerb, np.where(down, np.maximum(y_walk, kerb),
                                                               np.inf)))
    hit = np.where(~past, HIT_ROAD, HIT_KERB)
    hit = np.where(np.isfinite(y), hit, HIT_NONE)
    return y / cos, hit


def _ray_cast(p, objects, stamps, x_ego, roll, height, angles):
    """True ranges, what each beam hit (object index or HIT_*), and the hit material."""
    n_scans, n_beams = len(stamps), len(angles)
    theta = angles[None, :] + roll[:, None]
    cos, sin = np.cos(theta), np.sin(theta)
    rng_true, hit = _cast_ground(p, height, cos, sin)
    material = np.full((n_scans, n_beams), _BODY, dtype=np.int8)
    scans, owners, boxes = _cross_sections(objects, stamps, x_ego)
    if not len(scans):
        return rng_true, hit, material
    # slot of every box within its scan
    starts = np.searchsorted(scans, np.arange(n_scans))
    slot = np.arange(len(scans)) - starts[scans]
    K = int(slot.max()) + 1
    pad = np.full((n_scans, K, 4), np.inf)
    pad[scans, slot] = boxes[:, :4]
    own = np.full((n_scans, K), -1, dtype=np.int64)
    own[scans, slot] = owners
    mat = np.zeros((n_scans, K), dtype=np.int8)
    mat[scans, slot] = boxes[:, 4].astype(np.int8)
    inv_cos = 1.0 / cos
    safe_sin = np.where(np.abs(sin) < 1e-12, 1e-12, sin)
    inv_sin = 1.0 / safe_sin
    for a in range(0, n_scans, _CHUNK):
        b = min(a + _CHUNK, n_scans)
        # number of boxes actually used in this chunk
        k = int(np.isfinite(pad[a:b, :, 0]).sum(axis=1).max(initial=0))
        if k == 0:
            continue
        P = pad[a:b, :k]
        ic, isn = inv_cos[a:b, None, :], inv_sin[a:b, None, :]
        H = height[a:b, None, None]
        ty0 = P[:, :, 0, None] * ic
        ty1 = P[:, :, 1, None] * ic
        tz0 = (P[:, :, 2, None] - H) * isn
        tz1 = (P[:, :, 3, None] - H) * isn
        t_in = np.maximum(ty0, np.minimum(tz0, tz1))
        t_out = np.minimum(ty1, np.maximum(tz0, tz1))
        t = np.where((t_in <= t_out) & (t_out > 0), t_in, np.inf)
        best = np.argmin(t, axis=1)
        t_best = np.take_along_axis(t, best[:, None, :], axis=1)[:, 0]
        closer = t_best < rng_true[a:b]
        rows = np.arange(b - a)[:, None]
        rng_true[a:b] = np.where(closer, t_best, rng_true[a:b])
        hit[a:b] = np.where(closer, own[a:b][rows, best], hit[a:b])
        material[a:b] = np.where(closer, mat[a:b][rows, best], material[a:b])
    return rng_true, hit, material


def _measure(p, rng_true, hit, material, cos, sin, rng):
    """The sensor: noise, dropouts, millimetre steps, 8.191 m beyond 8.0 m."""
    n_scans, n_beams = rng_true.shape
    noise = rng.standard_normal((n_scans, n_beams))
    u = rng.random((n_scans, n_beams))
    extra = rng.random((n_scans, n_beams))
    finite = np.isfinite(rng_true)
    r = np.where(finite, rng_true, 0.0)
    sigma = p["range_noise"] + p["range_noise_per_m"] * r
    r = r + sigma * noise
    foliage = finite & (hit >= 0) & (material == _FOLIAGE)
    # beams reach into foliage by up to ~0.3 m; a few pass through its gaps
    r = np.where(foliage, r + 0.3 * extra**2, r)
    through = foliage & (u > 0.96)
    r = np.round(r * 1000.0) / 1000.0
    out = np.where(finite & ~through & (r <= MEASURE_LIMIT), r, MAX_RANGE)
    # dropouts: at random, on glass (specular) and on black tyres, at grazing road angles
    p_drop = np.full((n_scans, n_beams), p["dropout_rate"])
    p_drop = np.where(hit >= 0, np.where(material == _GLASS, 0.35, p_drop), p_drop)
    p_drop = np.where((hit >= 0) & (material == _TYRE), 0.1, p_drop)
    grazing = (hit == HIT_ROAD) & (np.abs(sin) < 0.3)
    p_drop = np.where(grazing, p_drop + 0.3 * (0.3 - np.abs(sin)), p_drop)
    dropped = finite & (extra < p_drop) & ~foliage
    out = np.where(dropped, np.nan, out)
    return out


# --------------------------------------------------------------------------------------
# The generator
# --------------------------------------------------------------------------------------
def _check_args(n_scans, scenario):
    if isinstance(n_scans, bool) or not isinstance(n_scans, numbers.Integral):
        raise TypeError(f"n_scans must be an int; got {type(n_scans).__name__}")
    if n_scans < 2:
        raise ValueError(f"n_scans must be at least 2; got {n_scans}")
    if scenario not in STREET_SCENARIOS:
        raise ValueError(
            f"scenario must be one of {', '.join(map(repr, STREET_SCENARIOS))}; "
            f"got {scenario!r}"
        )


def _seed(random_state):
    if isinstance(random_state, numbers.Integral) and not isinstance(random_state, bool):
        seed = int(random_state)
        if not 0 <= seed < 2**32:
            raise ValueError(f"random_state must lie in [0, 2**32); got {seed}")
        return seed
    if random_state is None or isinstance(random_state, np.random.RandomState):
        return int(check_random_state(random_state).randint(0, 2**31 - 1))
    if isinstance(random_state, np.random.Generator):
        return int(random_state.integers(0, 2**31 - 1))
    raise TypeError(
        "random_state must be None, an int, a numpy RandomState or Generator; "
        f"got {type(random_state).__name__}"
    )


def _simulate(n_scans=4000, scenario="sparse", random_state=None, **overrides):
    """Everything the simulator knows, for tests and plots (private).

    Returns a dict with ``ranges``, ``stamps``, ``geometry``, ``gt``, ``info`` and the
    truth per scan/beam: ``hit`` (object index, or ``HIT_ROAD``/``HIT_KERB``/
    ``HIT_NONE``), ``roll`` (rad), ``height`` (m), ``objects`` (dicts, by index).
    """
    _check_args(n_scans, scenario)
    seed = _seed(random_state)
    rng = np.random.default_rng(seed)
    p = _resolve_params(scenario, overrides, rng)
    stamps, speed, x_ego, roll, height = _ego(p, n_scans, rng)
    inc = math.radians(p["angle_increment_deg"])
    n_beams = int(math.floor((p["angle_max_deg"] - p["angle_min_deg"]) /
                             p["angle_increment_deg"] + 1e-9)) + 1
    geometry = LaserGeometry(
        angle_min=math.radians(p["angle_min_deg"]), angle_increment=inc,
        range_min=0.1, range_max=MAX_RANGE, mount_height=p["mount_height"],
    )
    angles = geometry.angles(n_beams)

    def t_of_x(x):
        return float(np.interp(x, x_ego, stamps))

    v0 = p["speed_kmh"] / 3.6
    objects = _layout(p, x_ego[0] - 15.0, x_ego[-1] + 15.0, t_of_x, rng)
    for o in _passing(p, stamps, v0, rng):
        # place it so that its middle crosses the plane at its cross time
        tc = o.pop("cross_time")
        xc = float(np.interp(tc, stamps, x_ego, left=x_ego[0] + v0 * (tc - stamps[0]),
                             right=x_ego[-1] + v0 * (tc - stamps[-1])))
        o["x0"] = xc - o["length"] / 2 - o["speed"] * tc
        objects.append(o)
    rng_true, hit, material = _ray_cast(p, objects, stamps, x_ego, roll, height, angles)
    theta = angles[None, :] + roll[:, None]
    ranges = _measure(p, rng_true, hit, material, np.cos(theta), np.sin(theta), rng)

    # ground truth: vehicles the scanner sees (in at least 3 scans, between 0.1 m and
    # 2 m above the road), over the scans their body crosses the plane
    with np.errstate(invalid="ignore"):
        z = height[:, None] + ranges * np.sin(theta)
        valid = (hit >= 0) & (ranges < MAX_RANGE) & (z > 0.1) & (z < 2.0)
    scan_idx = np.nonzero(valid)[0]
    seen = np.unique(hit[valid] * np.int64(n_scans) + scan_idx)
    scans_seen = np.bincount(seen // n_scans, minlength=len(objects))
    rows = []
    for i, o in enumerate(objects):
        if o["label"] is None or scans_seen[i] < 3:
            continue
        if o["speed"] == 0.0:
            first = int(np.searchsorted(x_ego, o["x0"], "left"))
            last = int(np.searchsorted(x_ego, o["x0"] + o["length"], "right")) - 1
        else:
            u = x_ego - (o["x0"] + o["speed"] * stamps)
            inside = np.flatnonzero((u >= 0) & (u <= o["length"]))
            first, last = int(inside[0]), int(inside[-1])
        rows.append((first, last, o["label"], i))
    rows.sort()
    gt = pd.DataFrame({
        "id": pd.Series(np.arange(1, len(rows) + 1), dtype="int64"),
        "first_scan": pd.Series([r[0] for r in rows], dtype="int64"),
        "last_scan": pd.Series([r[1] for r in rows], dtype="int64"),
        "label": pd.Series([r[2] for r in rows], dtype="object"),
    })[list(RUN_GT_COLUMNS)]
    for k, r in enumerate(rows, start=1):
        objects[r[3]]["id"] = k

    any_hit = np.bincount(hit[hit >= 0], minlength=len(objects))
    hidden = sum(1 for i, o in enumerate(objects)
                 if o["label"] is not None and any_hit[i] > 0 and scans_seen[i] < 3)
    clutter = {}
    for i, o in enumerate(objects):
        if o["label"] is None and any_hit[i] > 0:
            clutter[o["kind"]] = clutter.get(o["kind"], 0) + 1
    roll_deg = np.rad2deg(roll)
    info = {
        "generator": "tunnelsense.datasets.make_street_scans",
        "scenario": scenario,
        "seed": seed,
        "n_scans": int(n_scans),
        "n_beams": int(n_beams),
        "scan_rate_hz": p["scan_rate_hz"],
        "speed_kmh_mean": round(float(speed.mean() * 3.6), 3),
        "speed_kmh_min": round(float(speed.min() * 3.6), 3),
        "speed_kmh_max": round(float(speed.max() * 3.6), 3),
        "distance_m": round(float(x_ego[-1] - x_ego[0]), 3),
        "mount_height": p["mount_height"],
        "roll_deg_start": round(float(roll_deg[0]), 4),
        "roll_deg_end": round(float(roll_deg[-1]), 4),
        "roll_deg_mean": round(float(roll_deg.mean()), 4),
        "roll_deg_min": round(float(roll_deg.min()), 4),
        "roll_deg_max": round(float(roll_deg.max()), 4),
        "n_parked": int((gt["label"] == "parked").sum()),
        "n_passing": int((gt["label"] == "passing").sum()),
        "n_vehicles_hidden": int(hidden),
        "clutter_seen": dict(sorted(clutter.items())),
        "vehicles": [
            {"id": objects[r[3]]["id"], "kind": objects[r[3]]["kind"], "label": r[2],
             "where": objects[r[3]].get("where", "lane"),
             "depth_near": round(float(objects[r[3]]["depth_near"]), 3),
             "length": round(float(objects[r[3]]["length"]), 3),
             "height": round(float(max(objects[r[3]].get("top_h", [1.2]))), 3),
             "speed_kmh": round(float(objects[r[3]]["speed"] * 3.6), 2)}
            for r in rows
        ],
        "params": {k: (round(v, 6) if isinstance(v, float) else v) for k, v in p.items()},
    }
    return {
        "ranges": ranges, "stamps": stamps, "geometry": geometry, "gt": gt, "info": info,
        "hit": hit, "roll": roll, "height": height, "objects": objects, "x": x_ego,
        "speed": speed,
    }


def make_street_scans(n_scans=4000, *, scenario="sparse", random_state=None, name=None,
                      **overrides):
    """Simulate a laser street run: a vertical scanner driving past parked vehicles.

    A laser range finder on a measurement vehicle scans the vertical plane
    perpendicular to the street, toward the kerb side, with 0.5 degree beams fanning
    from the road near the vehicle (bottom) upward, about 75 times a second, while the
    vehicle drives at about 40 km/h.  Every scan ray-casts the beams against the road
    (with camber), the kerb and sidewalk, and the cross-sections that the scan plane
    cuts through the objects of the street at that moment:

    * parked cars, vans (taller than the 2 m region of interest) and motorbikes at
      4.3-6.3 m depth, often nose-to-tail with small gaps or touching bumpers, some at
      the region boundaries (near 4.0 m, badly parked; near 6.6 m, half on the
      sidewalk).  Successive scans see a vehicle's cross-section at successive
      positions along its length: bumper, bonnet, cabin (with glass), boot, and the
      wheels with the underbody gap between them;
    * passing vehicles in the lane between (1.5-3.5 m depth) at other speeds, which
      partly hide parked ones;
    * pedestrians (standing at the kerb, walking along the road edge or the sidewalk),
      rubbish bins and bollards; hedges, trees and lamp poles beyond 6.6 m;
    * range noise (1-3 cm), dropouts (NaN; frequent on glass), millimetre steps, and
      8.191 m for every beam whose target lies beyond 8.0 m or nowhere.

    Parameters
    ----------
    n_scans : int, default=4000
        Number of scans (at least 2).
    scenario : {"sparse", "dense", "tilted", "crowded"}, default="sparse"
        ``"sparse"``: sparse parking, light traffic.  ``"dense"``: dense nose-to-tail
        parking, some touching bumpers, more traffic.  ``"tilted"``: the sensor has an
        unknown roll of 2-4 degrees (either way) that drifts by about 1 degree along the
        run, mounted at 2.4 m.  ``"crowded"``: dense parking, heavy traffic, vans,
        motorbikes, cars at the region boundaries, many pedestrians, bins and bollards,
        and an unknown drifting roll of 1-2 degrees.
    random_state : int, RandomState instance, Generator or None, default=None
        Seed.  The same int gives byte-identical output; the seed used is recorded in
        ``info["seed"]`` (pass it back to reproduce a run made with ``None``).
    name : str, default=None
        Name of the run; ``"street-<scenario>-<seed>"`` when None.
    **overrides : float
        Physical parameters replacing the scenario's values: ``speed_kmh`` (mean ego
        speed), ``speed_variation_kmh`` (amplitude of its slow changes),
        ``scan_rate_hz``, ``mount_height`` (m, true and nominal), ``roll_deg`` (the
        true sensor roll at the start of the run; positive turns the beams up),
        ``roll_drift_deg`` (amplitude of its drift), ``angle_min_deg``,
        ``angle_max_deg``, ``angle_increment_deg``, ``range_noise`` (m, at 0 m),
        ``range_noise_per_m``, ``dropout_rate``, ``kerb_depth`` (m), ``kerb_height``,
        ``camber_drop`` (m the road falls from the vehicle to the kerb),
        ``parked_cluster_size`` (mean cars nose-to-tail), ``parked_gap_m`` (mean free
        kerb between clusters), ``touching_fraction``, ``van_fraction``,
        ``motorbike_fraction``, ``boundary_fraction``, ``passing_per_min``,
        ``passing_van_fraction``, ``passing_motorbike_fraction``,
        ``pedestrians_per_100m``, ``bins_per_100m``, ``bollard_rows_per_100m``,
        ``hedge_fraction``, ``trees_per_100m``.

    Returns
    -------
    run : Run
        Scans with the nominal :class:`~tunnelsense.LaserGeometry` (the true roll is
        not in it), ground truth ``id,first_scan,last_scan,label`` with one row per
        parked or passing vehicle (motorbikes included) that the scanner sees
        between 0.1 m and 2 m above the road in at least 3 scans, over the scans
        during which its body crosses the scan plane, and ``info``
        (scenario, seed, speeds, true roll summary, per-vehicle facts, parameters).

    Examples
    --------
    >>> from tunnelsense.datasets import make_street_scans
    >>> run = make_street_scans(750, scenario="dense", random_state=0)
    >>> len(run), run.scans[0].ranges.shape
    (750, (241,))
    >>> sorted(set(run.gt["label"]))
    ['parked', 'passing']
    >>> run.geometry.range_max
    8.191
    """
    sim = _simulate(n_scans, scenario, random_state, **overrides)
    if name is None:
        name = f"street-{scenario}-{sim['info']['seed']}"
    elif not isinstance(name, str) or not name:
        raise TypeError(f"name must be a non-empty str or None; got {name!r}")
    return Run.from_arrays(name, sim["ranges"], sim["stamps"], sim["geometry"], sim["gt"],
                           info=sim["info"])
