"""The FIR indicator detector of Wang et al. (2013), one module per paper section.

Stages 1-3 (sections 3.1-3.3): :class:`IntensityKeypointSampler` (keypoint detection),
:class:`KMeansHistogramVerifier` (keypoint verification), :class:`MSTClusterer`
(keypoint clustering).  Each is a frame stage (frame records in, frame records out);
the verifier and the clusterer also take 2-D arrays (histograms, points).  See
``docs/tunnel-stages.md``.
"""

from tunnelsense.tunnel._appearance import (
    WeightedAdaBoost,
    box_histograms,
    centres_in_boxes,
)
from tunnelsense.tunnel._clustering import MSTClusterer, cluster_boxes, mst_partition
from tunnelsense.tunnel._keypoints import (
    IntensityKeypointSampler,
    indicator_band,
    sample_keypoints,
)
from tunnelsense.tunnel._motion import PCCVerifier, pearson_r
from tunnelsense.tunnel._pipeline import make_indicator_pipeline
from tunnelsense.tunnel._tracking import TrajectoryLinker
from tunnelsense.tunnel._verification import (
    KMeansHistogramVerifier,
    fit_kmeans,
    patch_histograms,
    rank_positive_centers,
)

__all__ = [
    "IntensityKeypointSampler",
    "KMeansHistogramVerifier",
    "MSTClusterer",
    "PCCVerifier",
    "TrajectoryLinker",
    "WeightedAdaBoost",
    "box_histograms",
    "centres_in_boxes",
    "cluster_boxes",
    "fit_kmeans",
    "indicator_band",
    "make_indicator_pipeline",
    "mst_partition",
    "patch_histograms",
    "pearson_r",
    "rank_positive_centers",
    "sample_keypoints",
]
