"""Per-call cost of the appearance machine: scikit-learn's predict vs. array stumps.

A frame holds a few keypoint clusters, so the per-frame cost is per-call overhead.
Compares, in the same run, ``AdaBoostClassifier.predict`` (50 stumps) with
``WeightedAdaBoost``'s array evaluation of the same stumps on 1, 3 and 1,000 rows,
and checks that their decisions are identical.  Medians over repeats, one core.

    python benchmarks/bench_adaboost.py
"""

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

import time  # noqa: E402

import numpy as np  # noqa: E402
from sklearn.ensemble import AdaBoostClassifier  # noqa: E402
from sklearn.tree import DecisionTreeClassifier  # noqa: E402

from tunnelsense.tunnel import WeightedAdaBoost  # noqa: E402


def per_call(f, X, repeats):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        f(X)
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def main():
    rng = np.random.default_rng(0)
    X = rng.dirichlet(np.ones(32), 5000)
    y = ((X[:, 3] + X[:, 7] + rng.normal(0, 0.02, 5000)) > 0.07).astype(int)
    w = np.where(y == 1, 7.0, 1.0)
    sk = AdaBoostClassifier(DecisionTreeClassifier(max_depth=1), n_estimators=50,
                            random_state=0).fit(X, y, sample_weight=w)
    ours = WeightedAdaBoost(n_estimators=50).fit(X, y)
    Xt = rng.dirichlet(np.ones(32), 1000)
    same = bool((sk.predict(Xt) == ours.predict(Xt)).all())
    print(f"identical decisions on 1,000 rows: {same}\n")
    print("| rows per call | AdaBoostClassifier.predict | array stumps (frame path) | speed-up |")
    print("|---|---|---|---|")
    for rows in (1, 3, 1000):
        a = per_call(sk.predict, Xt[:rows], 50)
        b = per_call(ours._predict_arrays, Xt[:rows], 500)
        print(f"| {rows} | {a * 1e3:.3f} ms | {b * 1e3:.4f} ms | {a / b:,.0f} x |")


if __name__ == "__main__":
    main()
