"""KMeansHistogramVerifier.fit at the paper's scale: 30,000 + 3,000,000 histograms.

Run: ``python benchmarks/bench_kmeans_verifier.py [--n-negative 3000000] [--context]``.

``--context`` appends to every histogram a second one of 32 bins, of a 325-pixel
(25 x 13) context patch, multiplied by 1.5: the verifier's default descriptor
(64 values, 768 MB for 3,000,000 rows).

Histograms are 32-bin normalized intensity histograms of 21-pixel patches (the
verifier's default 7 x 3 patch), drawn from patch-like intensity distributions: one
or two Gaussian intensity levels per patch (plates, walls, lamp halos, edges) sampled
pixel by pixel.  Positives are plates in the band [160, 190]; negatives cover the
whole range.  Stored as float32 (384 MB for 3,000,000 rows).

Reported beside their peers, measured in the same run:

* fit time (budget 3 min) and peak memory of the fit (tracemalloc peak of NumPy's
  allocations during ``fit``, plus the process's peak RSS; budget 2 GiB);
* k-means inertia of the fitted centres on a 300,000-row subset of the negatives,
  against a full Lloyd ``KMeans(400, n_init=1)`` fitted on that subset (target: at
  most 5 % higher), and the same for the positives (full ``KMeans(40)`` on all 30,000);
* ``MiniBatchKMeans.fit`` on 300,000 rows (the path DESIGN.md section 6 warns about),
  timed for comparison with the ``partial_fit`` loop the verifier uses.
"""

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import resource  # noqa: E402
import time  # noqa: E402
import tracemalloc  # noqa: E402

import numpy as np  # noqa: E402
from scipy.special import ndtr  # noqa: E402
from sklearn.cluster import KMeans, MiniBatchKMeans  # noqa: E402

from tunnelsense.tunnel import KMeansHistogramVerifier  # noqa: E402

BINS = 32
PIXELS = 21
EDGES = np.arange(BINS + 1) * (256 / BINS)


CONTEXT_PIXELS, CONTEXT_WEIGHT = 25 * 13, 1.5


def histograms(n, positive, rng, chunk=200_000, context=False):
    out = np.empty((n, 2 * BINS if context else BINS), dtype=np.float32)
    for lo in range(0, n, chunk):
        m = min(chunk, n - lo)
        if positive:
            mean1 = rng.uniform(160, 190, m)
            sd1 = rng.uniform(2, 6, m)
            mean2 = rng.uniform(90, 140, m)  # wall or edge at the patch border
            w2 = np.where(rng.random(m) < 0.5, rng.uniform(0, 0.4, m), 0)
        else:
            mean1 = rng.uniform(60, 250, m)
            sd1 = rng.uniform(2, 25, m)
            mean2 = rng.uniform(60, 250, m)
            w2 = np.where(rng.random(m) < 0.5, rng.uniform(0, 0.5, m), 0)
        sd2 = rng.uniform(2, 10, m)
        cdf1 = ndtr((EDGES[None, :] - mean1[:, None]) / sd1[:, None])
        cdf2 = ndtr((EDGES[None, :] - mean2[:, None]) / sd2[:, None])
        p = (1 - w2)[:, None] * np.diff(cdf1, axis=1) + w2[:, None] * np.diff(cdf2, axis=1)
        p = np.clip(p, 0, None)
        p /= p.sum(1, keepdims=True)
        out[lo : lo + m, :BINS] = rng.multinomial(PIXELS, p) / PIXELS
        if context:
            # the context mixes the patch's levels with a third: the wall around
            # a plate (positives), anything (negatives)
            mean3 = rng.uniform(80, 130, m) if positive else rng.uniform(60, 250, m)
            w3 = rng.uniform(0.3, 0.8, m) if positive else rng.uniform(0, 0.6, m)
            cdf3 = ndtr((EDGES[None, :] - mean3[:, None]) / sd2[:, None])
            pc = (1 - w3)[:, None] * p + w3[:, None] * np.diff(cdf3, axis=1)
            pc = np.clip(pc, 0, None)
            pc /= pc.sum(1, keepdims=True)
            out[lo : lo + m, BINS:] = (
                rng.multinomial(CONTEXT_PIXELS, pc) * (CONTEXT_WEIGHT / CONTEXT_PIXELS)
            )
    return out


def inertia(X, centers, chunk=50_000):
    c = np.asarray(centers, dtype=np.float64)
    csq = (c * c).sum(1)
    total = 0.0
    for lo in range(0, len(X), chunk):
        x = np.asarray(X[lo : lo + chunk], dtype=np.float64)
        d2 = (x * x).sum(1)[:, None] - 2 * x @ c.T + csq[None, :]
        total += float(np.maximum(d2.min(1), 0).sum())
    return total


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--n-positive", type=int, default=30_000)
    parser.add_argument("--n-negative", type=int, default=3_000_000)
    parser.add_argument("--subset", type=int, default=300_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--context", action="store_true",
                        help="64-value descriptors: patch + 1.5 x context histogram")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    t0 = time.perf_counter()
    pos = histograms(args.n_positive, True, rng, context=args.context)
    neg = histograms(args.n_negative, False, rng, context=args.context)
    X = np.concatenate([pos, neg])
    del neg
    y = np.zeros(len(X), dtype=np.int8)
    y[: args.n_positive] = 1
    print(f"data: {len(X):,} descriptors x {X.shape[1]} values float32 "
          f"({X.nbytes / 2**20:.0f} MiB), made in {time.perf_counter() - t0:.1f} s")

    fit_times, peaks, verifier = [], [], None
    for rep in range(args.repeats):
        verifier = KMeansHistogramVerifier(random_state=rep)
        tracemalloc.start()
        t0 = time.perf_counter()
        verifier.fit(X, y)
        fit_times.append(time.perf_counter() - t0)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
    t_fit = float(np.median(fit_times))
    peak = max(peaks)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024

    sub = X[args.n_positive :][
        np.sort(rng.choice(len(X) - args.n_positive, args.subset, replace=False))
    ]
    t0 = time.perf_counter()
    full_neg = KMeans(400, n_init=1, random_state=0).fit(sub)
    t_full_neg = time.perf_counter() - t0
    ours_neg = inertia(sub, verifier.negative_centers_)
    t0 = time.perf_counter()
    full_pos = KMeans(40, n_init=1, random_state=0).fit(pos)
    t_full_pos = time.perf_counter() - t0
    ours_pos = inertia(pos, verifier.positive_centers_)

    t0 = time.perf_counter()
    MiniBatchKMeans(400, batch_size=4096, n_init=1, random_state=0).fit(sub)
    t_mbk_fit = time.perf_counter() - t0

    print()
    print(f"{'measure':<58} {'ours':>12} {'peer / budget':>16} {'ratio':>8}")
    print("-" * 98)
    label = (f"fit {args.n_positive:,} + {args.n_negative:,} histograms, "
             f"median of {args.repeats} (s)")
    print(f"{label:<58} "
          f"{t_fit:>12.1f} {'budget 180':>16} {t_fit / 180:>8.2f}")
    print(f"{'peak NumPy memory during fit (MiB, tracemalloc)':<58} "
          f"{peak / 2**20:>12.0f} {'budget 2048':>16} {peak / 2**31:>8.2f}")
    print(f"{'peak RSS of this process incl. data (MiB)':<58} "
          f"{rss / 2**20:>12.0f} {'budget 2048':>16} {rss / 2**31:>8.2f}")
    label = f"inertia, 400 negative centres, on {args.subset:,} subset"
    print(f"{label:<58} "
          f"{ours_neg:>12.1f} {full_neg.inertia_:>16.1f} "
          f"{ours_neg / full_neg.inertia_:>8.3f}")
    print(f"{'  (peer: full KMeans(400) fitted on that subset, s)':<58} "
          f"{'':>12} {t_full_neg:>16.1f}")
    print(f"{'inertia, 40 positive centres, on all positives':<58} "
          f"{ours_pos:>12.2f} {full_pos.inertia_:>16.2f} "
          f"{ours_pos / full_pos.inertia_:>8.3f}")
    print(f"{'  (peer: full KMeans(40) fitted on the positives, s)':<58} "
          f"{'':>12} {t_full_pos:>16.1f}")
    print(f"{'MiniBatchKMeans(400).fit on the subset (s)':<58} "
          f"{'':>12} {t_mbk_fit:>16.1f}")
    print(f"\nfit: {t_fit:.1f} s (budget 180 s); peak {peak / 2**20:.0f} MiB "
          f"(budget 2048 MiB); negative inertia ratio {ours_neg / full_neg.inertia_:.3f}"
          " (target <= 1.05)")


if __name__ == "__main__":
    main()
