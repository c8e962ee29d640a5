"""Simulators of labelled data: far-infrared tunnel tours and laser street runs.

No public data of either kind exists, so tunnelsense makes its own, grounded in the
geometry of the sensors and the scenes the papers describe.
"""

from tunnelsense.datasets._odometry import (
    TourKinematics,
    make_tunnel_kinematics,
    make_tunnel_odometry,
    simulate_indicator_detections,
)
from tunnelsense.datasets._simulate import simulate_to_folder
from tunnelsense.datasets._street import STREET_SCENARIOS, make_street_scans
from tunnelsense.datasets._tunnel import TUNNEL_SCENARIOS, make_tunnel_tour

__all__ = [
    "simulate_to_folder",
    "STREET_SCENARIOS",
    "TUNNEL_SCENARIOS",
    "TourKinematics",
    "make_street_scans",
    "make_tunnel_kinematics",
    "make_tunnel_odometry",
    "make_tunnel_tour",
    "simulate_indicator_detections",
]
