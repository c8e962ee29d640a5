"""Pictures of frames, scans and detections (needs the optional ``plot`` extra)."""

from tunnelsense.plotting._frames import CLASS_COLORS, plot_frame
from tunnelsense.plotting._scans import plot_range_image, plot_scan, scan_points
from tunnelsense.tunnel._pipeline import draw_detections

__all__ = [
    "CLASS_COLORS",
    "draw_detections",
    "plot_frame",
    "plot_range_image",
    "plot_scan",
    "scan_points",
]
