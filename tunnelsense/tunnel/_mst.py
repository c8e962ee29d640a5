"""Keypoint clustering (section 3.3), the math: cut the minimum spanning tree.

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

The clusters' rectangles are in :mod:`tunnelsense.tunnel._mst_boxes` (re-exported here).
"""

from __future__ import annotations

import numbers

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from tunnelsense.tunnel._mst_boxes import cluster_boxes, cluster_windows, region_boxes
from tunnelsense.utils._sklearn_compat import Interval, _fit_context, validate_data

__all__ = [
    "DENSE_MAX_POINTS",
    "MSTClustererCore",
    "cluster_boxes",
    "mst_partition",
    "cluster_windows",
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
    # are joined without special care.  SciPy's spatial module is imported here, on
    # the first set of more than DENSE_MAX_POINTS points (a frame's keypoints seldom
    # are): a short command that never meets one does not pay its import
    from scipy.spatial import cKDTree  # noqa: PLC0415

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
    from scipy.spatial import Delaunay, QhullError  # noqa: PLC0415 (see _pair_partition)

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


class MSTClustererCore(TransformerMixin, BaseEstimator):
    """Single-linkage partition of 2-D points: cut MST edges longer than ``cut``.

    The tabular core of :class:`~tunnelsense.tunnel.MSTClusterer`.  ``fit`` sets
    ``labels_``, the partition of ``X`` into connected components of the ``<= cut``
    neighbour graph (identical to cutting the MST; duplicate points share a cluster);
    ``fit_predict`` returns it; ``transform`` gives, for new points, the single-linkage
    distance to every fitted cluster (the distance to its nearest member).  It is not
    a :class:`~sklearn.base.ClusterMixin`: its ``cut`` is an absolute length in
    pixels, not a scale-free setting that scikit-learn's clustering checks on
    standardized blobs could meaningfully test.

    Parameters
    ----------
    cut : float, default=40.0
        MST edges longer than this are removed.

    Attributes
    ----------
    labels_ : ndarray of shape (n_samples,)
        Cluster of every fitted point, by first occurrence.
    n_clusters_ : int
        Number of clusters of the fitted points.
    X_fit_ : ndarray of shape (n_samples, n_features)
        The fitted points (used by ``transform``).
    n_features_in_ : int
        Number of coordinates per point.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.tunnel._mst import MSTClustererCore
    >>> MSTClustererCore(cut=40).fit_predict(np.array([[0, 0], [0, 30], [0, 100.]]))
    array([0, 0, 1])
    """

    _parameter_constraints: dict = {
        "cut": [Interval(numbers.Real, 0, None, closed="left")],
    }

    def __init__(self, cut=40.0):
        self.cut = cut

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.transformer_tags.preserves_dtype = ["float64"]
        return tags

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y=None):
        """Partition the points.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        y : ignored

        Returns
        -------
        self : MSTClustererCore
        """
        X = validate_data(self, X, dtype=np.float64)
        self.X_fit_ = X
        self.labels_ = mst_partition(X, self.cut)
        self.n_clusters_ = int(self.labels_.max()) + 1
        return self

    def fit_predict(self, X, y=None):
        """Partition the points and return the labels.

        Returns
        -------
        labels : ndarray of shape (n_samples,), intp
        """
        return self.fit(X, y).labels_

    def transform(self, X):
        """The distance from every point to the nearest member of each fitted cluster.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)

        Returns
        -------
        distances : ndarray of shape (n_samples, n_clusters_)
        """
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
