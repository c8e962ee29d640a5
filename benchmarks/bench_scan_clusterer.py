"""ScanClusterer speed, and its single linkage beside SciPy's ``single`` + ``fcluster``.

Run: ``python benchmarks/bench_scan_clusterer.py [n_scans]``.  A simulated "dense"
street run with a 1,081-beam scanner (178 degrees, the simulator's widest fan, at
0.165 degrees; the paper's sensor delivers 75 scans/s) is processed on one thread:

* the whole detector (``ScanClusterer.detect``: restoration, tilt, ROI, intra- and
  inter-scan clustering, regions, split, labels), in scans per second;
* the intra-scan clustering alone on the same ROI points: tunnelsense's exact single
  linkage over all scans at once, beside SciPy ``single(pdist)`` + ``fcluster`` scan by
  scan (partitions checked identical).

Every figure is the median of repeats measured in this run.

``python benchmarks/bench_scan_clusterer.py --quality [n_scans] [n_seeds] [first_seed]``
prints instead the detection quality on simulated runs of every scenario (4,000 scans,
seeds ``first_seed`` (default 2000) and up, none used while developing), with the
merge-splitting option, the tilt compensation, the cross-section body evidence and the
occlusion extension each switched off in turn.
"""

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from scipy.cluster.hierarchy import fcluster, single  # noqa: E402
from scipy.spatial.distance import pdist  # noqa: E402

from tunnelsense.datasets import make_street_scans  # noqa: E402
from tunnelsense.street import ScanClusterer, single_linkage  # noqa: E402

REPEATS = 5


def median_time(func, repeats=REPEATS):
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        func()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def same_partition(a, b):
    pairs = set(zip(a.tolist(), b.tolist(), strict=True))
    return len(pairs) == len(set(a.tolist())) == len(set(b.tolist()))


def main(n_scans=3000):
    run = make_street_scans(n_scans, scenario="dense", random_state=0,
                            angle_min_deg=-89.0, angle_max_deg=89.0,
                            angle_increment_deg=178.0 / 1080)
    n_beams = len(run.scans[0].ranges)
    X = list(run.scans)
    est = ScanClusterer().fit(X)
    est.detect(X)  # warm up
    t_detect = median_time(lambda: est.detect(X))
    out = est.transform(X)
    pts = [r.payload["points"] for r in out]
    groups = np.repeat(np.arange(len(pts)), [len(p) for p in pts])
    allp = np.concatenate(pts)
    t_ours = median_time(lambda: single_linkage(allp, 0.6, groups=groups))

    def scipy_all():
        return [fcluster(single(pdist(p)), 0.6, criterion="distance") if len(p) > 1
                else np.ones(len(p), int) for p in pts]

    t_scipy = median_time(scipy_all, repeats=3)
    ours = single_linkage(allp, 0.6, groups=groups)
    ref = scipy_all()
    bounds = np.r_[0, np.cumsum([len(p) for p in pts])]
    same = all(same_partition(ours[bounds[i]:bounds[i + 1]], ref[i])
               for i in range(len(pts)))
    n_pts = np.array([len(p) for p in pts])
    print(f"run: {n_scans} scans x {n_beams} beams, ROI points per scan: median "
          f"{np.median(n_pts):.0f}, max {n_pts.max()}; one thread; medians of "
          f"{REPEATS} (SciPy 3) repeats")
    print()
    print(f"{'what':52s} {'time (s)':>9s} {'scans/s':>9s} {'ratio':>7s}")
    print(f"{'ScanClusterer.detect (whole method)':52s} {t_detect:9.3f} "
          f"{n_scans / t_detect:9.0f} {'':>7s}")
    print(f"{'intra-scan: tunnelsense single_linkage (all scans)':52s} {t_ours:9.3f} "
          f"{n_scans / t_ours:9.0f} {t_scipy / t_ours:6.1f}x")
    print(f"{'intra-scan: SciPy single(pdist) + fcluster per scan':52s} {t_scipy:9.3f} "
          f"{n_scans / t_scipy:9.0f} {1.0:6.1f}x")
    print(f"\npartitions identical to SciPy's in all {len(pts)} scans: {same}")
    print(f"target: >= 5000 scans/s for the whole method: "
          f"{'met' if n_scans / t_detect >= 5000 else 'NOT met'}")


def quality(n_scans=4000, n_seeds=3, first_seed=2000):
    import pandas as pd

    from tunnelsense.datasets import STREET_SCENARIOS
    from tunnelsense.metrics import street_scores

    variants = {
        "default": {},
        "split_merged=False": {"split_merged": False},
        "tilt_compensation=False": {"tilt_compensation": False},
        "min_body_fraction=0": {"min_body_fraction": 0.0},
        "occluded_length=None": {"occluded_length": None},
        "bridge_occluded=False": {"bridge_occluded": False},
    }
    print(f"parked vehicles, {n_seeds} runs x {n_scans} scans per scenario, seeds "
          f"{first_seed}-{first_seed + n_seeds - 1} (tp / fp / fn, recall, precision)")
    print(f"{'scenario':16s} {'variant':24s} {'tp':>5s} {'fp':>4s} {'fn':>4s} "
          f"{'recall':>7s} {'precision':>9s}")
    cases = [(s, {}) for s in STREET_SCENARIOS]
    # the "tilted" scenario rolls the sensor up (the road sinks below the ROI when
    # not compensated); rolled down, the road rises into the ROI
    cases.append(("tilted", {"roll_deg": -3.0}))
    for scenario, over in cases:
        runs = [make_street_scans(n_scans, scenario=scenario, random_state=first_seed + k,
                                  **over)
                for k in range(n_seeds)]
        if over:
            scenario = f"{scenario} {over['roll_deg']:+g} deg"
        gt = pd.concat([r.gt.assign(run=r.name) for r in runs])
        for name, params in variants.items():
            det = pd.concat([ScanClusterer(**params).fit(r.scans).detect(r.scans)
                             for r in runs])
            sc = street_scores(gt, det)["parked"]
            print(f"{scenario:16s} {name:24s} {sc['tp']:5d} {sc['fp']:4d} {sc['fn']:4d} "
                  f"{sc['recall']:7.3f} {sc['precision']:9.3f}")


if __name__ == "__main__":
    if "--quality" in sys.argv:
        rest = [int(a) for a in sys.argv[1:] if a != "--quality"]
        quality(*rest)
    else:
        main(int(sys.argv[1]) if len(sys.argv) > 1 else 3000)
