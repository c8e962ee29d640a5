"""Pictures of frames, scans and detections.

:func:`draw_detections` draws with OpenCV; the others need matplotlib (the optional
``plot`` extra), imported only when a picture is drawn so that importing
``tunnelsense`` stays fast.
"""

from tunnelsense.plotting._census import VEHICLE_CLASS_COLOURS, plot_census
from tunnelsense.plotting._detections import DRAW_COLOURS, draw_detections
from tunnelsense.plotting._frames import CLASS_COLORS, plot_frame
from tunnelsense.plotting._scans import (
    interval_bars,
    plot_range_image,
    plot_scan,
    scan_points,
)
from tunnelsense.plotting._street import (
    draw_run,
    plot_clusters,
    plot_dendrogram,
    plot_objects,
)

__all__ = [
    "CLASS_COLORS",
    "DRAW_COLOURS",
    "VEHICLE_CLASS_COLOURS",
    "draw_detections",
    "draw_run",
    "interval_bars",
    "plot_census",
    "plot_clusters",
    "plot_dendrogram",
    "plot_frame",
    "plot_objects",
    "plot_range_image",
    "plot_scan",
    "scan_points",
]
