"""Positioning in a tunnel: dead reckoning reset at each detected indicator.

Where GPS fails, a vehicle integrates its odometry; each emergency-telephone
indicator the far-infrared detector finds stands at a surveyed chainage and resets
the accumulated error (Wang et al., 2013, section 1).  :class:`TunnelPositioner`
fuses the two with a 1-D Kalman filter over distance, from a given start or, without
one, by locking on to the map from the spacing of the indicators passed.
"""

from tunnelsense.positioning._evaluate import (
    dead_reckoning,
    errors_table,
    format_errors,
    position_errors,
)
from tunnelsense.positioning._filter import forward, rts_smooth
from tunnelsense.positioning._fixes import detection_table, estimate_pass
from tunnelsense.positioning._online import locate_online
from tunnelsense.positioning._plot import plot_positioning
from tunnelsense.positioning._positioner import TunnelPositioner
from tunnelsense.positioning._run import evaluate_positions, position_tour, tour_tables
from tunnelsense.positioning._stream import FIX_COLUMNS, Position, PositionStream
from tunnelsense.positioning._tables import (
    ESTIMATE_COLUMNS,
    check_indicator_map,
    check_odometry,
    check_positions,
    read_indicator_map,
    read_odometry,
    read_positions,
)

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
    "plot_positioning",
    "position_errors",
    "position_tour",
    "read_indicator_map",
    "read_odometry",
    "read_positions",
    "rts_smooth",
    "tour_tables",
]
