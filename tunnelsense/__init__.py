"""tunnelsense: scikit-learn estimators that find roadside landmarks in sensor data.

Two published methods, as estimators that compose in :class:`sklearn.pipeline.Pipeline`:

* emergency-telephone indicators in far-infrared tunnel video (Wang et al., 2013);
* street-parked vehicles from a vertically scanning laser range finder
  (Hirahara and Ikeuchi).

A sample is one frame or one scan (:class:`FrameRecord`, :class:`ScanRecord`); see
:doc:`/architecture`.
"""

from tunnelsense._records import (
    MOT_GT_COLUMNS,
    OBJECT_CLASSES,
    RUN_GT_COLUMNS,
    RUN_LABELS,
    DecodedImage,
    FrameRecord,
    FrameSequence,
    ImageFile,
    LaserGeometry,
    Run,
    ScanRecord,
    ScanSequence,
    Tour,
    VideoFrame,
    check_frames,
    check_scans,
    to_xy,
)
from tunnelsense._version import __version__
from tunnelsense.positioning import TunnelPositioner
from tunnelsense.street import ScanClusterer, make_parking_pipeline
from tunnelsense.tunnel import (
    IntensityKeypointSampler,
    KMeansHistogramVerifier,
    MSTClusterer,
    PCCVerifier,
    TrajectoryLinker,
    WeightedAdaBoost,
    make_indicator_pipeline,
)

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
