"""The grid k-means: exact distances, so the same centres on every CPU."""

import numpy as np
import pytest
from scipy.spatial.distance import cdist

from tunnelsense.tunnel._kmeans_grid import (
    grid_quantum,
    grid_sq_distances,
    kmeans_plusplus,
    lloyd,
    shifted_sq_distances,
    to_grid,
)
from tunnelsense.tunnel._verification import fit_kmeans


@pytest.mark.parametrize("max_abs, d", [(1.0, 64), (1.5, 64), (300.0, 8), (1e-3, 32)])
def test_grid_distances_are_exact_integers(max_abs, d, global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    q = grid_quantum(max_abs, d)
    X = to_grid(rng.uniform(-max_abs, max_abs, (50, d)), q)
    C = to_grid(rng.uniform(-max_abs, max_abs, (7, d)), q)
    got = grid_sq_distances(X, C)
    # Python integers: the exact squared distances
    Xi, Ci = X.astype(np.int64).tolist(), C.astype(np.int64).tolist()
    exact = [[sum((a - b) ** 2 for a, b in zip(x, c, strict=True)) for c in Ci] for x in Xi]
    assert got.tolist() == [[float(v) for v in row] for row in exact]
    assert all(v < 2**53 for row in exact for v in row)
    # whatever order the products are summed in (columns reversed, one at a time)
    rev = grid_sq_distances(X[:, ::-1].copy(), C[:, ::-1].copy())
    by_column = sum(((X[:, None, j] - C[None, :, j]) ** 2) for j in range(d))
    assert np.array_equal(got, rev) and np.array_equal(got, by_column)


def test_grid_quantum_is_a_power_of_two_and_refuses_nan():
    q = grid_quantum(0.7, 64)
    assert np.log2(q) == int(np.log2(q))
    assert grid_quantum(0.0, 3) == 1.0
    with pytest.raises(ValueError, match="finite"):
        grid_quantum(np.nan, 3)


def test_lloyd_finds_separated_blobs(global_random_seed):
    rng = np.random.RandomState(global_random_seed)
    means = np.array([[0.0, 0], [1, 0], [0, 1]])
    X = np.vstack([m + 0.02 * rng.randn(100, 2) for m in means])
    q = grid_quantum(np.abs(X).max(), 2)
    U = to_grid(X, q)
    C = lloyd(U, kmeans_plusplus(U, 3, rng)) * q
    assert np.abs(np.sort(C, axis=0) - np.sort(means, axis=0)).max() < 0.01


@pytest.mark.parametrize("n, max_full", [(3000, 20_000), (30_000, 1000)])
def test_fit_kmeans_does_not_depend_on_column_order(n, max_full, global_random_seed):
    """Reversing the columns changes every BLAS summation order, not the centres."""
    rng = np.random.default_rng(global_random_seed)
    X = rng.dirichlet(np.ones(16) * 0.5, n)
    kw = dict(max_full_samples=max_full, batch_size=1024, n_steps=20,
              random_state=global_random_seed)
    a = fit_kmeans(X, 25, **kw)
    b = fit_kmeans(X[:, ::-1], 25, **kw)
    assert np.array_equal(a, b[:, ::-1])


def test_full_kmeans_inertia_close_to_scikit_learn(global_random_seed):
    from sklearn.cluster import KMeans

    rng = np.random.default_rng(global_random_seed)
    X = rng.dirichlet(np.ones(8) * 0.5, 4000)
    ours = fit_kmeans(X, 20, random_state=global_random_seed)
    theirs = KMeans(20, n_init=1, random_state=global_random_seed).fit(X)
    assert (cdist(X, ours, "sqeuclidean").min(1)).sum() <= 1.05 * theirs.inertia_


@pytest.mark.parametrize("max_abs, d", [(1.0, 64), (300.0, 8)])
def test_shifted_distances_plus_row_norms_are_the_exact_distances(max_abs, d,
                                                                   global_random_seed):
    # the k-means' nearest centres read ||c||^2 - 2 u.c: adding ||u||^2 back gives
    # the exact table, and the nearest centres (ties to the lowest index) are its
    rng = np.random.default_rng(global_random_seed)
    q = grid_quantum(max_abs, d)
    C = to_grid(rng.uniform(-max_abs, max_abs, (9, d)), q)
    X = np.vstack([to_grid(rng.uniform(-max_abs, max_abs, (40, d)), q),
                   C[[3, 3, 7]], (C[1] + C[2]) / 2])  # on centres; between two
    full = grid_sq_distances(X, C)
    e = shifted_sq_distances(X, C)
    assert np.array_equal(e + (X * X).sum(1)[:, None], full)
    assert np.array_equal(e.argmin(1), full.argmin(1))


@pytest.mark.parametrize("n_distinct", [1, 5, 39, 40, 41, 200])
def test_fit_kmeans_returns_the_distinct_rows_when_at_most_k(n_distinct,
                                                             global_random_seed):
    # rows repeated from a few distinct ones (one of them differing from another in
    # one column only): at most k distinct rows are the centres, more are clustered
    rng = np.random.default_rng(global_random_seed)
    base = rng.integers(0, 8, (n_distinct, 32)) / 8.0
    if n_distinct > 1:
        base[1] = base[0]
        base[1, 31] = base[0, 31] + 1.0
    X = base[rng.integers(0, n_distinct, 5000)]
    X[:n_distinct] = base
    C = fit_kmeans(X, 40, random_state=0)
    if n_distinct <= 40:
        assert np.array_equal(C, np.unique(base, axis=0))
    else:
        assert len(C) == 40


def test_distinct_row_count_exact_on_colliding_sums():
    from tunnelsense.tunnel._kmeans_fit import _at_most_distinct

    # two rows whose weighted sums are equal for the weights drawn, yet distinct:
    # counted exactly, not by their sums
    w = np.random.default_rng(0).integers(1, 1024, 2).astype(np.float64)
    U = np.array([[w[1], 0.0], [0.0, w[0]]] * 10)
    assert (U[0] @ w) == (U[1] @ w)
    assert _at_most_distinct(U, 2) and not _at_most_distinct(U, 1)
    assert not _at_most_distinct(np.arange(20.0).reshape(10, 2), 9)
    assert _at_most_distinct(np.arange(20.0).reshape(10, 2), 10)
