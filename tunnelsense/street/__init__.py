"""Street-parked vehicles from a vertically scanning laser range finder.

Section III of Hirahara and Ikeuchi, *Detection of Street-Parking Vehicles on Panoramic
Laser-Range Image*, as array functions and scikit-learn estimators on scan records;
user guide: :doc:`/street`.
The modules follow the method: geometry (``_restoration``, ``_roi``, ``_geometry``),
clustering (``_clustering``), objects (``_sections``, ``_objects``, ``_splitting``, ``_classes``),
the online state (``_stream``), the estimator (``_detector``) and whole runs (``_run``);
a parking census of the objects (``_census``).
"""

# The modules follow the method: geometry (_restoration, _roi, _geometry), clustering
# (_clustering), objects (_sections, _objects), the online state (_stream), the
# estimator (_detector) and whole runs (_run).

from tunnelsense.street._census import (
    CENSUS_CLASSES,
    CENSUS_COLUMNS,
    VEHICLE_CLASSES,
    census,
    parked_extents,
    scan_distances,
)
from tunnelsense.street._classes import class_features, vehicle_class
from tunnelsense.street._clustering import link_scans, single_linkage
from tunnelsense.street._detector import OBJECT_COLUMNS, ScanClusterer
from tunnelsense.street._plotting import plot_clusters, plot_dendrogram, plot_objects
from tunnelsense.street._restoration import (
    compensate_tilt,
    estimate_tilt,
    no_return,
    restore_points,
)
from tunnelsense.street._roi import roi_mask
from tunnelsense.street._run import (
    OBJECT_CSV_COLUMNS,
    SEARCH_GRID,
    format_object,
    format_objects_written,
    format_runs,
    format_training,
    make_parking_pipeline,
    stream_objects,
    train_detector,
    write_objects,
)
from tunnelsense.street._sections import passed_under, section_evidence
from tunnelsense.street._splitting import split_profile

__all__ = [
    "CENSUS_CLASSES",
    "CENSUS_COLUMNS",
    "VEHICLE_CLASSES",
    "census",
    "class_features",
    "vehicle_class",
    "parked_extents",
    "scan_distances",
    "OBJECT_COLUMNS",
    "OBJECT_CSV_COLUMNS",
    "SEARCH_GRID",
    "ScanClusterer",
    "make_parking_pipeline",
    "split_profile",
    "compensate_tilt",
    "estimate_tilt",
    "format_object",
    "format_objects_written",
    "format_runs",
    "format_training",
    "link_scans",
    "no_return",
    "plot_clusters",
    "plot_dendrogram",
    "plot_objects",
    "restore_points",
    "roi_mask",
    "passed_under",
    "section_evidence",
    "single_linkage",
    "stream_objects",
    "train_detector",
    "write_objects",
]
