"""The simulated tunnel scene: cross-section, the ego vehicle's motion, traffic, and
where the indicators stand (in metres).  The parameters, their defaults and the
scenarios are in :mod:`tunnelsense.datasets._tunnel_params`."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["INDICATOR", "LAMP", "SHADOW", "TUNNEL_SCENARIOS", "VEHICLE"]

from tunnelsense.datasets._scenarios import TUNNEL_SCENARIOS  # noqa: E402

INDICATOR, LAMP, VEHICLE, SHADOW = 1, 2, 3, 4

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
    if p["pitch_deg"]:
        pitch = pitch + math.radians(p["pitch_deg"])
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
    duration = t[-1] + 1.0 / p["frame_rate_hz"]
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
