"""k-means whose every decision is the same on every CPU.

BLAS kernels (and so scikit-learn's k-means) sum dot products in an order that
depends on the processor: two machines then disagree in the last bits of a
distance, a near-tie in an assignment goes the other way, and the centres of a
long k-means drift apart.  Here the rows and the centres live on one grid: every
value is an integer multiple of a power-of-two ``quantum`` small enough to be
invisible in a histogram (2**-22 for values up to 1 in 64 columns) and large enough
that every product and every partial sum of a squared distance is an integer below
2**53.  Such sums are exact in float64 in any order, so a BLAS product of grid
values is the same on every CPU, whatever kernel or thread count computes it; ties
go to the lower centre index, and the rest (means, rounding to the grid) are single
IEEE operations, which every CPU rounds alike.

The functions take and return grid integers stored as float64 (``to_grid`` makes
them); :func:`tunnelsense.tunnel.fit_kmeans` is the public entry point.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "grid_quantum",
    "grid_sq_distances",
    "kmeans_plusplus",
    "lloyd",
    "minibatch_kmeans",
    "shifted_sq_distances",
    "to_grid",
]

# ||u||^2 + ||c||^2 + 2 |u.c| <= 4 d M^2 must stay below 2**53 (exact integers)
_EXACT = 2.0**51


def grid_quantum(max_abs, n_features) -> float:
    """The finest power of two on which ``n_features`` columns of values up to
    ``max_abs`` give exact squared distances in float64.

    Examples
    --------
    >>> grid_quantum(1.0, 64) == 2.0**-22
    True
    """
    max_abs = float(max_abs)
    if not math.isfinite(max_abs):
        raise ValueError(f"grid_quantum: values must be finite, got max |x| = {max_abs}")
    if max_abs <= 0:
        return 1.0
    limit = math.sqrt(_EXACT / max(int(n_features), 1))  # largest grid integer
    return 2.0 ** math.ceil(math.log2(max_abs / limit))


def to_grid(X, quantum) -> np.ndarray:
    """``X`` as integers on the grid of ``quantum`` (float64; round half to even)."""
    return np.rint(np.asarray(X, dtype=np.float64) / float(quantum))


def grid_sq_distances(U, C, U_sq=None, C_sq=None) -> np.ndarray:
    """Exact squared distances between grid rows ``U`` and grid centres ``C``.

    Shape (len(U), len(C)); float64 holding integers, identical on every CPU.
    """
    if U_sq is None:
        U_sq = (U * U).sum(1)
    if C_sq is None:
        C_sq = (C * C).sum(1)
    d2 = U @ C.T
    d2 *= -2.0
    d2 += U_sq[:, None]
    d2 += C_sq[None, :]
    return d2


def shifted_sq_distances(U, C, C_sq=None) -> np.ndarray:
    """``grid_sq_distances(U, C)`` less each row's ``||u||^2``: ``||c||^2 - 2 u.c``.

    Exact on the grid as the full distances are (``-2 C`` is exact, and every
    partial sum stays within the grid's bound), so a row's nearest centre, its ties
    and, with ``||u||^2`` added back, its distance are those of
    :func:`grid_sq_distances`, for two passes over the (rows, centres) table
    fewer.
    """
    if C_sq is None:
        C_sq = (C * C).sum(1)
    e = U @ (-2.0 * C).T
    e += C_sq[None, :]
    return e


def _nearest(U, C, U_sq, chunk=4096):
    """Index of (first) nearest centre and the squared distance to it."""
    C_sq = (C * C).sum(1)
    C2 = -2.0 * C
    labels = np.empty(len(U), dtype=np.intp)
    dist = np.empty(len(U))
    for start in range(0, len(U), chunk):
        e = U[start:start + chunk] @ C2.T
        e += C_sq[None, :]
        lab = e.argmin(1)
        labels[start:start + chunk] = lab
        dist[start:start + chunk] = e[np.arange(len(lab)), lab] + U_sq[start:start + chunk]
    return labels, dist


def _sums(U, labels, k):
    """Per-centre sums of the rows (exact: sums of grid integers) and counts."""
    counts = np.bincount(labels, minlength=k).astype(np.float64)
    sums = np.empty((k, U.shape[1]))
    for j in range(U.shape[1]):
        sums[:, j] = np.bincount(labels, weights=U[:, j], minlength=k)
    return sums, counts


def kmeans_plusplus(U, k, rng, U_sq=None) -> np.ndarray:
    """Greedy k-means++ seeding (``2 + log k`` trials a centre, as scikit-learn's).

    ``U``: grid rows with at least ``k`` rows; ``rng``: a ``RandomState``.
    Returns ``k`` rows of ``U`` (copies).
    """
    n = len(U)
    if U_sq is None:
        U_sq = (U * U).sum(1)
    trials = 2 + int(np.log(k))
    centers = np.empty((k, U.shape[1]))
    first = rng.randint(n)
    centers[0] = U[first]
    closest = grid_sq_distances(U, U[first:first + 1], U_sq, U_sq[first:first + 1])[:, 0]
    potential = closest.sum()
    for c in range(1, k):
        if potential <= 0:  # fewer distinct rows than k: take any row
            pick = rng.randint(n)
            centers[c] = U[pick]
            continue
        draws = rng.uniform(size=trials) * potential
        candidates = np.searchsorted(np.cumsum(closest), draws)
        np.clip(candidates, None, n - 1, out=candidates)
        d2 = grid_sq_distances(U, U[candidates], U_sq, U_sq[candidates])
        np.minimum(closest[:, None], d2, out=d2)
        pots = d2.sum(0)
        best = int(np.argmin(pots))
        potential = pots[best]
        closest = d2[:, best].copy()
        centers[c] = U[candidates[best]]
    return centers


def lloyd(U, centers, *, max_iter=300, tol=1e-4) -> np.ndarray:
    """Lloyd iterations on grid rows from grid ``centers``; grid centres out.

    Stops when no label changes, or when the squared shift of all centres is at
    most ``tol`` times the mean variance of the columns (scikit-learn's rule).  An
    empty cluster takes the row farthest from its centre.
    """
    U_sq = (U * U).sum(1)
    k = len(centers)
    tol_abs = float(tol) * float(np.mean(np.var(U, axis=0)))
    labels = None
    for _ in range(int(max_iter)):
        new_labels, dist = _nearest(U, centers, U_sq)
        if labels is not None and np.array_equal(new_labels, labels):
            break
        labels = new_labels
        sums, counts = _sums(U, labels, k)
        empty = np.flatnonzero(counts == 0)
        new = centers.copy()
        full = counts > 0
        new[full] = np.rint(sums[full] / counts[full, None])
        if len(empty):
            far = np.argsort(-dist, kind="stable")[: len(empty)]
            new[empty] = U[far]
        shift = float(((new - centers) ** 2).sum())
        centers = new
        if shift <= tol_abs:
            break
    return centers


def minibatch_kmeans(take, n, k, *, batch_size, n_steps, rng,
                     reassignment_ratio=0.01) -> np.ndarray:
    """Mini-batch k-means (Sculley, 2010) on grid rows, as scikit-learn's
    ``MiniBatchKMeans.partial_fit`` on uniformly drawn batches.

    ``take(indices)`` returns those grid rows of the ``n`` rows; the first batch
    (``max(batch_size, 3 k)`` rows without replacement) seeds k-means++, then
    ``n_steps - 1`` batches of ``batch_size`` rows (with replacement) move each
    centre to the running mean of the rows it won; centres that won less than
    ``reassignment_ratio`` of the busiest one move to random rows of the batch.
    """
    first = np.sort(rng.choice(n, min(max(batch_size, 3 * k), n), replace=False))
    batch = take(first)
    centers = kmeans_plusplus(batch, k, rng)
    weights = np.zeros(k)
    since_reassign = 0

    def step(B, reassign):
        nonlocal centers, weights
        labels, _ = _nearest(B, centers, (B * B).sum(1))
        sums, counts = _sums(B, labels, k)
        won = counts > 0
        total = weights[won] + counts[won]
        centers[won] = np.rint((centers[won] * weights[won, None] + sums[won])
                               / total[:, None])
        weights[won] = total
        if reassign and reassignment_ratio > 0:
            low = weights < reassignment_ratio * weights.max()
            if low.sum() > 0.5 * len(B):
                keep = np.argsort(weights, kind="stable")[int(0.5 * len(B)):]
                low[keep] = False
            if low.any():
                centers[low] = B[rng.choice(len(B), size=int(low.sum()), replace=False)]
                if (~low).any():
                    weights[low] = weights[~low].min()

    for i in range(int(n_steps)):
        if i:
            batch = take(np.sort(rng.randint(0, n, batch_size)))
        since_reassign += len(batch)
        reassign = bool((weights == 0).any()) or since_reassign >= 10 * k
        if reassign:
            since_reassign = 0
        step(batch, reassign and i > 0)
    return centers
