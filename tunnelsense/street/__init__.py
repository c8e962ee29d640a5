"""Street-parked vehicles from a vertically scanning laser range finder.

Section III of Hirahara and Ikeuchi, *Detection of Street-Parking Vehicles on Panoramic
Laser-Range Image*, as array functions and scikit-learn estimators on scan records;
user guide: :doc:`/street`.
The modules follow the method: geometry (``_restoration``, ``_roi``, ``_geometry``),
clustering (``_clustering``), objects (``_sections``, ``_objects``, ``_vehicles``,
``_splitting``, ``_classes``), the online state (``_stream``, ``_labelling``), the
estimator (``_detector``) and whole runs (``_run``); a parking census of the objects
(``_census``).
"""

# The modules follow the method: geometry (_restoration, _roi, _geometry), clustering
# (_clustering), objects (_sections, _objects, _vehicles), the online state (_stream,
# _labelling), the estimator (_detector; its parameters _detector_params and outputs
# _detector_outputs) and whole runs (_run).

from tunnelsense._lazy import attach

_NAMES = {
    "CENSUS_CLASSES": "_census",
    "CENSUS_COLUMNS": "_census",
    "VEHICLE_CLASSES": "_census",
    "census": "_census",
    "parked_extents": "_census",
    "scan_distances": "_census",
    "class_features": "_classes",
    "vehicle_class": "_classes",
    "link_scans": "_clustering",
    "single_linkage": "_clustering",
    "OBJECT_COLUMNS": "_detector",
    "ScanClusterer": "_detector",
    "plot_clusters": "_plotting",
    "plot_dendrogram": "_plotting",
    "plot_objects": "_plotting",
    "compensate_tilt": "_restoration",
    "estimate_tilt": "_restoration",
    "no_return": "_restoration",
    "restore_points": "_restoration",
    "roi_mask": "_roi",
    "OBJECT_CSV_COLUMNS": "_run",
    "SEARCH_GRID": "_run",
    "format_object": "_run",
    "format_objects_written": "_run",
    "format_runs": "_run",
    "format_training": "_run",
    "make_parking_pipeline": "_run",
    "stream_objects": "_run",
    "train_detector": "_run",
    "write_objects": "_run",
    "passed_under": "_sections",
    "section_evidence": "_sections",
    "split_profile": "_splitting",
}

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

__getattr__, __dir__, _ = attach(__name__, _NAMES, __all__)
