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

from tunnelsense._records import RUN_GT_COLUMNS, LaserGeometry, Run, ScanSequence
from tunnelsense.datasets._street_params import (
    _PARAMS,
    OPTIONAL_PARAMS,
    STREET_SCENARIOS,
    resolve_params,
)
from tunnelsense.datasets._street_render import ray_cast
from tunnelsense.datasets._street_scene import layout, passing
from tunnelsense.datasets._street_sensor import (
    MAX_RANGE,
    ego,
    measure,
    rain,
    sensor_pitch,
    wet_road,
)

__all__ = ["STREET_SCENARIOS", "make_street_scans"]

#: The simulator's kinds of vehicle as vehicle classes
#: (:data:`~tunnelsense.street.VEHICLE_CLASSES`): a small car is a car, a long low
#: lorry or trailer a van.
KIND_CLASS = {"car": "car", "small": "car", "van": "van", "long": "van",
              "caravan": "van", "motorbike": "motorbike"}


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
    ``HIT_NONE``), ``roll`` and ``pitch`` (rad), ``height`` (m), ``objects`` (dicts, by index).
    """
    _check_args(n_scans, scenario)
    seed = _seed(random_state)
    rng = np.random.default_rng(seed)
    p = resolve_params(scenario, overrides, rng)
    stamps, speed, x_ego, roll, height = ego(p, n_scans, rng, seed)
    pitch = sensor_pitch(p, stamps, seed)
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
    aux = np.random.default_rng([seed, 4])  # angled bays, walls: a stream of their own
    objects = layout(p, x_ego[0] - 15.0, x_ego[-1] + 15.0, t_of_x, rng, aux)
    for o in passing(p, stamps, v0, rng):
        # place it so that its middle crosses the plane at its cross time
        tc = o.pop("cross_time")
        xc = float(np.interp(tc, stamps, x_ego, left=x_ego[0] + v0 * (tc - stamps[0]),
                             right=x_ego[-1] + v0 * (tc - stamps[-1])))
        o["x0"] = xc - o["length"] / 2 - o["speed"] * tc
        objects.append(o)
    if p["cross_fall"]:  # everything stands on the road (or sidewalk) where it is
        for o in objects:
            centre = o["depth_near"] + o["width"] / 2
            o["base"] -= p["cross_fall"] * min(centre, p["kerb_depth"])
    rng_true, hit, material = ray_cast(p, objects, stamps, x_ego, roll, height, angles,
                                       pitch)
    theta = angles[None, :] + roll[:, None]
    ranges = measure(p, rng_true, hit, material, np.cos(theta), np.sin(theta), rng)
    ranges, hit = wet_road(p, ranges, hit, seed)
    ranges, hit = rain(p, ranges, hit, seed)

    # ground truth: vehicles the scanner sees (in at least 3 scans, between 0.1 m and
    # 2 m above the road), over the scans their body crosses the plane
    with np.errstate(invalid="ignore"):
        z = height[:, None] + ranges * np.sin(theta) * np.cos(pitch)[:, None]
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
    gt["vehicle_class"] = pd.Series([KIND_CLASS[objects[r[3]]["kind"]] for r in rows],
                                    dtype="object")
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
        "params": {k: (round(v, 6) if isinstance(v, float) else v) for k, v in p.items()
                   if k not in OPTIONAL_PARAMS or v != _PARAMS[k][0]},
    }
    if pitch.any():  # (the older scenarios' info stays as it was)
        info["pitch_deg_min"] = round(float(np.rad2deg(pitch.min())), 4)
        info["pitch_deg_max"] = round(float(np.rad2deg(pitch.max())), 4)
    return {
        "ranges": ranges, "stamps": stamps, "geometry": geometry, "gt": gt, "info": info,
        "hit": hit, "roll": roll, "pitch": pitch, "height": height, "objects": objects, "x": x_ego,
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
      8.191 m for every beam whose target lies beyond 8.0 m or nowhere; with
      ``rain_echo_rate``, echoes from raindrops and spray 0.3-3 m away on single
      beams of single scans.

    Parameters
    ----------
    n_scans : int, default=4000
        Number of scans (at least 2).
    scenario : {"sparse", "dense", "tilted", "crowded", "hard", "randomized"}, \
            default="sparse"
        ``"sparse"``: sparse parking, light traffic.  ``"dense"``: dense nose-to-tail
        parking, some touching bumpers, more traffic.  ``"tilted"``: the sensor has an
        unknown roll of 2-4 degrees (either way) that drifts by about 1 degree along the
        run, mounted at 2.4 m.  ``"crowded"``: dense parking, heavy traffic, vans,
        motorbikes, cars at the region boundaries, many pedestrians, bins and bollards,
        and an unknown drifting roll of 1-2 degrees.  ``"hard"``: mount 2.4 m, roll
        drifting between about 0 and 3 degrees over a 2-3 % cross-fall, rows of 2-8
        with 0.05-0.3 m gaps and 1 in 4 touching, small cars, vans 2.0-2.3 m high,
        motorbikes, whole rows at 4.0-4.3 m or 6.2-6.6 m, groups of pedestrians,
        walkers along the rows, rows of wheelie bins, communal bins, bollards.
        ``"randomized"``: the physical factors drawn uniformly per run.
    random_state : int, RandomState instance, Generator or None, default=None
        Seed.  The same int gives byte-identical output; the seed used is recorded in
        ``info["seed"]`` (pass it back to reproduce a run made with ``None``).
    name : str, default=None
        Name of the run; ``"street-<scenario>-<seed>"`` when None.
    **overrides : float
        Physical parameters replacing the scenario's values: ``speed_kmh`` (mean ego
        speed), ``speed_variation_kmh`` (amplitude of its slow changes),
        ``stops_per_min`` (stop-and-go: one stop in every ``60 / stops_per_min`` s,
        braking at 1.5-3 m/s2 to a standstill, standing ``stop_duration_s`` x
        0.5-1.5, then accelerating at 1-2 m/s2; 0, the default, never stops),
        ``scan_rate_hz``, ``mount_height`` (m, true and nominal), ``roll_deg`` (the
        true sensor roll at the start of the run; positive turns the beams up),
        ``roll_drift_deg`` (amplitude of its drift), ``pitch_deg`` (the true pitch,
        the scan plane leaning along the street; positive leans it forward) and
        ``pitch_drift_deg`` (amplitude of its slow drift), ``angle_min_deg``,
        ``angle_max_deg``, ``angle_increment_deg``, ``range_noise`` (m, at 0 m),
        ``range_noise_per_m``, ``dropout_rate``, ``rain_echo_rate`` (of the beams,
        an echo from a raindrop 0.3-3 m away, nearer than the target),
        ``kerb_depth`` (m), ``kerb_height``,
        ``camber_drop`` (m the road falls from the vehicle to the kerb),
        ``cross_fall`` (plane slope of the road towards the kerb, m per m; 0.02 is
        2 %), ``parked_cluster_size`` (mean cars nose-to-tail), ``parked_gap_m``
        (mean free kerb between clusters), ``row_gap_min_m`` and ``row_gap_max_m``
        (m between vehicles of a row), ``touching_fraction`` (of the gaps in a row),
        ``touching_gap_m`` (largest gap of touching bumpers, m), ``van_fraction``,
        ``van_height_min`` and ``van_height_max`` (m), ``small_car_fraction`` (city
        cars 2.5-3.4 m long), ``motorbike_fraction``, ``motorbike_across_fraction``
        (of the parked motorbikes, at right angles to the kerb: 1.9-2.2 m deep
        across the street, 0.7-0.85 m along it, a screen at 1.1-1.35 m),
        ``motorbike_footway_fraction`` (of those, with the rear half on the
        footway behind the kerb step), ``boundary_fraction`` (of the
        vehicles, near a region boundary), ``boundary_row_fraction`` (of the rows,
        whole at 4.0-4.3 m or 6.2-6.6 m), ``passing_per_min``,
        ``passing_van_fraction``, ``passing_motorbike_fraction``,
        ``passing_long_fraction`` (flatbed lorries and car transporters, 8-12 m long,
        1.4-1.6 m high),
        ``pedestrians_per_100m``, ``pedestrian_groups_per_100m`` (2-5 people),
        ``kerb_walkers_per_100m`` (walking along the parked rows at 4.0-4.3 m),
        ``bins_per_100m``, ``bin_rows_per_100m`` (1-4 wheelie bins),
        ``communal_bins_per_100m``, ``bollard_rows_per_100m``, ``hedge_fraction``,
        ``trees_per_100m``.  The beam count follows from ``angle_min_deg``,
        ``angle_max_deg`` and ``angle_increment_deg``.

    Returns
    -------
    run : Run
        Scans with the nominal :class:`~tunnelsense.LaserGeometry` (the true roll is
        not in it), ground truth ``id,first_scan,last_scan,label,vehicle_class``
        (``car``, ``van`` or ``motorbike``: :data:`KIND_CLASS` of the vehicle's
        kind) with one row per
        parked or passing vehicle (motorbikes included) that the scanner sees
        between 0.1 m and 2 m above the road in at least 3 scans, over the scans
        during which its body crosses the scan plane, and ``info``
        (scenario, seed, speeds, true roll summary, per-vehicle facts, parameters).
        Every scan carries the ego speed (m/s) at its time in its payload
        (``"speed"``), as a ROS bag's odometry gives it.

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
    run = Run.from_arrays(name, sim["ranges"], sim["stamps"], sim["geometry"], sim["gt"],
                          info=sim["info"])
    # every scan carries the ego speed (m/s) there, as a bag's odometry gives it
    return Run(run.name, ScanSequence([r.evolve(speed=float(v)) for r, v in
                                       zip(run.scans, sim["speed"], strict=True)]),
               run.gt, run.info)
