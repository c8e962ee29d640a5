"""Street-parked vehicles from a vertically scanning laser range finder.

Section III of Hirahara and Ikeuchi, *Detection of Street-Parking Vehicles on Panoramic
Laser-Range Image*, as array functions and scikit-learn estimators on scan records;
see ``docs/street.md``.
"""

from tunnelsense.street._clustering import link_scans, single_linkage
from tunnelsense.street._detector import (
    OBJECT_COLUMNS,
    ScanClusterer,
    make_parking_pipeline,
    split_profile,
)
from tunnelsense.street._plotting import plot_clusters, plot_dendrogram, plot_objects
from tunnelsense.street._restoration import (
    compensate_tilt,
    estimate_tilt,
    no_return,
    restore_points,
)
from tunnelsense.street._roi import roi_mask
from tunnelsense.street._sections import section_evidence

__all__ = [
    "OBJECT_COLUMNS",
    "ScanClusterer",
    "make_parking_pipeline",
    "split_profile",
    "compensate_tilt",
    "estimate_tilt",
    "link_scans",
    "no_return",
    "plot_clusters",
    "plot_dendrogram",
    "plot_objects",
    "restore_points",
    "roi_mask",
    "section_evidence",
    "single_linkage",
]
