"""tunnelsense: scikit-learn estimators that find roadside landmarks in sensor data.

Two published methods, as estimators that compose in :class:`sklearn.pipeline.Pipeline`:

* emergency-telephone indicators in far-infrared tunnel video (Wang et al., 2013);
* street-parked vehicles from a vertically scanning laser range finder
  (Hirahara and Ikeuchi).

A sample is one frame or one scan (:class:`FrameRecord`, :class:`ScanRecord`); see
:doc:`/architecture`.
"""

from tunnelsense._lazy import attach
from tunnelsense._version import __version__

_NAMES = {
    "MOT_GT_COLUMNS": "_records",
    "OBJECT_CLASSES": "_records",
    "RUN_GT_COLUMNS": "_records",
    "RUN_LABELS": "_records",
    "DecodedImage": "_records",
    "FrameRecord": "_records",
    "FrameSequence": "_records",
    "ImageFile": "_records",
    "LaserGeometry": "_records",
    "Run": "_records",
    "ScanRecord": "_records",
    "ScanSequence": "_records",
    "Tour": "_records",
    "VideoFrame": "_records",
    "check_frames": "_records",
    "check_scans": "_records",
    "to_xy": "_records",
    "TunnelPositioner": "positioning",
    "ScanClusterer": "street",
    "make_parking_pipeline": "street",
    "IntensityKeypointSampler": "tunnel",
    "KMeansHistogramVerifier": "tunnel",
    "MSTClusterer": "tunnel",
    "PCCVerifier": "tunnel",
    "TrajectoryLinker": "tunnel",
    "WeightedAdaBoost": "tunnel",
    "make_indicator_pipeline": "tunnel",
}

__all__ = [
    "DecodedImage",
    "FrameRecord",
    "ImageFile",
    "IntensityKeypointSampler",
    "KMeansHistogramVerifier",
    "MSTClusterer",
    "PCCVerifier",
    "TrajectoryLinker",
    "WeightedAdaBoost",
    "make_indicator_pipeline",
    "ScanClusterer",
    "make_parking_pipeline",
    "TunnelPositioner",
    "FrameSequence",
    "LaserGeometry",
    "MOT_GT_COLUMNS",
    "OBJECT_CLASSES",
    "RUN_GT_COLUMNS",
    "RUN_LABELS",
    "Run",
    "ScanRecord",
    "ScanSequence",
    "Tour",
    "VideoFrame",
    "__version__",
    "check_frames",
    "check_scans",
    "to_xy",
]

__getattr__, __dir__, _ = attach(__name__, _NAMES, __all__)
