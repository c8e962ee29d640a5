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
    _Background,
    _Camera,
    _lag_samples,
    _roll_box,
    _roll_image,
    _roll_matrix,
    _vignette,
)
from tunnelsense.datasets._tunnel_frame import (
    _gt_rows,
    _Scene,
    _sensor_noise,
    _tour_info,
)
from tunnelsense.datasets._tunnel_params import _resolve_params
from tunnelsense.datasets._tunnel_scene import (
    _Z_FAR,
    INDICATOR,
    TUNNEL_SCENARIOS,
    _ego_motion,
    _indicator_positions,
    _lining_x,
    _make_vehicles,
)
from tunnelsense.datasets._tunnel_sensor import (
    Recording,
    burn_overlay,
    camera_output,
    defect_map,
    panel_layout,
    shake,
)

__all__ = ["TUNNEL_SCENARIOS", "make_tunnel_tour"]

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
        and in no ground truth, so a detection on one is a false alarm);
        ``overlay`` ("none": a mark the camera or recorder burns into every
        frame, "clock": its name and the time in white text at the top left,
        "bar": a grey-scale bar, white to black, at the right edge, half the
        frame high; drawn at the same fractions of any frame size, frozen with
        the picture by a flat-field freeze; in no ground truth).

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
    bank, fpn, noise_pick = _sensor_noise(rng, p, (H, W), n_frames)

    warming = p["ambient_warming"]
    roll = _roll_matrix(p["roll_deg"], (H, W)) if p["roll_deg"] else None
    vignette = _vignette((H, W), p["vignetting"]) if p["vignetting"] < 1.0 else None
    agc = _Agc(fps, p["agc_time_s"]) if p["agc"] else None
    lag = (_lag_samples(p["thermal_time_constant_s"], fps)
           if p["thermal_time_constant_s"] > 0 else None)

    scene = _Scene(cam=cam, p=p, bg=bg, lat=lat, hgt=hgt, pitch=pitch, yaw=yaw,
                   s_ego=s_ego, W=W, H=H, warming=warming, indicators=indicators,
                   lamp_spacing=lamp_spacing, lamp_s=lamp_s, lamp_look=lamp_look,
                   lamp_ids=lamp_ids, panel_s=panel_s, panel_look=panel_look,
                   panel_side=panel_side, vehicles=vehicles, ind_look=ind_look,
                   ind_ids=ind_ids, veh_ids=veh_ids, shadow_ids=shadow_ids)

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
        out = camera_output(img, p["response_gamma"], p["bit_depth"])
        if p["overlay"] != "none":  # a mark burned into the picture
            burn_overlay(out, p["overlay"], f / fps,
                         255.0 * 2 ** max(p["bit_depth"] - 8, 0))
        images[f] = out
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
    info = _tour_info(scenario, seed, p, cam, speed, distance, indicators, n_ind,
                      passed, lamp_spacing, recording)
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
