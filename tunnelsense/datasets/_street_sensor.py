"""The simulated sensor: ego motion and attitude, and what the scanner measures.

The measurement vehicle drives along the street at a slowly varying speed; the sensor
rolls in the scan plane and bobs in height.  The scanner reports ranges with noise,
dropouts on glass, tyres and foliage, millimetre steps and 8.191 m for no return or
anything beyond 8.0 m.
"""

from __future__ import annotations

import numpy as np

from tunnelsense.datasets._street_shapes import FOLIAGE as _FOLIAGE
from tunnelsense.datasets._street_shapes import GLASS as _GLASS
from tunnelsense.datasets._street_shapes import TYRE as _TYRE

__all__ = ["HIT_KERB", "HIT_NONE", "HIT_RAIN", "HIT_ROAD", "MAX_RANGE", "MEASURE_LIMIT",
           "ego", "measure", "rain", "sensor_pitch", "stop_profile", "wet_road"]

#: Range the paper's sensor reports for no return or an object beyond 8.0 m (m).
MAX_RANGE = 8.191
#: Farthest range the sensor measures (m).
MEASURE_LIMIT = 8.0
# codes of what a beam hit, besides object indices (>= 0)
HIT_NONE, HIT_ROAD, HIT_KERB, HIT_RAIN = -1, -2, -3, -4
#: Nearest and farthest range (m) of an echo from a raindrop or spray.
RAIN_RANGE = (0.3, 3.0)


def _smooth(rng, t, periods, amplitude):
    """A smooth random signal of ``t``: sinusoids of the given periods, peak ~amplitude."""
    out = np.zeros_like(t)
    weights = rng.uniform(0.5, 1.0, len(periods))
    weights /= weights.sum()
    for w, (plo, phi) in zip(weights, periods, strict=True):
        period = rng.uniform(plo, phi)
        out += w * np.sin(2 * np.pi * t / period + rng.uniform(0, 2 * np.pi))
    return amplitude * out


def stop_profile(p, stamps, seed):
    """Ceiling (m/s) on the ego speed per scan from stops: ``stops_per_min`` stops
    (one in every ``60 / stops_per_min`` s, at a random moment of it), each
    decelerating at 1.5-3 m/s2 to a standstill, standing ``stop_duration_s`` x
    0.5-1.5 and accelerating again at 1-2 m/s2 (a light, a bus ahead); +inf without
    stops.  Its own random stream (nothing is drawn without stops, so that the rest of
    a run does not change with them)."""
    ceiling = np.full(len(stamps), np.inf)
    if not p["stops_per_min"]:
        return ceiling
    rng = np.random.default_rng([seed, 3])
    every = 60.0 / p["stops_per_min"]
    t0, t1 = float(stamps[0]), float(stamps[-1])
    start = t0
    while start < t1:
        stand = start + rng.uniform(0.2, 0.8) * every  # the car stands still from here
        duration = p["stop_duration_s"] * rng.uniform(0.5, 1.5)
        decel, accel = rng.uniform(1.5, 3.0), rng.uniform(1.0, 2.0)
        v = np.where(stamps < stand, decel * (stand - stamps),
                     np.where(stamps > stand + duration,
                              accel * (stamps - stand - duration), 0.0))
        ceiling = np.minimum(ceiling, v)
        start += every
    return ceiling


def ego(p, n_scans, rng, seed=0):
    dt = 1.0 / p["scan_rate_hz"]
    stamps = np.arange(n_scans) * dt + rng.uniform(-0.02, 0.02, n_scans) * dt
    v0 = p["speed_kmh"] / 3.6
    speed = v0 + _smooth(rng, stamps, [(8.0, 20.0), (25.0, 60.0)], p["speed_variation_kmh"] / 3.6)
    speed = np.minimum(np.maximum(speed, 0.5 * v0), stop_profile(p, stamps, seed))
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


def sensor_pitch(p, stamps, seed):
    """The sensor's pitch (rad) per scan: ``pitch_deg`` plus a slow drift of about
    ``pitch_drift_deg``; zero without drawing anything when both are 0 (its own
    random stream, so that the rest of a run does not change with it)."""
    if not (p["pitch_deg"] or p["pitch_drift_deg"]):
        return np.zeros(len(stamps))
    rng = np.random.default_rng([seed, 1])
    drift = _smooth(rng, stamps, [(15.0, 40.0), (40.0, 120.0)], p["pitch_drift_deg"])
    return np.deg2rad(p["pitch_deg"] + drift)


def measure(p, rng_true, hit, material, cos, sin, rng):
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


def rain(p, ranges, hit, seed):
    """Echoes from raindrops and spray: a fraction ``rain_echo_rate`` of the beams
    returns from a drop between 0.3 and 3 m, nearer than what it would have hit
    (each drop is one beam of one scan).  Its own random stream (nothing is drawn
    without rain, so that the rest of a run does not change with it); ``hit`` of
    those beams becomes ``HIT_RAIN``."""
    if not p["rain_echo_rate"]:
        return ranges, hit
    rng = np.random.default_rng([seed, 2])
    echo = rng.random(ranges.shape) < p["rain_echo_rate"]
    r = np.round(rng.uniform(*RAIN_RANGE, ranges.shape) * 1000.0) / 1000.0
    with np.errstate(invalid="ignore"):
        echo &= ~(ranges <= r)  # nearer than the target (or the target is missing)
    return np.where(echo, r, ranges), np.where(echo, HIT_RAIN, hit)


def wet_road(p, ranges, hit, seed):
    """A wet road: water on the asphalt reflects the beam away (specular), so a
    fraction ``wet_road_fraction`` of the beams on the road return nothing (8.191 m,
    as for no target), in patches (puddles, wheel tracks) a few beams and scans long.
    Its own random stream (nothing is drawn on a dry road); ``hit`` of those beams
    becomes ``HIT_NONE``."""
    f = p["wet_road_fraction"]
    if not f:
        return ranges, hit
    rng = np.random.default_rng([seed, 5])
    # patches: a coarse random field (every 8 scans x 4 beams) thresholded at f
    n_scans, n_beams = ranges.shape
    coarse = rng.random((n_scans // 8 + 2, n_beams // 4 + 2))
    field = coarse[np.arange(n_scans)[:, None] // 8, np.arange(n_beams)[None, :] // 4]
    lost = (hit == HIT_ROAD) & (field < f)
    return np.where(lost, MAX_RANGE, ranges), np.where(lost, HIT_NONE, hit)
