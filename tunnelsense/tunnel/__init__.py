"""The FIR indicator detector of Wang et al. (2013), one module per paper section.

Stages 1-3 (sections 3.1-3.3): :class:`IntensityKeypointSampler` (keypoint detection),
:class:`KMeansHistogramVerifier` (keypoint verification), :class:`MSTClusterer`
(keypoint clustering).  Each is a frame stage (frame records in, frame records out);
the verifier and the clusterer also take 2-D arrays (histograms, points).  See
``docs/tunnel-stages.md``.
"""

from tunnelsense.tunnel._clustering import MSTClusterer, cluster_boxes, mst_partition
from tunnelsense.tunnel._keypoints import (
    IntensityKeypointSampler,
    indicator_band,
    sample_keypoints,
)
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
    "cluster_boxes",
    "fit_kmeans",
    "indicator_band",
    "mst_partition",
    "patch_histograms",
    "rank_positive_centers",
    "sample_keypoints",
]
