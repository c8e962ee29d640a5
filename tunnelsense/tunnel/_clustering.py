"""Keypoint clustering (section 3.3): the frame stage :class:`MSTClusterer`.

The math is in :mod:`tunnelsense.tunnel._mst` (the minimum spanning tree cut as
connected components of the neighbour graph, and the tabular core
:class:`~tunnelsense.tunnel._mst.MSTClustererCore`) and
:mod:`tunnelsense.tunnel._mst_boxes` (the clusters' rectangles).
"""

from __future__ import annotations

import numbers

import numpy as np

from tunnelsense._payload import (
    CLUSTER_BOXES,
    CLUSTER_LABELS,
    KEYPOINT_BAND,
    KEYPOINTS,
    keypoint_band_of,
    keypoints_of,
)
from tunnelsense._records import check_frames
from tunnelsense.tunnel._common import FrameModeMixin
from tunnelsense.tunnel._contrast import contrast_region_boxes
from tunnelsense.tunnel._mst import DENSE_MAX_POINTS, MSTClustererCore, mst_partition
from tunnelsense.tunnel._mst_boxes import cluster_boxes, region_boxes
from tunnelsense.utils._sklearn_compat import StrOptions, _fit_context

__all__ = [
    "DENSE_MAX_POINTS",
    "MSTClusterer",
    "cluster_boxes",
    "mst_partition",
    "region_boxes",
    "separate_left_out",
]


def separate_left_out(image, rows, cols, labels, boxes, *, cut=40.0, reach=(14, 12)):
    """Keypoints far outside their cluster's contrast box become clusters of their own.

    Single linkage chains a far sign's few keypoints to a brighter object within
    ``cut`` of them (a vehicle's lights, a lamp); the cluster's contrast box
    (:func:`~tunnelsense.tunnel._contrast.contrast_region_boxes`) then follows the
    brighter object and the sign is in no box.  Here the keypoints of each cluster
    lying more than ``reach`` outside its box are partitioned again (MST at the same
    ``cut``) into new clusters, numbered after the others, and every cluster's
    contrast box is made again from its keypoints.  Geometry only: the box is set by grey-level ratios,
    ``reach`` is the region's own limit.

    Parameters
    ----------
    image : ndarray of shape (height, width), uint8 or uint16
    rows, cols : ndarray of shape (n,)
        Keypoint positions.
    labels : ndarray of shape (n,)
        Cluster of every keypoint (``0 .. m - 1``).
    boxes : ndarray of shape (m, 4)
        The clusters' contrast boxes ``(left, top, width, height)``.
    cut : float, default=40.0
        The MST cut (px) of the new partition.
    reach : (int, int), default=(14, 12)
        How far (rows, columns; px) outside its box a keypoint still belongs to it.

    Returns
    -------
    labels : ndarray of shape (n,), intp
    boxes : ndarray of shape (m', 4), float64
        ``m' >= m``; the first ``m`` rows are the clusters of ``labels``, without
        the keypoints they left out.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.full((60, 120), 100, np.uint8)
    >>> img[20:26, 10:16] = 220                # a bright light
    >>> img[20:30, 60:64] = 150                # a dimmer sign 45 px away
    >>> rows, cols = np.array([22, 22, 24]), np.array([12, 36, 61])
    >>> labels = np.array([0, 0, 0])           # chained by the 40 px cut
    >>> from tunnelsense.tunnel._contrast import contrast_region_boxes
    >>> box = contrast_region_boxes(img, rows, cols, labels, np.array([[12., 22, 50, 3]]))
    >>> box
    array([[10., 20.,  6.,  6.]])
    >>> separate_left_out(img, rows, cols, labels, box)
    (array([0, 1, 1]), array([[10., 20.,  6.,  6.],
           [60., 20.,  4., 10.]]))
    """
    rows, cols = np.asarray(rows), np.asarray(cols)
    labels = np.asarray(labels, dtype=np.intp)
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    if not len(boxes):
        return labels, boxes
    rr, rc = (int(v) for v in reach)
    left, top, w, h = (boxes[labels, k] for k in range(4))
    away = ~((cols >= left - rc) & (cols < left + w + rc)
             & (rows >= top - rr) & (rows < top + h + rr))
    if not away.any():
        return labels, boxes
    idx = np.flatnonzero(away)
    labels = labels.copy()
    labels[idx] = len(boxes) + mst_partition(np.column_stack([rows[idx], cols[idx]]),
                                             float(cut))
    # every cluster's box again: a cluster that lost keypoints has a smaller
    # keypoint rectangle, so another rim to measure its surround on
    return labels, contrast_region_boxes(image, rows, cols, labels,
                                         cluster_boxes(rows, cols, labels),
                                         reach=(rr, rc))


class MSTClusterer(FrameModeMixin, MSTClustererCore):
    """Single-linkage clustering of keypoints: cut MST edges longer than ``cut``.

    Section 3.3 of the FIR paper: a minimum spanning tree over the keypoints of a frame
    is split by removing the edges longer than ``cut`` (40 px, half the largest
    indicator height); each remaining tree is a keypoint cluster, and its smallest
    bounding rectangle is a detection hypothesis.

    One class, two modes, chosen by the input of ``fit`` / ``transform``:

    * **frame mode** (``X`` a :class:`~tunnelsense.FrameSequence` or any sequence of
      :class:`~tunnelsense.FrameRecord`, as in a :class:`~sklearn.pipeline.Pipeline`
      after :class:`IntensityKeypointSampler` and :class:`KMeansHistogramVerifier`):
      ``transform`` returns a :class:`~tunnelsense.FrameSequence` of the same frames
      (same length and identities), each record evolved with

      - ``payload["cluster_labels"]``: ndarray of shape (n,), intp -- the cluster of
        every keypoint of ``payload["keypoints"]`` (numbered by first occurrence, i.e.
        in the keypoints' raster order);
      - ``payload["cluster_boxes"]``: ndarray of shape (m, 4), float64 -- per cluster
        the smallest bounding rectangle ``(left, top, width, height)`` of its
        keypoints in whole pixels (see :func:`cluster_boxes`; a one-keypoint cluster
        is a 1 x 1 px box).

      Nothing is learned; ``fit`` validates the input and marks the stage fitted.
    * **tabular mode** (``X`` a 2-D array of points): ``fit`` sets ``labels_``, the
      partition of ``X`` into connected components of the ``<= cut`` neighbour graph
      (identical to cutting the MST; duplicate points share a cluster);
      ``fit_predict`` returns it; ``transform`` gives, for new points, the
      single-linkage distance to every fitted cluster (the distance to its nearest
      member).  It is not a :class:`~sklearn.base.ClusterMixin`: its ``cut`` is an
      absolute length in pixels, not a scale-free setting that scikit-learn's
      clustering checks on standardized blobs could meaningfully test.  The tabular
      mode passes ``parametrize_with_checks`` as a transformer.

    Parameters
    ----------
    cut : float, default=40.0
        MST edges longer than this (px) are removed.
    box : {"keypoints", "region", "contrast"}, default="keypoints"
        Frame mode: the rectangle of each cluster.  ``"keypoints"`` (the paper's):
        the smallest rectangle of its keypoints, quantized to the 7 x 6 px grid.
        ``"region"``: that rectangle refined on the image to the in-band pixels
        connected to the keypoints (:func:`region_boxes`), which gives the object's
        own extent: a stable centre and scale for tracking and the whole sign for the
        appearance histogram; it goes with a band of grey levels.  ``"contrast"``
        (:func:`~tunnelsense.tunnel.make_indicator_pipeline`'s): the region at or
        above half the contrast of the cluster's brightest keypoint over its
        surround, that keypoint's component only
        (:func:`~tunnelsense.tunnel._contrast.contrast_region_boxes`): no band, so
        the region does not grow when the keypoint band is widened, and an affine
        change of the grey levels does not move it.
    band : (float, float) or None, default=None
        ``box="region"``: the intensity band of the region.  ``None`` takes the band
        :class:`IntensityKeypointSampler` used, from ``payload["keypoint_band"]``.
    reach : (int, int), default=(14, 12)
        ``box="region"`` or ``"contrast"``: how far (rows, columns; px) the region may extend beyond the
        keypoints' rectangle (two grid steps).
    separate : bool, default=False
        ``box="contrast"``: the keypoints of a cluster lying more than ``reach``
        outside its box form clusters of their own, numbered after the others
        (:func:`separate_left_out`): a far sign chained to a brighter object
        keeps a cluster.  Off by default: the extra, smaller clusters can also
        make false-alarm trajectories.

    Attributes
    ----------
    labels_ : ndarray of shape (n_samples,)
        Tabular mode: cluster of every fitted point, by first occurrence.
    n_clusters_ : int
        Tabular mode: number of clusters of the fitted points.
    X_fit_ : ndarray of shape (n_samples, n_features)
        Tabular mode: the fitted points (used by ``transform``).
    n_features_in_ : int
        Tabular mode: number of coordinates per point.
    n_frames_fit_ : int
        Frame mode: number of frames seen by ``fit``.

    See Also
    --------
    mst_partition : The array-in, array-out function this estimator wraps.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.tunnel import MSTClusterer
    >>> MSTClusterer(cut=40).fit_predict(np.array([[0, 0], [0, 30], [0, 100.]]))
    array([0, 0, 1])

    Frame mode, on keypoints ``(row, col, intensity)``:

    >>> from tunnelsense import FrameRecord
    >>> kp = np.array([[7, 6, 170], [14, 6, 175], [70, 300, 180]], dtype=np.int32)
    >>> rec = FrameRecord("t", 1, np.zeros((480, 640), np.uint8), {"keypoints": kp})
    >>> out = MSTClusterer().fit_transform([rec])
    >>> out[0].payload["cluster_labels"]
    array([0, 0, 1])
    >>> out[0].payload["cluster_boxes"]
    array([[  6.,   7.,   1.,   8.],
           [300.,  70.,   1.,   1.]])
    """

    _parameter_constraints: dict = {
        **MSTClustererCore._parameter_constraints,
        "box": [StrOptions({"keypoints", "region", "contrast"})],
        "band": [tuple, list, None],
        "reach": [tuple, list],
        "separate": ["boolean"],
    }
    _tabular_methods = ("fit_predict",)
    _frames_instead = "fit_transform, which stores the labels in payload['cluster_labels']"
    _payload_reads = (KEYPOINTS,)
    _payload_optional = (KEYPOINT_BAND,)
    _payload_adds = (CLUSTER_LABELS, CLUSTER_BOXES)

    def __init__(self, cut=40.0, *, box="keypoints", band=None, reach=(14, 12),
                 separate=False):
        self.cut = cut
        self.box = box
        self.band = band
        self.reach = reach
        self.separate = separate

    @_fit_context(prefer_skip_nested_validation=True)
    def _fit_frames(self, X, y=None):
        records, _ = check_frames(X, y)
        for i, r in enumerate(records):
            keypoints_of(r, i, "MSTClusterer")
        self.n_frames_fit_ = len(records)
        return self

    def _check_region_params(self):
        reach = tuple(self.reach)
        if len(reach) != 2 or not all(
            isinstance(v, numbers.Integral) and v >= 0 for v in reach
        ):
            raise ValueError(
                f"reach must be a pair (rows, columns) of non-negative ints; got {self.reach!r}"
            )
        if self.band is not None:
            band = tuple(self.band)
            if len(band) != 2 or not band[0] <= band[1]:
                raise ValueError(
                    f"band must be None or a pair (low, high) with low <= high; got {self.band!r}"
                )

    def _band_of(self, record, index):
        if self.band is not None:
            return tuple(self.band)
        return keypoint_band_of(record, index, "MSTClusterer(box='region')",
                                instead=", or band=(low, high)")

    def _transform_frames(self, records):
        cut = float(self.cut)
        region = self.box in ("region", "contrast")
        if region:
            self._check_region_params()
            reach = tuple(int(v) for v in self.reach)
        out = []
        for i, r in enumerate(records):
            kp = keypoints_of(r, i, "MSTClusterer")
            rows = kp[:, 0]
            cols = kp[:, 1]
            labels = mst_partition(np.column_stack([rows, cols]), cut)
            boxes = cluster_boxes(rows, cols, labels)
            if self.box == "contrast" and len(boxes):
                image = r.image
                boxes = contrast_region_boxes(image, rows, cols, labels, boxes,
                                              reach=reach)
                if self.separate:
                    labels, boxes = separate_left_out(image, rows, cols, labels, boxes,
                                                      cut=cut, reach=reach)
            elif region and len(boxes):
                boxes = region_boxes(
                    r.image, rows, cols, labels, boxes, self._band_of(r, i), reach
                )
            out.append(r.evolve(**{CLUSTER_LABELS: labels, CLUSTER_BOXES: boxes}))
        return out
