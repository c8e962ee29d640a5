"""Positioning in a tunnel: dead reckoning reset at each detected indicator.

Where GPS fails, a vehicle integrates its odometry; each emergency-telephone
indicator the far-infrared detector finds stands at a surveyed chainage and resets
the accumulated error (Wang et al., 2013, section 1).  :class:`TunnelPositioner`
fuses the two with a 1-D Kalman filter over distance, from a given start or, without
one, by locking on to the map from the spacing of the indicators passed.
"""

from tunnelsense._lazy import attach

_NAMES = {
    "dead_reckoning": "_evaluate",
    "errors_table": "_evaluate",
    "format_errors": "_evaluate",
    "position_errors": "_evaluate",
    "forward": "_filter",
    "rts_smooth": "_filter",
    "detection_table": "_fixes",
    "estimate_pass": "_fixes",
    "scale_from_slope": "_fixes",
    "locate_online": "_online",
    "observed_side": "_side",
    "plot_positioning": "_plot",
    "TunnelPositioner": "_positioner",
    "evaluate_positions": "_run",
    "position_tour": "_run",
    "tour_tables": "_run",
    "FIX_COLUMNS": "_stream",
    "Position": "_stream",
    "PositionStream": "_stream",
    "ESTIMATE_COLUMNS": "_tables",
    "check_indicator_map": "_tables",
    "check_odometry": "_tables",
    "check_positions": "_tables",
    "read_indicator_map": "_tables",
    "read_odometry": "_tables",
    "read_positions": "_tables",
}

__all__ = [
    "ESTIMATE_COLUMNS",
    "FIX_COLUMNS",
    "Position",
    "PositionStream",
    "TunnelPositioner",
    "check_indicator_map",
    "check_odometry",
    "check_positions",
    "dead_reckoning",
    "detection_table",
    "errors_table",
    "evaluate_positions",
    "estimate_pass",
    "format_errors",
    "forward",
    "locate_online",
    "observed_side",
    "plot_positioning",
    "position_errors",
    "position_tour",
    "read_indicator_map",
    "read_odometry",
    "read_positions",
    "rts_smooth",
    "scale_from_slope",
    "tour_tables",
]

__getattr__, __dir__, _ = attach(__name__, _NAMES, __all__)
