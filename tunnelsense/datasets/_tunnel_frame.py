"""Parts of the tunnel simulator's :func:`~tunnelsense.datasets.make_tunnel_tour`:
the scene rendered frame by frame, the sensor's noise, the ground-truth rows of a
frame and the tour's info."""

from __future__ import annotations

import cv2
import numpy as np

from tunnelsense.datasets._tunnel_camera import _at
from tunnelsense.datasets._tunnel_render import (
    _draw_indicator,
    _draw_lamp,
    _draw_panel,
    _draw_shadow,
    _draw_vehicle,
    _lamp_boxes,
)
from tunnelsense.datasets._tunnel_scene import (
    _MIN_BOX_PX,
    _Z_FAR,
    _Z_NEAR,
    INDICATOR,
    LAMP,
    SHADOW,
    VEHICLE,
)

_PANEL = 0  # a lit panel's class while drawing (it has no ground truth)


class _Scene:
    """The tour's scene (camera, tunnel, signs, lamps, panels, traffic, the ego
    pose per frame), rendered frame by frame as radiance (``scene(f)``)."""

    def __init__(self, *, cam, p, bg, lat, hgt, pitch, yaw, s_ego, W, H, warming,
                 indicators, lamp_spacing, lamp_s, lamp_look, lamp_ids, panel_s,
                 panel_look, panel_side, vehicles, ind_look, ind_ids, veh_ids,
                 shadow_ids):
        # keyword-only: 24 parts, several of the same type, are easily swapped
        # by position; __call__ unpacks them in this order
        self.parts = (cam, p, bg, lat, hgt, pitch, yaw, s_ego, W, H, warming,
                      indicators, lamp_spacing, lamp_s, lamp_look, lamp_ids,
                      panel_s, panel_look, panel_side, vehicles, ind_look, ind_ids,
                      veh_ids, shadow_ids)

    def __call__(self, f, q=None):
        """The radiance image and drawn objects at frame ``f``; ``q`` (a fractional
        frame index) renders the scene at that earlier instant instead (the ego
        motion and traffic interpolated linearly), for the bolometer's lag."""
        (cam, p, bg, lat, hgt, pitch, yaw, s_ego, W, H, warming, indicators,
         lamp_spacing, lamp_s, lamp_look, lamp_ids, panel_s, panel_look, panel_side,
         vehicles, ind_look, ind_ids, veh_ids, shadow_ids) = self.parts
        if q is None:
            pose = (float(lat[f]), float(hgt[f]), float(pitch[f]))
            pose += () if yaw is None else (float(yaw[f]),)
            sc = float(s_ego[f])
        else:
            pose = (_at(lat, q), _at(hgt, q), _at(pitch, q))
            pose += () if yaw is None else (_at(yaw, q),)
            sc = _at(s_ego, q)
        half = bg.render(sc, pose)
        img = cv2.resize(half, (W, H), interpolation=cv2.INTER_LINEAR)
        if warming:  # lining and road follow the air; signs, lamps, engines do not
            img += np.float32(warming)
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
        lo, hi = np.searchsorted(panel_s, [sc + _Z_NEAR, sc + _Z_FAR])
        for k in range(lo, hi):
            todo.append((panel_s[k] - sc, _PANEL, k))
        for k, veh in enumerate(vehicles):
            ds = veh["gap"][f] if q is None else _at(veh["gap"], q)
            if 2.0 < ds < _Z_FAR:
                todo.append((ds, VEHICLE, k))
        todo.sort(key=lambda item: -item[0])  # painter's order: far to near
        for ds, cls, key in todo:
            if cls == _PANEL:  # lit, but no indicator: in no ground truth
                _draw_panel(img, cam, pose, ds, panel_side, panel_look[key])
                continue
            if cls == INDICATOR:
                box = _draw_indicator(img, cam, pose, ds, p, ind_look[key])
                oid = ind_ids[key]
            elif cls == LAMP:
                row, k, gl, ho = key
                box = _draw_lamp(img, gl, ho, lamp_look[k])
                oid = lamp_ids[row, k]
            else:
                veh = vehicles[key]
                if q is not None:  # its lateral position at that instant
                    veh = {**veh, "x": {f: _at(veh["x"], q)}}
                sbox = _draw_shadow(img, cam, pose, veh, f, ds, warming)
                if sbox is not None:
                    drawn.append((sbox[4], SHADOW, shadow_ids[key], sbox, False))
                box = _draw_vehicle(img, cam, pose, veh, f, ds)
                oid = veh_ids[key]
            if box is not None:
                drawn.append((box[4], cls, oid, box, cls == VEHICLE))
        return img, drawn


def _sensor_noise(rng, p, shape, n_frames):
    """The sensor's noise, drawn from the tour's stream ``rng``: a bank of two
    temporal noise images (a random window of one per frame), the fixed-pattern
    noise with a slight vignetting, and each frame's pick ``(image, row, col)``
    in the bank."""
    H, W = shape
    pad = 24
    bank = rng.standard_normal((2, H + pad, W + pad), dtype=np.float32)
    if p["noise_corr_px"] > 0:
        bank = _correlate(bank, p["noise_corr_px"])
    bank *= np.float32(p["noise_sigma"])
    fpn = (
        rng.normal(0, p["fpn_sigma"], W)[None, :]
        + rng.normal(0, p["fpn_sigma"] / 2, (H, W))
    ).astype(np.float32)
    yy, xx = np.mgrid[0:H, 0:W]
    r2 = ((xx - W / 2) / (W / 2)) ** 2 + ((yy - H / 2) / (H / 2)) ** 2
    fpn += (3.0 - 3.0 * r2).astype(np.float32)  # slight vignetting
    noise_pick = rng.integers(0, [2, pad + 1, pad + 1], size=(n_frames, 3))
    return bank, fpn, noise_pick


def _tour_info(scenario, seed, p, cam, speed, distance, indicators, n_ind, passed,
               lamp_spacing, recording):
    """The tour's ``info`` (its ``seqinfo.ini``): the scenario, the seed, the
    camera, the scene and, named only when in use, the sensor and air factors."""
    warming = p["ambient_warming"]
    vertical = p["vertical_curve_radius_m"]
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
        "pitch_deg": float(p["pitch_deg"]),
        "vertical_curve_radius_m": float(vertical),
        "noise_corr_px": float(p["noise_corr_px"]),
        "gain": float(p["gain"]),
        "offset": float(p["offset"]),
        "fpn_sigma": float(p["fpn_sigma"]),
        "indicator_width_m": float(p["indicator_size_m"][0]),
        "indicator_tall_m": float(p["indicator_size_m"][1]),
        "indicator_height_m": float(p["indicator_height_m"]),
    }
    # the sensor and air factors, named only when in use (a default tour's info and
    # its seqinfo.ini are as they were)
    if p["sensor_scale"] != 1.0:
        info["sensor_scale"] = float(p["sensor_scale"])
    if warming:
        info["ambient_warming"] = float(warming)
    for key, default in (("roll_deg", 0.0), ("vignetting", 1.0),
                         ("indicator_side", "left"), ("thermal_time_constant_s", 0.0),
                         ("dropped_frames", 0.0), ("defect_pixels", 0.0),
                         ("dead_columns", 0), ("yaw_deg", 0.0), ("shake_deg", 0.0),
                         ("defocus_px", 0.0), ("response_gamma", 1.0), ("bit_depth", 8),
                         ("panel_spacing_m", None)):
        if p[key] != default:
            info[key] = p[key]
    info.update(recording.info(p))
    return info


def _correlate(bank, sigma_px):
    """White noise made spatially correlated (Gaussian kernel), unit variance kept."""
    import cv2  # noqa: PLC0415

    out = np.empty_like(bank)
    for k in range(len(bank)):
        out[k] = cv2.GaussianBlur(bank[k], (0, 0), float(sigma_px),
                                  borderType=cv2.BORDER_REFLECT)
        out[k] /= max(float(out[k].std()), 1e-6)
    return out


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
