"""Simulators of labelled data: far-infrared tunnel tours and laser street runs.

No public data of either kind exists, so tunnelsense makes its own, grounded in the
geometry of the sensors and the scenes the papers describe.
"""

from tunnelsense._lazy import attach

_NAMES = {
    "TourKinematics": "_odometry",
    "make_tunnel_kinematics": "_odometry",
    "make_tunnel_odometry": "_odometry",
    "simulate_indicator_detections": "_indicator_detections",
    "simulate_to_folder": "_simulate",
    "STREET_SCENARIOS": "_street",
    "make_street_scans": "_street",
    "TUNNEL_SCENARIOS": "_tunnel",
    "make_tunnel_tour": "_tunnel",
}

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

__getattr__, __dir__, _ = attach(__name__, _NAMES, __all__)
