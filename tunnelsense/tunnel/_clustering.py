"""Keypoint clustering (section 3.3): cut the minimum spanning tree of the keypoints.

The partition obtained by removing the edges longer than ``cut`` from the Euclidean
minimum spanning tree (MST) is the partition into connected components of the
*neighbour graph* that joins every two points at most ``cut`` apart.  This module builds
that graph without ever forming a full MST:

* up to :data:`DENSE_MAX_POINTS` points (the per-frame case, about 100 keypoints): a dense
  distance matrix and min-label propagation with pointer jumping, all in NumPy;
* more points, when a grid count bounds the number of pairs at most ``cut`` apart by
  ``max(30 n, 2e6)`` (sparse sets, such as keypoints): those pairs from a KD-tree's
  ``query_pairs``, then :func:`scipy.sparse.csgraph.connected_components`;
* dense 2-D sets: the edges of the Delaunay triangulation of the distinct points (the
  Euclidean MST lies inside it, and every pair at most ``cut`` apart is joined by a
  path of Delaunay edges each at most ``cut`` long: if a pair's edge is missing, some
  point lies in the closed disc on that pair's diameter, and is strictly nearer to
  both), then connected components; when Qhull cannot triangulate (all points
  collinear), the KD-tree pairs.

Points at identical positions always fall into one cluster.  Labels are numbered in
order of first occurrence (the cluster of ``points[0]`` is 0, and so on).
"""

from __future__ import annotations

import numbers

import cv2
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import Delaunay, QhullError, cKDTree
from sklearn.base import BaseEstimator, TransformerMixin, _fit_context
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.validation import check_is_fitted, validate_data

from tunnelsense._records import FrameSequence, check_frames
from tunnelsense.tunnel._common import is_record_input, keypoints_of

__all__ = [
    "DENSE_MAX_POINTS",
    "MSTClusterer",
    "cluster_boxes",
    "mst_partition",
    "region_boxes",
]

#: Up to this many points, :func:`mst_partition` uses a dense distance matrix.
DENSE_MAX_POINTS = 384


def _canonical(labels: np.ndarray) -> np.ndarray:
    """Relabel a partition so that clusters are numbered by first occurrence."""
    n = len(labels)
    first = np.full(n, n, dtype=np.intp)
    np.minimum.at(first, labels, np.arange(n, dtype=np.intp))
    roots = np.flatnonzero(first < n)
    order = np.empty(n, dtype=np.intp)
    order[roots[np.argsort(first[roots], kind="stable")]] = np.arange(len(roots))
    return order[labels]


def _dense_partition(points: np.ndarray, cut: float) -> np.ndarray:
    n = len(points)
    adjacent = None
    for k in range(points.shape[1]):
        x = points[:, k]
        d = x[:, None] - x
        d *= d
        adjacent = d if adjacent is None else adjacent + d
    adjacent = adjacent <= cut * cut
    # Min-label propagation: every point takes the smallest index among its
    # neighbours (itself included), then jumps along its labels' labels.  Labels
    # only decrease and stay within a component, so at the fixed point every
    # component is labelled by its smallest index, which is its first occurrence.
    labels = adjacent.argmax(axis=1)  # the first True: the smallest neighbour
    labels = labels[labels]
    while True:
        new = np.where(adjacent, labels, n).min(axis=1)
        new = new[new[new]]
        if np.array_equal(new, labels):
            break
        labels = new
    roots = labels == np.arange(n)
    rank = np.cumsum(roots) - 1
    return rank[labels].astype(np.intp, copy=False)


def _components(n: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    graph = coo_matrix(
        (np.ones(len(i), dtype=np.int8), (i, j)), shape=(n, n)
    ).tocsr()
    return connected_components(graph, directed=False)[1]


def _pair_partition(points: np.ndarray, cut: float) -> np.ndarray:
    # query_pairs reports coincident points too (distance 0 <= cut), so duplicates
    # are joined without special care.
    pairs = cKDTree(points).query_pairs(cut, output_type="ndarray")
    return _components(len(points), pairs[:, 0], pairs[:, 1])


def _distinct(points: np.ndarray):
    """Distinct rows of a 2-D array and the index of every row's distinct row."""
    order = np.lexsort(points.T[::-1])
    sorted_points = points[order]
    new = np.empty(len(points), dtype=bool)
    new[0] = True
    np.any(sorted_points[1:] != sorted_points[:-1], axis=1, out=new[1:])
    group = np.cumsum(new) - 1
    inverse = np.empty(len(points), dtype=np.intp)
    inverse[order] = group
    return sorted_points[new], inverse


def _delaunay_partition(points: np.ndarray, cut: float) -> np.ndarray:
    unique, inverse = _distinct(points)
    if len(unique) < 3:
        return _pair_partition(points, cut)
    try:
        simplices = Delaunay(unique).simplices
    except (QhullError, ValueError):  # all points collinear
        return _pair_partition(points, cut)
    edges = np.concatenate(
        [simplices[:, [0, 1]], simplices[:, [1, 2]], simplices[:, [0, 2]]]
    )
    d = unique[edges[:, 0]] - unique[edges[:, 1]]
    keep = np.einsum("ij,ij->i", d, d) <= cut * cut
    edges = edges[keep]
    return _components(len(unique), edges[:, 0], edges[:, 1])[inverse]


def _pair_bound(points: np.ndarray, cut: float) -> float:
    """An upper bound on the number of pairs at most ``cut`` apart (grid count)."""
    cells = np.floor(points / cut).astype(np.int64)
    cells -= cells.min(axis=0)
    span = cells.max(axis=0) + 1
    if float(span[0]) * float(span[1]) < 2.0**62:
        keys = cells[:, 0] * span[1] + cells[:, 1]
        counts = np.unique(keys, return_counts=True)[1]
    else:
        counts = np.unique(cells, axis=0, return_counts=True)[1]
    counts = counts.astype(np.float64)
    # a pair within cut lies in the same or adjacent cells: sum over the 3 x 3
    # neighbourhood of c_i * c_j <= 4.5 * sum(c_i ** 2)
    return 4.5 * float(np.dot(counts, counts))


def mst_partition(points, cut: float = 40.0) -> np.ndarray:
    """Partition points by cutting the MST edges longer than ``cut``.

    Parameters
    ----------
    points : ndarray of shape (n_points, n_dims)
        Point coordinates (float).
    cut : float, default=40.0
        Edges longer than this are removed; points at most ``cut`` apart always share
        a cluster.

    Returns
    -------
    labels : ndarray of shape (n_points,), dtype intp
        Cluster of every point, numbered ``0, 1, ...`` in order of first occurrence.

    Notes
    -----
    Up to :data:`DENSE_MAX_POINTS` points: dense distances.  More points: the pairs at
    most ``cut`` apart from a KD-tree when a grid count bounds their number by
    ``max(30 * n, 2e6)``; otherwise (dense 2-D sets) the Delaunay edges of the
    distinct points.  Either way, connected components give the partition.

    Examples
    --------
    >>> import numpy as np
    >>> mst_partition(np.array([[0, 0], [100, 0], [30, 0], [100, 0]]), cut=40)
    array([0, 1, 0, 1])
    """
    points = np.asarray(points, dtype=np.float64)
    n = len(points)
    cut = float(cut)
    if n == 0:
        return np.empty(0, dtype=np.intp)
    if n <= DENSE_MAX_POINTS:
        return _dense_partition(points, cut)
    if (
        points.shape[1] == 2
        and cut > 0
        and _pair_bound(points, cut) > max(30.0 * n, 2e6)
    ):
        labels = _delaunay_partition(points, cut)
    else:
        labels = _pair_partition(points, cut)
    return _canonical(labels.astype(np.intp, copy=False))


def cluster_boxes(rows, cols, labels, n_clusters=None) -> np.ndarray:
    """Smallest bounding rectangle of every cluster, as ``(left, top, width, height)``.

    Boxes span whole pixels: a cluster of keypoints in columns ``c0..c1`` and rows
    ``r0..r1`` gets ``(c0, r0, c1 - c0 + 1, r1 - r0 + 1)``, so a cluster of one keypoint
    is the 1 x 1 px box of that pixel.

    Examples
    --------
    >>> import numpy as np
    >>> cluster_boxes(np.array([7, 14, 70]), np.array([6, 12, 6]), np.array([0, 0, 1]))
    array([[ 6.,  7.,  7.,  8.],
           [ 6., 70.,  1.,  1.]])
    """
    rows = np.asarray(rows, dtype=np.float64)
    cols = np.asarray(cols, dtype=np.float64)
    labels = np.asarray(labels, dtype=np.intp)
    if n_clusters is None:
        n_clusters = int(labels.max()) + 1 if len(labels) else 0
    if n_clusters == 0:
        return np.empty((0, 4), dtype=np.float64)
    order = np.argsort(labels, kind="stable")
    starts = np.searchsorted(labels[order], np.arange(int(n_clusters)))
    r, c = rows[order], cols[order]
    top, left = np.minimum.reduceat(r, starts), np.minimum.reduceat(c, starts)
    bottom, right = np.maximum.reduceat(r, starts), np.maximum.reduceat(c, starts)
    return np.column_stack([left, top, right - left + 1, bottom - top + 1])


def region_boxes(image, rows, cols, labels, boxes, band, reach=(14, 12)) -> np.ndarray:
    """Refine keypoint-cluster rectangles to the in-band image region around them.

    A cluster's keypoints lie on the 7 x 6 px grid, so their bounding rectangle is
    quantized to the grid: it jumps by a grid step as the object grows or moves, and a
    cluster of one keypoint is a 1 x 1 px box.  The object itself is the region of
    pixels whose intensity lies in the keypoint band: this function takes, inside the
    cluster's rectangle grown by ``reach`` px (rows, columns), the 8-connected
    components of the pixels within ``band`` that hold a keypoint of the cluster, and
    returns their bounding rectangle.  Keypoints whose pixel is not in the band (after
    a band change) keep their own 1 x 1 px box in the union.

    Parameters
    ----------
    image : ndarray of shape (height, width), uint8 or uint16
    rows, cols : ndarray of shape (n,)
        Keypoint positions.
    labels : ndarray of shape (n,)
        Cluster of every keypoint (``0 .. m - 1``).
    boxes : ndarray of shape (m, 4)
        The clusters' keypoint rectangles (:func:`cluster_boxes`).
    band : (float, float)
        Inclusive intensity band ``[low, high]`` (the keypoint band).
    reach : (int, int), default=(14, 12)
        How far (rows, columns; px) the region may extend beyond the keypoints'
        rectangle: two grid steps.

    Returns
    -------
    boxes : ndarray of shape (m, 4), float64
        ``(left, top, width, height)`` in whole pixels; each contains the input box.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.full((40, 40), 100, np.uint8)
    >>> img[10:26, 17:23] = 175          # a 16 x 6 px sign
    >>> rows, cols = np.array([14, 21]), np.array([18, 18])
    >>> box = cluster_boxes(rows, cols, np.array([0, 0]))
    >>> box
    array([[18., 14.,  1.,  8.]])
    >>> region_boxes(img, rows, cols, np.array([0, 0]), box, (160, 190))
    array([[17., 10.,  6., 16.]])
    """
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    out = boxes.copy()
    if len(boxes) == 0:
        return out
    h, w = image.shape
    lo, hi = float(band[0]), float(band[1])
    rr, rc = int(reach[0]), int(reach[1])
    rows = np.asarray(rows, dtype=np.intp)
    cols = np.asarray(cols, dtype=np.intp)
    labels = np.asarray(labels, dtype=np.intp)
    for k, (left, top, bw, bh) in enumerate(boxes.tolist()):
        r0 = max(int(top) - rr, 0)
        c0 = max(int(left) - rc, 0)
        r1 = min(int(top + bh) + rr, h)
        c1 = min(int(left + bw) + rc, w)
        window = image[r0:r1, c0:c1]
        mask = ((window >= lo) & (window <= hi)).view(np.uint8)
        _, comp = cv2.connectedComponents(mask, connectivity=8)
        member = labels == k
        seeds = np.unique(comp[rows[member] - r0, cols[member] - c0])
        seeds = seeds[seeds > 0]
        if len(seeds) == 0:
            continue
        ys, xs = np.nonzero(np.isin(comp, seeds) if len(seeds) > 1 else comp == seeds[0])
        y0 = min(int(ys.min()) + r0, int(top))
        x0 = min(int(xs.min()) + c0, int(left))
        y1 = max(int(ys.max()) + r0 + 1, int(top + bh))
        x1 = max(int(xs.max()) + c0 + 1, int(left + bw))
        out[k] = (x0, y0, x1 - x0, y1 - y0)
    return out


class MSTClusterer(TransformerMixin, BaseEstimator):
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
    box : {"keypoints", "region"}, default="keypoints"
        Frame mode: the rectangle of each cluster.  ``"keypoints"`` (the paper's):
        the smallest rectangle of its keypoints, quantized to the 7 x 6 px grid.
        ``"region"``: that rectangle refined on the image to the in-band pixels
        connected to the keypoints (:func:`region_boxes`), which gives the object's
        own extent: a stable centre and scale for tracking and the whole sign for the
        appearance histogram.  :func:`~tunnelsense.tunnel.make_indicator_pipeline`
        uses ``"region"``.
    band : (float, float) or None, default=None
        ``box="region"``: the intensity band of the region.  ``None`` takes the band
        :class:`IntensityKeypointSampler` used, from ``payload["keypoint_band"]``.
    reach : (int, int), default=(14, 12)
        ``box="region"``: how far (rows, columns; px) the region may extend beyond the
        keypoints' rectangle (two grid steps).

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
        "cut": [Interval(numbers.Real, 0, None, closed="left")],
        "box": [StrOptions({"keypoints", "region"})],
        "band": [tuple, list, None],
        "reach": [tuple, list],
    }

    def __init__(self, cut=40.0, *, box="keypoints", band=None, reach=(14, 12)):
        self.cut = cut
        self.box = box
        self.band = band
        self.reach = reach

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.transformer_tags.preserves_dtype = ["float64"]
        return tags

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y=None):
        """Validate the input; in tabular mode, partition the points.

        Parameters
        ----------
        X : sequence of FrameRecord, or array-like of shape (n_samples, n_features)
            Frame records with ``payload["keypoints"]`` (frame mode) or points
            (tabular mode).
        y : ignored in tabular mode; per-frame boxes in frame mode (validated only).

        Returns
        -------
        self : MSTClusterer
        """
        if is_record_input(X):
            records, _ = check_frames(X, y)
            for i, r in enumerate(records):
                keypoints_of(r, i, "MSTClusterer")
            self.n_frames_fit_ = len(records)
            return self
        X = validate_data(self, X, dtype=np.float64)
        self.X_fit_ = X
        self.labels_ = mst_partition(X, self.cut)
        self.n_clusters_ = int(self.labels_.max()) + 1
        return self

    def fit_predict(self, X, y=None):
        """Partition 2-D points (tabular mode) and return the labels.

        Returns
        -------
        labels : ndarray of shape (n_samples,), intp
        """
        if is_record_input(X):
            raise TypeError(
                "fit_predict takes a 2-D array of points; for frame records use "
                "fit_transform, which stores the labels in payload['cluster_labels']"
            )
        return self.fit(X, y).labels_

    def transform(self, X):
        """Cluster each frame's keypoints, or measure distances to fitted clusters.

        Parameters
        ----------
        X : sequence of FrameRecord, or array-like of shape (n_samples, n_features)

        Returns
        -------
        X_new : FrameSequence or ndarray of shape (n_samples, n_clusters)
            Frame mode: the evolved records (see the class docstring).  Tabular mode:
            the distance from every point to the nearest member of each fitted cluster.
        """
        if is_record_input(X):
            check_is_fitted(self)
            records, _ = check_frames(X)
            return self._transform_records(records)
        check_is_fitted(self, "X_fit_")
        X = validate_data(self, X, dtype=np.float64, reset=False)
        order = np.argsort(self.labels_, kind="stable")
        starts = np.searchsorted(self.labels_[order], np.arange(self.n_clusters_))
        fit_sorted = self.X_fit_[order]
        out = np.empty((len(X), self.n_clusters_))
        for lo in range(0, len(X), 1024):
            chunk = X[lo : lo + 1024]
            d = chunk[:, None, :] - fit_sorted[None, :, :]
            d = np.sqrt(np.einsum("ijk,ijk->ij", d, d))
            out[lo : lo + 1024] = np.minimum.reduceat(d, starts, axis=1)
        return out

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
        try:
            return tuple(record.payload["keypoint_band"])
        except KeyError:
            raise ValueError(
                f"X[{index}] ({record.tour!r}, frame {record.frame}) has no "
                "payload['keypoint_band']: MSTClusterer(box='region') needs band=(low, "
                "high) or frames that went through IntensityKeypointSampler"
            ) from None

    def _transform_records(self, records):
        cut = float(self.cut)
        region = self.box == "region"
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
            if region and len(boxes):
                boxes = region_boxes(
                    r.image, rows, cols, labels, boxes, self._band_of(r, i), reach
                )
            out.append(r.evolve(cluster_labels=labels, cluster_boxes=boxes))
        return FrameSequence(out)
