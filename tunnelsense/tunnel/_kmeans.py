"""Keypoint verification (section 3.2), the math: k-means centres of histograms.

Training clusters the histograms of positive keypoints (inside indicator boxes, k=40)
and of negative ones (k=400) with k-means, scores every positive centre by its mean
Euclidean distance to the negative centres (the paper's ``Eu``, eq. 3) and keeps the
``n_centers`` best (the paper's 10).  A histogram is verified when it lies within
``max_distance`` of its nearest kept centre and, unless ``margin`` is None, at most
``margin`` farther from it than from its nearest negative centre.
:class:`KMeansHistogramCore` is the tabular estimator of this rule; the functions
it wraps are in :mod:`tunnelsense.tunnel._kmeans_fit`.
"""

from __future__ import annotations

import numbers

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_is_fitted, column_or_1d

from tunnelsense.tunnel._kmeans_fit import (
    _distances,
    _nearest_distance,
    blas_threads,
    fit_kmeans,
    rank_positive_centers,
    verify_histograms,
)
from tunnelsense.tunnel._kmeans_grid import grid_quantum
from tunnelsense.utils._sklearn_compat import Interval, _fit_context, validate_data

__all__ = [
    "KMeansHistogramCore",
    "blas_threads",
    "fit_kmeans",
    "rank_positive_centers",
    "verify_histograms",
]


class KMeansHistogramCore(TransformerMixin, BaseEstimator):
    """Verify histograms by the k-means centres of the positive ones (section 3.2).

    The tabular core of :class:`~tunnelsense.tunnel.KMeansHistogramVerifier`.
    ``fit(X, y)`` clusters the rows of ``X`` whose ``y`` is ``pos_label`` (k =
    ``n_positive_clusters``) and the others (k = ``n_negative_clusters``) with
    :func:`fit_kmeans`, scores every positive centre by its mean distance to the
    negative centres (:func:`rank_positive_centers`) and keeps the ``n_centers``
    best.  ``predict`` gives 1 for the rows :func:`verify_histograms` verifies, else
    0; ``transform`` the distances to the kept centres.  It is not a
    :class:`~sklearn.base.ClassifierMixin`: it models the positive class only (a
    mixture of its centres and one radius), so accuracy on arbitrary labelled blobs
    is not what it promises.

    Parameters
    ----------
    n_positive_clusters : int, default=40
        k of k-means on the positive histograms.
    n_negative_clusters : int, default=400
        k of k-means on the negative histograms.
    n_centers : int or None, default=None
        Number of positive centres kept, those farthest on average from the negative
        centres (the paper keeps 10); ``None`` keeps them all.
    max_distance : float, default=0.4
        A histogram is verified only when its Euclidean distance to the nearest kept
        centre is at most this.
    margin : float or None, default=0.04
        A histogram is verified only when its distance to the nearest kept centre
        exceeds its distance to the nearest negative centre by at most ``margin``;
        ``None`` drops this test (the paper's rule).
    batch_size : int, default=4096
        Rows per mini-batch of the large-set k-means.
    n_steps : int, default=100
        Mini-batches drawn (uniformly, with replacement) for a large-set k-means
        (100 batches of 4,096 rows: within 1 % of the inertia of 300 batches on
        histograms, at a third of the cost).
    max_full_samples : int, default=20000
        A set of at most this many rows is clustered with full Lloyd k-means, a
        larger one with mini-batch k-means (:func:`fit_kmeans`).
    pos_label : int, float, bool or str, default=1
        The value of ``y`` that marks a positive histogram.
    random_state : int, RandomState instance or None, default=None
        Seeds k-means (initialisation and batches).
    n_jobs : int or None, default=None
        BLAS threads of k-means (``None``: one).  The centres do not depend on it.

    Attributes
    ----------
    positive_centers_ : ndarray of shape (n_positive_centers, n_features_in_)
        k-means centres of the positive rows.
    negative_centers_ : ndarray of shape (n_negative_centers, n_features_in_)
        k-means centres of the negative rows.
    center_scores_ : ndarray of shape (n_positive_centers,)
        The paper's ``Eu`` of every positive centre: its mean distance to the
        negative centres.
    centers_ : ndarray of shape (n_centers_, n_features_in_)
        The kept positive centres, best (largest ``Eu``) first.
    n_centers_ : int
        Number of kept centres (fewer than ``n_centers`` when there are fewer
        distinct positive rows).
    n_positive_, n_negative_ : int
        Numbers of positive and negative rows used in ``fit``.
    quantum_ : float
        The grid (a power of two) that the rows, the centres and the histograms to
        verify are rounded to, so that every distance is exact and every decision
        the same on every CPU (see :func:`fit_kmeans`).
    n_features_in_ : int
        Number of columns of ``X``.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.tunnel._kmeans import KMeansHistogramCore
    >>> rng = np.random.default_rng(0)
    >>> pos = rng.dirichlet(np.r_[np.ones(4), 50 * np.ones(2), np.ones(2)], 200)
    >>> neg = rng.dirichlet(np.r_[50 * np.ones(2), np.ones(6)], 2000)
    >>> X, y = np.vstack([pos, neg]), np.r_[np.ones(200), np.zeros(2000)]
    >>> v = KMeansHistogramCore(random_state=0).fit(X, y)
    >>> float(v.predict(pos).mean()) > 0.9, float(v.predict(neg).mean()) < 0.01
    (True, True)
    """

    _parameter_constraints: dict = {
        "n_positive_clusters": [Interval(numbers.Integral, 1, None, closed="left")],
        "n_negative_clusters": [Interval(numbers.Integral, 1, None, closed="left")],
        "n_centers": [Interval(numbers.Integral, 1, None, closed="left"), None],
        "max_distance": [Interval(numbers.Real, 0, None, closed="left")],
        "margin": [Interval(numbers.Real, None, None, closed="neither"), None],
        "batch_size": [Interval(numbers.Integral, 1, None, closed="left")],
        "n_steps": [Interval(numbers.Integral, 1, None, closed="left")],
        "max_full_samples": [Interval(numbers.Integral, 1, None, closed="left")],
        "pos_label": [numbers.Real, str, "boolean"],
        "random_state": ["random_state"],
        "n_jobs": [Interval(numbers.Integral, 1, None, closed="left"), None],
    }

    def __init__(
        self,
        *,
        n_positive_clusters=40,
        n_negative_clusters=400,
        n_centers=None,
        max_distance=0.4,
        margin=0.04,
        batch_size=4096,
        n_steps=100,
        max_full_samples=20_000,
        pos_label=1,
        random_state=None,
        n_jobs=None,
    ):
        self.n_positive_clusters = n_positive_clusters
        self.n_negative_clusters = n_negative_clusters
        self.n_centers = n_centers
        self.max_distance = max_distance
        self.margin = margin
        self.batch_size = batch_size
        self.n_steps = n_steps
        self.max_full_samples = max_full_samples
        self.pos_label = pos_label
        self.random_state = random_state
        self.n_jobs = n_jobs

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.required = True
        return tags

    def _check_settings(self):
        """Check the parameters the constraints cannot express (none here)."""

    def _fit_centers(self, positive, negative, positive_rows=None, negative_rows=None):
        """k-means of both sets; ``*_rows`` (index arrays) select them from one
        array given as both ``positive`` and ``negative`` (no copy of the data)."""
        n_pos = len(positive) if positive_rows is None else len(positive_rows)
        n_neg = len(negative) if negative_rows is None else len(negative_rows)
        if n_pos == 0 or n_neg == 0:
            which = "positive" if n_pos == 0 else "negative"
            raise ValueError(
                f"{type(self).__name__} needs positive and negative histograms; y "
                f"has only 1 class (no {which} sample among {n_pos + n_neg})"
            )
        rng = check_random_state(self.random_state)

        def max_abs(rows, idx):
            # the largest of max and -min: |x|.max() without a copy of the rows
            rows = rows if idx is None else rows[idx]
            if not np.size(rows):
                return 0.0
            return float(np.max([np.max(rows), -np.min(rows), 0.0]))

        self.quantum_ = grid_quantum(
            max(max_abs(positive, positive_rows), max_abs(negative, negative_rows)),
            np.shape(positive)[1],
        )
        kw = dict(
            batch_size=self.batch_size,
            n_steps=self.n_steps,
            max_full_samples=self.max_full_samples,
            n_jobs=self.n_jobs,
            quantum=self.quantum_,
        )
        self.positive_centers_ = fit_kmeans(
            positive, self.n_positive_clusters, random_state=rng,
            sample_indices=positive_rows, **kw
        )
        self.negative_centers_ = fit_kmeans(
            negative, self.n_negative_clusters, random_state=rng,
            sample_indices=negative_rows, **kw
        )
        self.center_scores_ = rank_positive_centers(
            self.positive_centers_, self.negative_centers_, quantum=self.quantum_
        )
        order = np.argsort(-self.center_scores_, kind="stable")[: self.n_centers]
        self.centers_ = self.positive_centers_[order]
        self.n_centers_ = len(self.centers_)
        self.n_positive_, self.n_negative_ = n_pos, n_neg

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y):
        """Learn the positive centres from labelled histograms.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_bins)
        y : array-like of shape (n_samples,)
            ``pos_label`` for positive histograms.

        Returns
        -------
        self : object
        """
        self._check_settings()
        X, y = validate_data(
            self, X, y, dtype=[np.float64, np.float32], y_numeric=False
        )
        y = column_or_1d(y)
        positive = y == self.pos_label
        self._fit_centers(X, X, np.flatnonzero(positive), np.flatnonzero(~positive))
        return self

    def distances(self, X):
        """Distance from every histogram to its nearest kept centre (tabular mode).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_bins)

        Returns
        -------
        distances : ndarray of shape (n_samples,)
        """
        check_is_fitted(self)
        X = validate_data(self, X, dtype=[np.float64, np.float32], reset=False)
        return _nearest_distance(X, self.centers_, self.quantum_)

    def _verified(self, H):
        """Boolean mask of the verified rows of ``H`` (see :func:`verify_histograms`)."""
        margin = None if self.margin is None else float(self.margin)
        return verify_histograms(
            H, self.centers_, self.negative_centers_,
            max_distance=float(self.max_distance), margin=margin, quantum=self.quantum_,
        )

    def predict(self, X):
        """1 for verified histograms, else 0.

        A histogram is verified when it lies within ``max_distance`` of its nearest
        kept centre and, unless ``margin`` is None, is at most ``margin`` farther
        from it than from the nearest negative centre.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_bins)

        Returns
        -------
        verified : ndarray of shape (n_samples,), int
        """
        check_is_fitted(self)
        X = validate_data(self, X, dtype=[np.float64, np.float32], reset=False)
        return self._verified(X).astype(np.int64)

    def transform(self, X):
        """The distance of every histogram to every kept centre.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_bins)

        Returns
        -------
        distances : ndarray of shape (n_samples, n_centers_)
        """
        check_is_fitted(self)
        X = validate_data(self, X, dtype=[np.float64, np.float32], reset=False)
        return _distances(X, self.centers_, self.quantum_)
