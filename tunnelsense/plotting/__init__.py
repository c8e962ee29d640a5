"""Pictures of frames, scans and detections.

:func:`draw_detections` draws with OpenCV; the others need matplotlib (the optional
``plot`` extra), imported only when a picture is drawn so that importing
``tunnelsense`` stays fast.
"""

from tunnelsense._lazy import attach

_NAMES = {
    "VEHICLE_CLASS_COLOURS": "_census",
    "plot_census": "_census",
    "DRAW_COLOURS": "_detections",
    "draw_detections": "_detections",
    "CLASS_COLORS": "_frames",
    "plot_frame": "_frames",
    "interval_bars": "_scans",
    "plot_range_image": "_scans",
    "plot_scan": "_scans",
    "scan_points": "_scans",
    "draw_run": "_street",
    "plot_clusters": "_street",
    "plot_dendrogram": "_street",
    "plot_objects": "_street",
}

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

__getattr__, __dir__, _ = attach(__name__, _NAMES, __all__)
