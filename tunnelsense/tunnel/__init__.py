"""The FIR indicator detector of Wang et al. (2013), one module per paper section.

Stages 1-3 (sections 3.1-3.3): :class:`IntensityKeypointSampler` (keypoint detection),
:class:`KMeansHistogramVerifier` (keypoint verification), :class:`MSTClusterer`
(keypoint clustering); stages 4-6 (sections 3.4-3.7): :class:`WeightedAdaBoost`,
:class:`TrajectoryLinker`, :class:`PCCVerifier`; :func:`make_indicator_pipeline` puts
the six in a Pipeline.  Each is a frame stage (frame records in, frame records out);
the verifier, the clusterer and the appearance machine also take 2-D arrays.  User
guide: :doc:`/tunnel-stages`, :doc:`/tunnel-detector`.
"""

from tunnelsense._lazy import attach

_NAMES = {
    "WeightedAdaBoost": "_appearance",
    "box_histograms": "_appearance",
    "centres_in_boxes": "_appearance",
    "MSTClusterer": "_clustering",
    "cluster_boxes": "_clustering",
    "mst_partition": "_clustering",
    "region_boxes": "_clustering",
    "detect_to_files": "_detect",
    "detect_tour": "_detect",
    "fit_indicator_detector": "_training",
    "stream_detect": "_detect",
    "IntensityKeypointSampler": "_keypoints",
    "indicator_band": "_keypoints",
    "sample_keypoints": "_keypoints",
    "PCCVerifier": "_motion",
    "curve_fit_r": "_motion",
    "motion_fit_r": "_motion",
    "pearson_r": "_motion",
    "straightness": "_motion",
    "make_indicator_pipeline": "_pipeline",
    "format_detection": "_reports",
    "format_tours": "_reports",
    "format_training": "_reports",
    "run_demo": "_reports",
    "TrajectoryLinker": "_tracking",
    "KMeansHistogramVerifier": "_verification",
    "fit_kmeans": "_verification",
    "keypoint_descriptors": "_verification",
    "patch_histograms": "_verification",
    "rank_positive_centers": "_verification",
    "verify_histograms": "_verification",
}

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
    "motion_fit_r",
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

__getattr__, __dir__, _ = attach(__name__, _NAMES, __all__)
