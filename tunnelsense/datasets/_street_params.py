"""Physical parameters of the simulated street: defaults, bounds, scenarios, draws.

Every factor of :func:`~tunnelsense.datasets.make_street_scans` is a keyword with a
default, a lower and an upper bound; a scenario replaces some defaults, and may leave
some to be drawn at random per run (``_DRAWN``).  The defaults keep the older
scenarios byte for byte.
"""

from __future__ import annotations

import math
import numbers

__all__ = ["OPTIONAL_PARAMS", "STREET_SCENARIOS", "resolve_params"]

#: Names of the street scenarios of :func:`make_street_scans`.
from tunnelsense.datasets._scenarios import STREET_SCENARIOS  # noqa: E402

# Physical parameters (the documented ``**overrides``): default, lower and upper bound.
# ``None`` as a scenario value means "drawn at random for every run".
_PARAMS = {
    "speed_kmh": (40.0, 5.0, 120.0),
    "speed_variation_kmh": (3.0, 0.0, 15.0),
    "stops_per_min": (0.0, 0.0, 10.0),
    "stop_duration_s": (15.0, 0.0, 120.0),
    "scan_rate_hz": (75.0, 1.0, 1000.0),
    "mount_height": (2.0, 0.5, 4.0),
    "roll_deg": (0.0, -15.0, 15.0),
    "roll_drift_deg": (0.0, 0.0, 10.0),
    "pitch_deg": (0.0, -10.0, 10.0),
    "pitch_drift_deg": (0.0, 0.0, 5.0),
    "angle_min_deg": (-80.0, -89.0, 0.0),
    "angle_max_deg": (40.0, 0.0, 89.0),
    "angle_increment_deg": (0.5, 0.05, 5.0),
    "range_noise": (0.01, 0.0, 0.2),
    "range_noise_per_m": (0.0025, 0.0, 0.05),
    "dropout_rate": (0.003, 0.0, 0.5),
    "rain_echo_rate": (0.0, 0.0, 0.2),
    "kerb_depth": (6.45, 5.0, 7.5),
    "kerb_height": (0.13, 0.0, 0.3),
    "camber_drop": (0.04, 0.0, 0.1),
    "cross_fall": (0.0, 0.0, 0.06),
    "parked_cluster_size": (1.6, 1.0, 50.0),
    "parked_gap_m": (25.0, 0.5, 1000.0),
    "touching_fraction": (0.0, 0.0, 1.0),
    "van_fraction": (0.1, 0.0, 1.0),
    "motorbike_fraction": (0.05, 0.0, 1.0),
    "motorbike_across_fraction": (0.0, 0.0, 1.0),
    "motorbike_footway_fraction": (0.0, 0.0, 1.0),
    "boundary_fraction": (0.0, 0.0, 1.0),
    "boundary_row_fraction": (0.0, 0.0, 1.0),
    "row_gap_min_m": (0.3, 0.0, 5.0),
    "row_gap_max_m": (1.5, 0.0, 5.0),
    "touching_gap_m": (0.02, 0.0, 0.1),
    "small_car_fraction": (0.0, 0.0, 1.0),
    "van_height_min": (2.05, 1.8, 3.5),
    "van_height_max": (2.6, 1.8, 3.5),
    "passing_per_min": (4.0, 0.0, 60.0),
    "passing_van_fraction": (0.15, 0.0, 1.0),
    "passing_motorbike_fraction": (0.1, 0.0, 1.0),
    "passing_long_fraction": (0.0, 0.0, 1.0),
    "pedestrians_per_100m": (2.0, 0.0, 100.0),
    "bins_per_100m": (0.5, 0.0, 50.0),
    "bollard_rows_per_100m": (0.3, 0.0, 20.0),
    "pedestrian_groups_per_100m": (0.0, 0.0, 50.0),
    "kerb_walkers_per_100m": (0.0, 0.0, 50.0),
    "bin_rows_per_100m": (0.0, 0.0, 50.0),
    "communal_bins_per_100m": (0.0, 0.0, 20.0),
    "hedge_fraction": (0.5, 0.0, 1.0),
    "trees_per_100m": (3.0, 0.0, 30.0),
    # conditions no scenario uses (all off by default; their draws come from streams
    # of their own, so that a run without them stays byte for byte as it was)
    "angled_row_fraction": (0.0, 0.0, 1.0),
    "bay_angle_deg": (90.0, 30.0, 90.0),
    "caravan_fraction": (0.0, 0.0, 1.0),
    "wet_road_fraction": (0.0, 0.0, 1.0),
    "wall_fraction": (0.0, 0.0, 1.0),
    "tight_hedge_fraction": (0.0, 0.0, 1.0),
    "bicycles_per_100m": (0.0, 0.0, 50.0),
}

#: Parameters recorded in a run's ``info["params"]`` only when away from their
#: default (the older runs' info stays as it was).
OPTIONAL_PARAMS = ("angled_row_fraction", "bay_angle_deg", "caravan_fraction",
                   "wet_road_fraction", "wall_fraction", "tight_hedge_fraction",
                   "bicycles_per_100m")

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
    "hard": {
        "mount_height": 2.4,
        "roll_deg": 1.5,  # drifting slowly between about 0 and 3 degrees
        "roll_drift_deg": 1.5,
        "cross_fall": None,  # 2-3 % towards the kerb
        "parked_cluster_size": 5.0,
        "parked_gap_m": 10.0,
        "row_gap_min_m": 0.05,
        "row_gap_max_m": 0.3,
        "touching_fraction": 0.25,
        "touching_gap_m": 0.0,
        "small_car_fraction": 0.2,
        "van_fraction": 0.2,
        "van_height_min": 2.0,
        "van_height_max": 2.3,
        "motorbike_fraction": 0.1,
        "boundary_row_fraction": 0.3,
        "pedestrians_per_100m": 6.0,
        "pedestrian_groups_per_100m": 2.0,
        "kerb_walkers_per_100m": 2.0,
        "bin_rows_per_100m": 1.5,
        "communal_bins_per_100m": 0.5,
        "bollard_rows_per_100m": 1.0,
    },
    "randomized": {},  # every factor of _DRAWN["randomized"] drawn per run
}

# factors drawn at random per run (uniform in [lo, hi]) by scenario
_DRAWN = {
    "hard": {"cross_fall": (0.02, 0.03)},
    "randomized": {
        "speed_kmh": (32.0, 48.0),
        "mount_height": (1.8, 2.6),
        "roll_deg": (-3.0, 3.0),
        "roll_drift_deg": (0.0, 1.5),
        "pitch_deg": (-2.0, 2.0),
        "pitch_drift_deg": (0.0, 1.0),
        "cross_fall": (0.0, 0.03),
        "angle_increment_deg": (0.25, 0.75),
        "parked_cluster_size": (1.5, 8.0),
        "parked_gap_m": (5.0, 25.0),
        "row_gap_min_m": (0.0, 0.3),
        "row_gap_max_m": (0.3, 1.5),
        "touching_fraction": (0.0, 0.3),
        "small_car_fraction": (0.0, 0.3),
        "van_fraction": (0.0, 0.3),
        "motorbike_fraction": (0.0, 0.15),
        "boundary_row_fraction": (0.0, 0.3),
        "passing_per_min": (0.0, 12.0),
        "pedestrians_per_100m": (0.0, 8.0),
        "pedestrian_groups_per_100m": (0.0, 2.0),
        "kerb_walkers_per_100m": (0.0, 2.0),
        "bins_per_100m": (0.0, 2.0),
        "bin_rows_per_100m": (0.0, 1.5),
        "communal_bins_per_100m": (0.0, 0.5),
        "bollard_rows_per_100m": (0.0, 1.0),
        "rain_echo_rate": (0.0, 0.03),
        "motorbike_across_fraction": (0.0, 0.6),
        "motorbike_footway_fraction": (0.0, 0.5),
        "passing_long_fraction": (0.0, 0.2),
    },
}

# range of a random unknown roll per scenario (deg, either sign)
_RANDOM_ROLL = {"tilted": (2.0, 4.0), "crowded": (1.0, 2.0)}



# --------------------------------------------------------------------------------------
# Parameters
# --------------------------------------------------------------------------------------
def resolve_params(scenario, overrides, rng):
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
    for key, (lo, hi) in _DRAWN.get(scenario, {}).items():
        value = float(rng.uniform(lo, hi))  # drawn even when overridden
        if key not in overrides:
            params[key] = value
    for key, value in params.items():
        _, vlo, vhi = _PARAMS[key]
        if not (math.isfinite(value) and vlo <= value <= vhi):
            raise ValueError(f"{key} must lie in [{vlo}, {vhi}]; got {value!r}")
    if params["row_gap_max_m"] < params["row_gap_min_m"]:
        raise ValueError("row_gap_max_m must be at least row_gap_min_m")
    if params["van_height_max"] < params["van_height_min"]:
        raise ValueError("van_height_max must be at least van_height_min")
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
