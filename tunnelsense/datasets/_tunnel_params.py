"""The simulated tunnel's parameters: the documented physical parameters of
:func:`~tunnelsense.datasets.make_tunnel_tour` and their defaults, the scenarios,
the ranges the ``"randomized"`` scenario draws from, and their checks."""

from __future__ import annotations

import math
from numbers import Integral

import numpy as np

from tunnelsense.datasets._scenarios import TUNNEL_SCENARIOS
from tunnelsense.datasets._tunnel_scene import _CROWN_HEIGHT, _Z_FAR
from tunnelsense.datasets._tunnel_sensor import OVERLAYS

__all__ = ["RANDOMIZED_RANGES"]

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
    "pitch_deg": 0.0,  # static camera pitch, up positive
    "noise_corr_px": 0.0,  # Gaussian sigma (px) of the temporal noise's correlation
    "gain": 1.0,  # sensor gain applied to the scene radiance (grey levels)
    "offset": 0.0,  # sensor offset (grey levels)
    "fpn_sigma": 0.8,  # column fixed-pattern noise (the pixel part is half of it)
    "indicator_size_m": (0.45, 1.0),  # sign width, height
    "vertical_curve_radius_m": math.inf,  # change of grade: > 0 sag, < 0 crest
    "sensor_scale": 1.0,  # image size and focal length times this: same field of view
    "ambient_warming": 0.0,  # grey levels the air-warmed surfaces (lining, road) gain
    "agc": False,  # automatic gain control on the scene's radiance percentiles
    "agc_time_s": 0.5,  # its time constant
    "roll_deg": 0.0,  # camera roll about the optical axis (image turned CCW)
    "frame_rate_hz": 30.0,  # frames per second
    "vignetting": 1.0,  # lens response at the image corners (1: none)
    "indicator_side": "left",  # the wall the signs stand on
    "thermal_time_constant_s": 0.0,  # microbolometer lag (0: none); 8-12 ms typical
    "nuc_interval_s": None,  # flat-field shutter every (low, high) s (None: none)
    "nuc_freeze_s": (0.3, 0.5),  # how long each correction freezes the picture
    "dropped_frames": 0.0,  # fraction of frames the recorder loses (numbers gap)
    "frame_numbers": "counter",  # the camera's counter, or "sequential" (no gaps)
    "defect_pixels": 0.0,  # fraction of pixels stuck (hot, dead, or at a level)
    "dead_columns": 0,  # columns reading 0
    "yaw_deg": 0.0,  # camera pointing, turned to the right positive
    "shake_deg": 0.0,  # per-frame pitch and yaw jitter (vibration), sigma in degrees
    "defocus_px": 0.0,  # Gaussian sigma (px) of an out-of-focus lens's extra blur
    "response_gamma": 1.0,  # output curve 255 (I / 255) ** gamma (1: linear)
    "bit_depth": 8,  # 8: uint8 grey levels; 9-16: uint16 counts, levels x 2**(b-8)
    "panel_spacing_m": None,  # lit exit/escape panels on the signs' wall (None: none)
    "overlay": "none",  # a mark burned into the picture: "none", "clock", "bar"
}

#: Ranges the ``"randomized"`` scenario draws from (uniform; the curve's sign and
#: whether the tunnel is straight are drawn too): plausible FIR cameras, mountings
#: and tunnels.
RANDOMIZED_RANGES = {
    "focal_length_px": (550.0, 900.0),
    "mount_height_m": (1.2, 2.4),
    "pitch_deg": (-1.5, 1.5),
    "noise_sigma": (1.5, 6.0),
    "noise_corr_px": (0.0, 1.5),
    "gain": (0.85, 1.2),
    "offset": (-10.0, 10.0),
    "fpn_sigma": (0.3, 1.5),
    "curve_radius_m": (800.0, 4000.0),  # |radius|; straight with probability 0.4
    "lamp_spacing_m": (8.0, 20.0),
    "indicator_height_m": (2.2, 3.5),
    "indicator_width_m": (0.4, 0.6),
    "indicator_tall_m": (0.8, 1.2),
    "speed_low_kmh": (50.0, 90.0),
    "speed_span_kmh": (10.0, 40.0),
    "traffic_per_km": (2.0, 25.0),
    "truck_fraction": (0.0, 0.5),
    "vertical_curve_radius_m": (3000.0, 30000.0),  # |radius|; none with prob. 0.5
    # the sensor and the air, drawn from a stream of their own (the draws above do
    # not move): each a factor with probability 0.5
    "sensor_scale": (0.5, 1.0),  # a 320x240 sensor of the same field of view, or not
    "ambient_warming": (0.0, 40.0),
    "agc": (False, True),
}


def _randomized(seed):
    """The physical parameters of the ``"randomized"`` scenario for ``seed``."""
    rng = np.random.default_rng([int(seed), 7919])
    r = RANDOMIZED_RANGES
    u = lambda key: float(rng.uniform(*r[key]))  # noqa: E731
    out = {k: u(k) for k in (
        "focal_length_px", "mount_height_m", "pitch_deg", "noise_sigma",
        "noise_corr_px", "gain", "offset", "fpn_sigma", "lamp_spacing_m",
        "indicator_height_m", "traffic_per_km", "truck_fraction",
    )}
    radius = u("curve_radius_m") * (1.0 if rng.random() < 0.5 else -1.0)
    out["curve_radius_m"] = math.inf if rng.random() < 0.4 else radius
    out["indicator_size_m"] = (u("indicator_width_m"), u("indicator_tall_m"))
    low = u("speed_low_kmh")
    out["speed_kmh"] = (low, low + u("speed_span_kmh"))
    vertical = u("vertical_curve_radius_m") * (1.0 if rng.random() < 0.5 else -1.0)
    out["vertical_curve_radius_m"] = math.inf if rng.random() < 0.5 else vertical
    # sensor and air factors: a stream of their own, so the draws above are unchanged
    rng2 = np.random.default_rng([int(seed), 7927])
    scale, warm, agc = rng2.random(3), rng2.uniform(*r["ambient_warming"]), rng2.random()
    out["sensor_scale"] = r["sensor_scale"][0] if scale[0] < 0.5 else 1.0
    out["ambient_warming"] = float(warm) if scale[1] < 0.5 else 0.0
    out["agc"] = bool(agc < 0.5)
    return out

_SCENARIOS = {
    "light": {},
    "heavy": {"traffic_per_km": 22.0, "truck_fraction": 0.45},
    "randomized": {},  # drawn per seed from RANDOMIZED_RANGES
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


def _check_radius(name, value, minimum, straight):
    """``value`` as a float signed radius with ``|value| >= minimum`` (inf: ``straight``)."""
    radius = float(value)
    if math.isnan(radius) or abs(radius) < minimum:
        raise ValueError(
            f"{name} must be a signed radius with |radius| >= {minimum:g} m "
            f"(inf for {straight}); got {value!r}"
        )
    return radius


def _resolve_params(scenario, overrides, seed=0):
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
    if scenario == "randomized":
        p.update(_randomized(seed))
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
    p["curve_radius_m"] = _check_radius(
        "curve_radius_m", p["curve_radius_m"], 200.0, "a straight tunnel"
    )
    p["vertical_curve_radius_m"] = _check_radius(
        "vertical_curve_radius_m", p["vertical_curve_radius_m"], 500.0, "a constant grade"
    )
    p["traffic_per_km"] = _check_range("traffic_per_km", p["traffic_per_km"], 0.0, 60.0)
    p["truck_fraction"] = _check_range("truck_fraction", p["truck_fraction"], 0.0, 1.0)
    p["lateral_jitter_m"] = _check_range(
        "lateral_jitter_m", p["lateral_jitter_m"], 0.0, 1.0
    )
    p["pitch_jitter_deg"] = _check_range(
        "pitch_jitter_deg", p["pitch_jitter_deg"], 0.0, 3.0
    )
    p["pitch_deg"] = _check_range("pitch_deg", p["pitch_deg"], -10.0, 10.0)
    p["noise_corr_px"] = _check_range("noise_corr_px", p["noise_corr_px"], 0.0, 10.0)
    p["gain"] = _check_range("gain", p["gain"], 0.1, 10.0)
    p["offset"] = _check_range("offset", p["offset"], -255.0, 255.0)
    p["fpn_sigma"] = _check_range("fpn_sigma", p["fpn_sigma"], 0.0, 20.0)
    size = p["indicator_size_m"]
    if np.ndim(size) != 1 or len(size) != 2:
        raise ValueError(
            f"indicator_size_m must be a (width, height) pair in metres; got {size!r}"
        )
    p["indicator_size_m"] = (
        _check_range("indicator_size_m", size[0], 0.05, 3.0),
        _check_range("indicator_size_m", size[1], 0.05, 3.0),
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
    p["sensor_scale"] = _check_range("sensor_scale", p["sensor_scale"], 0.1, 4.0)
    if p["sensor_scale"] != 1.0:  # same field of view: fewer, larger pixels
        k = p["sensor_scale"]
        p["image_shape"] = tuple(max(int(round(n * k)), 16) for n in p["image_shape"])
        p["focal_length_px"] = p["focal_length_px"] * k
    p["ambient_warming"] = _check_range(
        "ambient_warming", p["ambient_warming"], -100.0, 150.0
    )
    if not isinstance(p["agc"], bool | np.bool_):
        raise TypeError(f"agc must be True or False; got {p['agc']!r}")
    p["agc"] = bool(p["agc"])
    p["agc_time_s"] = _check_range("agc_time_s", p["agc_time_s"], 0.0, 60.0,
                                   closed_lo=False)
    p["roll_deg"] = _check_range("roll_deg", p["roll_deg"], -30.0, 30.0)
    p["frame_rate_hz"] = _check_range("frame_rate_hz", p["frame_rate_hz"], 1.0, 1000.0)
    p["vignetting"] = _check_range("vignetting", p["vignetting"], 0.1, 1.0)
    p["thermal_time_constant_s"] = _check_range(
        "thermal_time_constant_s", p["thermal_time_constant_s"], 0.0, 0.1
    )
    for key in ("nuc_interval_s", "nuc_freeze_s"):
        value = p[key]
        if value is None and key == "nuc_interval_s":
            continue
        if np.ndim(value) == 0:
            value = (value, value)
        if len(value) != 2:
            raise ValueError(
                f"{key} must be a number or a (low, high) pair of seconds; got {value!r}"
            )
        low = _check_range(key, value[0], 0.0, 3600.0, closed_lo=False)
        p[key] = (low, _check_range(key, value[1], low, 3600.0))
    p["dropped_frames"] = _check_range("dropped_frames", p["dropped_frames"], 0.0, 0.5)
    if p["frame_numbers"] not in ("counter", "sequential"):
        raise ValueError(
            f"frame_numbers must be 'counter' or 'sequential'; got {p['frame_numbers']!r}"
        )
    p["defect_pixels"] = _check_range("defect_pixels", p["defect_pixels"], 0.0, 0.1)
    columns = p["dead_columns"]
    if (isinstance(columns, bool) or not isinstance(columns, Integral)
            or not 0 <= columns <= p["image_shape"][1] // 4):
        raise ValueError(
            f"dead_columns must be an int in [0, {p['image_shape'][1] // 4}]; "
            f"got {columns!r}"
        )
    p["dead_columns"] = int(columns)
    p["yaw_deg"] = _check_range("yaw_deg", p["yaw_deg"], -20.0, 20.0)
    p["shake_deg"] = _check_range("shake_deg", p["shake_deg"], 0.0, 5.0)
    p["defocus_px"] = _check_range("defocus_px", p["defocus_px"], 0.0, 20.0)
    p["response_gamma"] = _check_range("response_gamma", p["response_gamma"], 0.2, 5.0)
    if p["panel_spacing_m"] is not None:
        p["panel_spacing_m"] = _check_range("panel_spacing_m", p["panel_spacing_m"], 5.0)
    depth = p["bit_depth"]
    if isinstance(depth, bool) or not isinstance(depth, Integral) or not 8 <= depth <= 16:
        raise ValueError(f"bit_depth must be an int in [8, 16]; got {depth!r}")
    p["bit_depth"] = int(depth)
    if p["overlay"] not in OVERLAYS:
        raise ValueError(f"overlay must be one of {list(OVERLAYS)}; got {p['overlay']!r}")
    if p["indicator_side"] not in ("left", "right"):
        raise ValueError(
            f"indicator_side must be 'left' or 'right'; got {p['indicator_side']!r}"
        )
    return p
