"""The FIR indicator detector of Wang et al. (2013), one module per paper section.

Stages 1-3 (sections 3.1-3.3): :class:`IntensityKeypointSampler` (keypoint detection),
:class:`KMeansHistogramVerifier` (keypoint verification), :class:`MSTClusterer`
(keypoint clustering); stages 4-6 (sections 3.4-3.7): :class:`WeightedAdaBoost`,
:class:`TrajectoryLinker`, :class:`PCCVerifier`; :func:`make_indicator_pipeline` puts
the six in a Pipeline.  Each is a frame stage (frame records in, frame records out);
the verifier, the clusterer and the appearance machine also take 2-D arrays.  User
guide: :doc:`/tunnel-stages`, :doc:`/tunnel-detector`.
"""

from tunnelsense.tunnel._appearance import (
    WeightedAdaBoost,
    box_histograms,
    centres_in_boxes,
)
from tunnelsense.tunnel._clustering import (
    MSTClusterer,
    cluster_boxes,
    mst_partition,
    region_boxes,
)
from tunnelsense.tunnel._detect import (
    detect_to_files,
    detect_tour,
    fit_indicator_detector,
    stream_detect,
)
from tunnelsense.tunnel._keypoints import (
    IntensityKeypointSampler,
    indicator_band,
    sample_keypoints,
)
from tunnelsense.tunnel._motion import PCCVerifier, curve_fit_r, pearson_r, straightness
from tunnelsense.tunnel._pipeline import make_indicator_pipeline
from tunnelsense.tunnel._reports import (
    format_detection,
    format_tours,
    format_training,
    run_demo,
)
from tunnelsense.tunnel._tracking import TrajectoryLinker
from tunnelsense.tunnel._verification import (
    KMeansHistogramVerifier,
    fit_kmeans,
    keypoint_descriptors,
    patch_histograms,
    rank_positive_centers,
    verify_histograms,
)

__all__ = [
    "format_detection",
    "format_tours",
    "format_training",
    "run_demo",
    "IntensityKeypointSampler",
    "KMeansHistogramVerifier",
    "MSTClusterer",
    "PCCVerifier",
    "TrajectoryLinker",
    "WeightedAdaBoost",
    "box_histograms",
    "centres_in_boxes",
    "cluster_boxes",
    "curve_fit_r",
    "detect_to_files",
    "detect_tour",
    "fit_indicator_detector",
    "fit_kmeans",
    "indicator_band",
    "keypoint_descriptors",
    "make_indicator_pipeline",
    "mst_partition",
    "patch_histograms",
    "pearson_r",
    "straightness",
    "rank_positive_centers",
    "verify_histograms",
    "region_boxes",
    "sample_keypoints",
    "stream_detect",
]
