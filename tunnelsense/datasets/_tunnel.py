"""Far-infrared tunnel tours: a calibrated pinhole camera driving through a tunnel.

The scene is built in metres and projected through the camera; see
:func:`make_tunnel_tour` for the physical model. Section 1, 3 and 4 of Wang et al. (2013),
*Detection of emergency telephone indicators in a tunnel environment*, describe what the
images look like: emergency-telephone indicators every 200 m, ordinary lamps that look like
indicators at some range, other vehicles and their warm "shadows" whose intensities are
close to the indicators'.
"""

from __future__ import annotations

import math
from numbers import Integral

import cv2
import numpy as np
import pandas as pd
from sklearn.utils import check_random_state

from tunnelsense._records import MOT_GT_COLUMNS, Tour
from tunnelsense.datasets._odometry import TourKinematics, with_kinematics
from tunnelsense.datasets._tunnel_camera import (
    _Agc,
    _at,
    _Background,
    _Camera,
    _lag_samples,
    _roll_box,
    _roll_image,
    _roll_matrix,
    _vignette,
)
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
    TUNNEL_SCENARIOS,
    VEHICLE,
    _ego_motion,
    _indicator_positions,
    _lining_x,
    _make_vehicles,
    _resolve_params,
)
from tunnelsense.datasets._tunnel_sensor import (
    Recording,
    camera_output,
    defect_map,
    panel_layout,
    shake,
)

__all__ = ["TUNNEL_SCENARIOS", "make_tunnel_tour"]

_PANEL = 0  # a lit panel's class while drawing (it has no ground truth)


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
    scenario : {"light", "heavy", "curved", "randomized"}, default="light"
        ``"light"``: light traffic. ``"heavy"``: heavy traffic with many trucks.
        ``"curved"``: another camera (focal length 620 px, mounted 1.35 m high, noise
        sigma 4) in a tunnel curving with a 1500 m radius.  ``"randomized"``: the
        camera, sensor, tunnel, signs, speed and traffic drawn uniformly from
        these ranges (focal length 550-900 px, mount 1.2-2.4 m, pitch +-1.5 deg,
        noise sigma 1.5-6 with correlation 0-1.5 px, gain 0.85-1.2, offset +-10, column
        fixed-pattern sigma 0.3-1.5, straight with probability 0.4 else a radius
        of 800-4000 m curving either way, lamps every 8-20 m, signs 0.4-0.6 m x
        0.8-1.2 m at 2.2-3.5 m, speeds from 50-90 km/h up to 10-40 km/h more,
        2-25 vehicles per km, 0-50 % trucks, a change of grade with probability
        0.5: vertical radius 3-30 km, sag or crest; and, each with probability 0.5,
        a 320x240 sensor of the same field of view, warm air of 0-40 grey levels and
        automatic gain control); the draw depends on the seed only and
        ``**overrides`` replace drawn values.
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
        ((480, 640)); ``pitch_deg`` (0, static camera pitch in degrees, up
        positive); ``noise_corr_px`` (0: white; else the sigma in pixels of the
        Gaussian kernel that correlates the temporal noise, whose standard
        deviation stays ``noise_sigma``); ``gain`` (1) and ``offset`` (0, grey
        levels), applied to the scene before the noise: ``gain * I + offset``;
        ``fpn_sigma`` (0.8 grey levels: the column fixed-pattern noise; a
        per-pixel part of half that is added); ``indicator_size_m`` ((0.45, 1.0),
        the sign's width and height in metres); ``vertical_curve_radius_m`` (inf:
        a constant grade, which changes nothing in the image as the camera tilts
        with the road; signed: > 0 a sag, the road ahead rising by ``s^2 / 2R`` at
        ``s`` metres, < 0 a crest; at least 500 m); ``sensor_scale`` (1: image size
        and focal length times this, the same field of view: 0.5 gives the
        640x480 scene on a 320x240 sensor); ``ambient_warming`` (0 grey levels:
        warmer air raises the lining and the road, and the warm road patches behind
        vehicles, by this; lit signs, lamps and engines keep their level, so about
        37 halves a sign's contrast to the wall); ``agc`` (False: automatic gain
        control, mapping each frame's 1st and 99.5th percentiles to grey levels 92
        and 240 with time constant ``agc_time_s``, 0.5 s, so a near lamp or a hot
        truck lowers the gain of every pixel; ``info`` then holds
        ``agc_gain_min`` and ``agc_gain_max``); ``roll_deg`` (0: the camera
        rolled about its optical axis, the image turned this many degrees
        counter-clockwise about its centre, boxes the hulls of the turned ones);
        ``frame_rate_hz`` (30); ``vignetting`` (1: the lens's response at the
        image corners, falling with the squared distance from the centre, applied
        to the radiance before the gain); ``indicator_side`` ("left": the wall the
        signs stand on, "right" for the other tube or left-hand traffic);
        ``thermal_time_constant_s`` (0: none; a microbolometer's pixel follows
        the radiance with a time constant of about 8-12 ms, so a frame is the
        radiance of the instants before it weighted by ``exp(-age / tau)``, which
        smears a fast near object along its path; rendered as sub-frame samples,
        see :func:`_lag_samples`; the ground truth is the object at the frame's
        instant); ``nuc_interval_s`` (None: the camera's flat-field correction
        shutter closes every ``(low, high)`` seconds, the intervals drawn
        uniformly, the first within the first interval, and the output repeats
        the last picture before it closed for ``nuc_freeze_s`` ((0.3, 0.5))
        seconds: identical frames, whose ground truth is that picture's);
        ``dropped_frames`` (0: the fraction of frames the recorder loses, each
        independently; the frames kept keep their numbers, the camera's frame
        counter, so the tour's frame numbers have gaps; ``frame_numbers``
        ("counter") set to "sequential" numbers them 1, 2, 3, ... as a recorder
        counting what it writes does, and the time of a lost frame is lost);
        ``defect_pixels`` (0:
        the fraction of pixels stuck at the same level in every frame, a third
        at 255, a third at 0, a third at a level of their own) and
        ``dead_columns`` (0: whole columns reading 0).  These sensor and
        recorder artefacts draw from random streams of their own and are
        applied to the camera's output.  ``yaw_deg`` (0: the camera pointing
        this many degrees to the right of the road's direction, left
        negative; the view turned about the vertical axis); ``shake_deg`` (0:
        vibration, the camera's pitch and yaw jittering by a normal of this
        sigma from frame to frame, from a random stream of its own);
        ``defocus_px`` (0: an out-of-focus lens, the radiance blurred by a
        Gaussian of this sigma in pixels before the sensor's noise);
        ``response_gamma`` (1: the camera's output curve, the grey levels
        written as ``255 (I / 255) ** gamma``, a non-affine response);
        ``bit_depth`` (8: uint8 grey levels; 9-16: uint16 counts, ``2 **
        (bit_depth - 8)`` per grey level, as cameras recording 14-bit counts
        write them); ``panel_spacing_m`` (None: lit panels, emergency-exit and
        escape-route signs 0.8 m wide x 0.4 m tall centred 2.0 m high on the
        signs' wall, lit from inside to about the indicators' levels, every this
        many metres from a random stream of their own; they are no indicators
        and in no ground truth, so a detection on one is a false alarm).

    Returns
    -------
    tour : Tour
        uint8 frames ``(n_frames, height, width)`` (uint16 for ``bit_depth``
        above 8); ground truth of every object at least
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
    if isinstance(random_state, Integral) and not isinstance(random_state, bool):
        seed = int(random_state)
        if seed < 0:
            raise ValueError(f"random_state must be >= 0; got {random_state!r}")
    else:
        seed = int(check_random_state(random_state).randint(0, 2**31 - 1))
    p = _resolve_params(scenario, overrides, seed)
    rng = np.random.default_rng(seed)
    if name is None:
        name = f"tunnel-{scenario}-{seed}"
    fps = p["frame_rate_hz"]
    H, W = p["image_shape"]
    kappa = 0.0 if math.isinf(p["curve_radius_m"]) else 1.0 / p["curve_radius_m"]
    vertical = p["vertical_curve_radius_m"]
    kappa_v = 0.0 if math.isinf(vertical) else 1.0 / vertical
    cam = _Camera(p["focal_length_px"], (H, W), kappa, kappa_v)

    t, speed, s_ego, lat, hgt, pitch = _ego_motion(rng, n_frames, fps, p)
    yaw = None  # the camera's yaw and vibration (a random stream of their own)
    if p["yaw_deg"] or p["shake_deg"]:
        pitch, yaw = shake(seed, pitch, p["yaw_deg"], p["shake_deg"])
    distance = float(s_ego[-1] + speed[-1] / fps)
    # an indicator's outer edge leaves the image at this depth
    side = -1 if p["indicator_side"] == "left" else 1
    panel_side = side  # lit panels stand on the signs' wall
    x_edge = abs(_lining_x(p["indicator_height_m"], side)) - 0.05
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
    panel_s, panel_look = panel_layout(seed, s_ego[-1], p["panel_spacing_m"])
    bg = _Background(cam, -20.0, s_ego[-1] + _Z_FAR + 20.0, rng)

    # ids: indicators, lamps (two rows), vehicles, shadows
    ind_ids = 1 + np.arange(len(indicators))
    lamp_ids = 1 + len(indicators) + np.arange(2 * len(lamp_s)).reshape(2, -1)
    veh_ids = 1 + len(indicators) + lamp_ids.size + np.arange(len(vehicles))
    shadow_ids = veh_ids + len(vehicles)

    # sensor: temporal noise bank (random windows), fixed-pattern noise, vignetting
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

    warming = p["ambient_warming"]
    roll = _roll_matrix(p["roll_deg"], (H, W)) if p["roll_deg"] else None
    vignette = _vignette((H, W), p["vignetting"]) if p["vignetting"] < 1.0 else None
    agc = _Agc(fps, p["agc_time_s"]) if p["agc"] else None
    lag = (_lag_samples(p["thermal_time_constant_s"], fps)
           if p["thermal_time_constant_s"] > 0 else None)

    def scene(f, q=None):
        """The radiance image and drawn objects at frame ``f``; ``q`` (a fractional
        frame index) renders the scene at that earlier instant instead (the ego
        motion and traffic interpolated linearly), for the bolometer's lag."""
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

    images = np.empty((n_frames, H, W),
                      dtype=np.uint8 if p["bit_depth"] == 8 else np.uint16)
    rows = []
    defects = None
    if p["defect_pixels"] > 0 or p["dead_columns"] > 0:
        defects = defect_map(seed, (H, W), p["defect_pixels"], p["dead_columns"])
    for f in range(n_frames):
        img, drawn = scene(f)
        if lag is not None:  # the bolometer's output: radiance averaged over its past
            lags, weights = lag
            img *= np.float32(weights[0])
            for u, w in zip(lags[1:], weights[1:], strict=True):
                img += np.float32(w) * scene(f, f - u * fps)[0]
        if roll is not None:  # the camera's roll turns the radiance image
            img = _roll_image(img, roll)
            drawn = [(z, c, o, _roll_box(b, roll), occ) for z, c, o, b, occ in drawn]
        if vignette is not None:  # the lens passes less radiance off-axis
            img *= vignette
        if p["defocus_px"] > 0:  # an out-of-focus lens: the radiance blurred
            img = cv2.GaussianBlur(img, (0, 0), p["defocus_px"],
                                   borderType=cv2.BORDER_REFLECT)
        if p["gain"] != 1.0 or p["offset"] != 0.0:
            img *= np.float32(p["gain"])
            img += np.float32(p["offset"])
        j, di, dj = noise_pick[f]
        img += bank[j, di : di + H, dj : dj + W]
        img += fpn
        if agc is not None:
            agc.apply(img)
        if defects is not None:  # stuck pixels and dead columns read the same
            img[defects[0], defects[1]] = defects[2]
            img[:, defects[3]] = 0.0
        images[f] = camera_output(img, p["response_gamma"], p["bit_depth"])
        rows.append(_gt_rows(f + 1, drawn, W, H))
        if progress is not None:
            progress(f + 1, n_frames)

    # the camera's output (flat-field freezes) and what the recorder keeps
    recording = Recording(seed, n_frames, fps, p)
    gt = pd.DataFrame(recording.rows(rows), columns=list(MOT_GT_COLUMNS))
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
    if agc is not None:
        info["agc"] = True
        info["agc_gain_min"] = round(float(min(agc.gains)), 6)
        info["agc_gain_max"] = round(float(max(agc.gains)), 6)
    if recording.plain:
        tour = Tour.from_array(name, images, gt, frame_rate=fps, info=info)
    else:
        tour = Tour(name, recording.frames(name, images), gt, fps, info)
    # where the camera was (positions, odometry, indicator map): no random draws here
    kin = TourKinematics(t, s_ego, speed, kappa, indicators, ind_ids, seed,
                         side=p["indicator_side"])
    return with_kinematics(tour, kin)


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
