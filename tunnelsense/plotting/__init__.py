"""Pictures of frames, scans and detections (needs the optional ``plot`` extra)."""

from tunnelsense.plotting._frames import CLASS_COLORS, plot_frame
from tunnelsense.plotting._scans import plot_range_image, plot_scan, scan_points

__all__ = [
    "CLASS_COLORS",
    "plot_frame",
    "plot_range_image",
    "plot_scan",
    "scan_points",
]
