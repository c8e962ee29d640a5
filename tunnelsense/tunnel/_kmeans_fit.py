"""Keypoint verification (section 3.2), the math: k-means centres of histograms,
the paper's ``Eu`` ranking of positive centres (eq. 3) and the verification rule,
as array-in/array-out functions; :class:`~tunnelsense.tunnel._kmeans.KMeansHistogramCore`
is the tabular estimator that wraps them.
"""

from __future__ import annotations

import contextlib
import functools

import numpy as np
from sklearn.utils import check_random_state
from threadpoolctl import ThreadpoolController

from tunnelsense.tunnel._kmeans_grid import (
    grid_quantum,
    grid_sq_distances,
    kmeans_plusplus,
    lloyd,
    minibatch_kmeans,
    shifted_sq_distances,
    to_grid,
)

__all__ = [
    "blas_threads",
    "fit_kmeans",
    "rank_positive_centers",
    "verify_histograms",
]

@functools.lru_cache(maxsize=1)
def _controller():
    # finding the loaded BLAS libraries costs about 0.5 ms: once per process
    return ThreadpoolController()


#: The BLAS thread limit a :func:`blas_threads` context has set, process-wide
#: (as the limit itself is), or None.
_IN_FORCE = [None]


@contextlib.contextmanager
def blas_threads(n_jobs=None):
    """A context in which BLAS uses at most ``n_jobs`` threads (``None``: one).

    Spinning BLAS threads make the small products of k-means and of the
    verification several times slower on a busy machine; no result depends on the
    thread count (the distances are exact, see :func:`fit_kmeans`).  Inside a
    context that set a limit at most as large, nothing is done: the verifier,
    called frame by frame inside the detector's own limit, does not set it again
    for every frame.

    Examples
    --------
    >>> from tunnelsense.tunnel._kmeans_fit import blas_threads
    >>> with blas_threads(1):
    ...     with blas_threads(2):  # within the outer limit of one thread: nothing set
    ...         pass
    """
    n = int(n_jobs or 1)
    if _IN_FORCE[0] is not None and _IN_FORCE[0] <= n:
        yield
        return
    with _controller().limit(limits=n, user_api="blas"):
        outer, _IN_FORCE[0] = _IN_FORCE[0], n
        try:
            yield
        finally:
            _IN_FORCE[0] = outer


def fit_kmeans(
    X, n_clusters, *, batch_size=4096, n_steps=100, max_full_samples=20_000,
    random_state=None, sample_indices=None, n_jobs=None, quantum=None,
) -> np.ndarray:
    """k-means centres of ``X``, exact for small sets, mini-batch for large ones.

    * at most ``n_clusters`` distinct rows (looked for when ``n_samples`` is at most
      ``max(max_full_samples, 4 * n_clusters)``): the distinct rows are the centres.
    * ``n_samples <= max_full_samples``: Lloyd's algorithm from a greedy k-means++
      seeding (scikit-learn's :class:`~sklearn.cluster.KMeans` with one init).
    * otherwise: mini-batch k-means (scikit-learn's ``MiniBatchKMeans.partial_fit``)
      with ``n_steps`` batches of ``batch_size`` rows drawn uniformly at random,
      the first batch (at least ``3 * n_clusters`` rows) seeding k-means++.  Memory
      beyond ``X`` stays at a few batches.

    The rows are rounded to multiples of ``quantum`` (a power of two) and every
    distance is computed exactly on that grid (see
    :mod:`tunnelsense.tunnel._kmeans_grid`): the centres are the same on every CPU,
    BLAS kernel and thread count.

    Parameters
    ----------
    X : ndarray of shape (n_rows, n_features)
        The rows (histograms).
    n_clusters : int
        k.
    batch_size, n_steps, max_full_samples : int
        See above.
    random_state : int, RandomState instance or None, default=None
        Seeds the initialisation and the batches.
    sample_indices : ndarray of int or None, default=None
        Cluster only these rows of ``X`` (``None``: all), without copying them out of
        a large ``X``: the result equals ``fit_kmeans(X[sample_indices], ...)``.
    n_jobs : int or None, default=None
        BLAS threads (``None``: one, which is fastest on a shared machine); the
        centres do not depend on it.
    quantum : float or None, default=None
        The grid; ``None``: ``grid_quantum(max |X|, n_features)``.

    Returns
    -------
    centers : ndarray of shape (n_centers, n_features), float64
        Multiples of ``quantum``; ``n_centers = min(n_clusters, number of distinct
        rows)``.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.tunnel import fit_kmeans
    >>> X = np.array([[0, 0], [0, 0.2], [1, 1], [1, 1.2]] * 25)
    >>> C = fit_kmeans(X, 2, random_state=0)
    >>> C[np.argsort(C[:, 0])].round(3).tolist()
    [[0.0, 0.1], [1.0, 1.1]]
    """
    if sample_indices is not None:
        sample_indices = np.asarray(sample_indices, dtype=np.intp)
    if quantum is None:
        rows = X if sample_indices is None else X[sample_indices]
        quantum = grid_quantum(np.abs(rows).max(initial=0.0), np.shape(X)[1])
    with blas_threads(n_jobs):
        U = _fit_kmeans(X, n_clusters, batch_size, n_steps, max_full_samples,
                        check_random_state(random_state), sample_indices, quantum)
    return U * quantum


def _fit_kmeans(X, n_clusters, batch_size, n_steps, max_full_samples, rng,
                sample_indices, quantum):
    n = len(X) if sample_indices is None else len(sample_indices)
    if n <= max(max_full_samples, 4 * n_clusters):
        rows = X if sample_indices is None else X[sample_indices]
        U = to_grid(rows, quantum)
        if _at_most_distinct(U, n_clusters):
            return np.unique(U, axis=0)
    if n <= max_full_samples:
        seeds = kmeans_plusplus(U, n_clusters, rng)
        return lloyd(U, seeds)

    def take(idx):
        return to_grid(X[idx] if sample_indices is None else X[sample_indices[idx]],
                       quantum)

    batch = max(int(batch_size), 3 * n_clusters)
    return minibatch_kmeans(take, n, n_clusters, batch_size=batch,
                            n_steps=n_steps, rng=rng)


def _at_most_distinct(U, k) -> bool:
    """Whether the rows of ``U`` hold at most ``k`` distinct rows.

    Equal rows have equal weighted sums, so more than ``k`` distinct weighted sums
    prove more than ``k`` distinct rows: that (the usual answer) takes one product
    and a sort of ``len(U)`` numbers instead of sorting the rows themselves;
    otherwise the rows are counted exactly.  The weights are integers below 2**10
    and the rows grid integers (:func:`~tunnelsense.tunnel._kmeans_grid.to_grid`),
    so every sum is an integer below 2**53, exact in any order of summation.
    """
    if len(U) <= k:
        return True
    weights = np.random.default_rng(0).integers(1, 1024, U.shape[1]).astype(np.float64)
    if len(np.unique(U @ weights)) > k:
        return False
    return len(np.unique(U, axis=0)) <= k


def rank_positive_centers(positive_centers, negative_centers, *, quantum=None):
    """The paper's ``Eu`` (eq. 3): mean distance of each positive centre to the negative ones.

    With ``quantum`` (the grid of :func:`fit_kmeans`) the distances are exact on
    that grid, so the ranking is the same on every CPU.
    """
    p = np.asarray(positive_centers, dtype=np.float64)
    q = np.asarray(negative_centers, dtype=np.float64)
    if quantum is not None:
        d2 = grid_sq_distances(to_grid(p, quantum), to_grid(q, quantum))
        return np.sqrt(np.maximum(d2, 0)).mean(axis=1) * float(quantum)
    d2 = (p * p).sum(1)[:, None] - 2 * p @ q.T + (q * q).sum(1)[None, :]
    return np.sqrt(np.maximum(d2, 0)).mean(axis=1)


def _distances(H, centers, quantum):
    """Distances from each histogram row to every centre, shape (n, n_centers);
    exact on the grid of ``quantum`` unless it is None."""
    H = np.asarray(H, dtype=np.float64)
    if quantum is not None:
        d2 = grid_sq_distances(to_grid(H, quantum), to_grid(centers, quantum))
        return np.sqrt(np.maximum(d2, 0)) * float(quantum)
    d2 = (H * H).sum(1)[:, None] - 2 * H @ centers.T + (centers * centers).sum(1)[None, :]
    return np.sqrt(np.maximum(d2, 0))


def _nearest_distance(H, centers, quantum=None):
    """Distance from each histogram row to its nearest centre, shape (n,).

    The least squared distance first, then its root: the same value as the least
    root (both are monotone), for one root a row instead of one a centre.
    """
    if not len(centers):
        return np.full(len(H), np.inf)
    H = np.asarray(H, dtype=np.float64)
    if quantum is not None:
        # the least of ||c||^2 - 2 h.c, then ||h||^2 added: exact, as the full table
        U = to_grid(H, quantum)
        d2 = shifted_sq_distances(U, to_grid(centers, quantum)).min(axis=1)
        d2 += (U * U).sum(1)
        return np.sqrt(np.maximum(d2, 0)) * float(quantum)
    d2 = ((H * H).sum(1)[:, None] - 2 * H @ centers.T
          + (centers * centers).sum(1)[None, :]).min(axis=1)
    return np.sqrt(np.maximum(d2, 0))


def verify_histograms(H, centers, negative_centers, *, max_distance, margin=None,
                      quantum=None):
    """The verification rule: which histograms are verified, shape (n,) bool.

    A histogram ``h`` is verified when ``d_pos(h) <= max_distance`` (the paper's
    rule: ``d_pos`` is the distance to the nearest kept positive centre) and, unless
    ``margin`` is None, ``d_pos(h) <= d_neg(h) + margin`` (``d_neg``: the distance to
    the nearest negative centre).  With ``quantum`` (the grid of the centres, see
    :func:`fit_kmeans`) the histograms are rounded to that grid and the distances
    are exact, so the decision is the same on every CPU.

    Examples
    --------
    >>> import numpy as np
    >>> P, N = np.array([[1.0, 0, 0]]), np.array([[0.0, 1, 0], [0.5, 0.5, 0]])
    >>> H = np.array([[0.9, 0.1, 0], [0.6, 0.4, 0]])
    >>> verify_histograms(H, P, N, max_distance=0.6).tolist()
    [True, True]
    >>> verify_histograms(H, P, N, max_distance=0.6, margin=0.0).tolist()
    [True, False]
    """
    centers = np.asarray(centers, dtype=np.float64)
    neg = np.asarray(negative_centers, dtype=np.float64)
    H = np.asarray(H, dtype=np.float64)
    d_pos = _nearest_distance(H, centers, quantum)
    keep = d_pos <= max_distance
    if margin is not None and keep.any():
        # only the rows the paper's test kept need the 400 negative centres
        rows = np.flatnonzero(keep)
        d_neg = _nearest_distance(H[rows], neg, quantum)
        keep[rows] = d_pos[rows] <= d_neg + margin
    return keep
