"""FIR stages 1-3 per 640x480 frame, beside OpenCV's PNG decode of the same frames.

Run: ``python benchmarks/bench_tunnel_stages.py`` (speed), or with ``--validation``
to also print the detection figures of issue 4 on simulated tours not used for
fitting: stages 1-2 fitted on ONE simulated heavy-traffic tour (seed ``--seed``,
``--train-frames`` frames) and measured on the light, heavy and curved (other
camera) tours of seeds ``--seed + 11, 12, 13`` (``--test-frames`` frames each), the
protocol of ``eval_indicator_detector.py``, whose tour cache
(``$TMPDIR/tunnelsense-eval``) it shares.  ``--seed 0`` (default) gives the
development tours, on which settings were chosen; other seeds check them.  It
prints the trade-off curves of the paper's rule (the 7x3 patch histogram alone,
10 centres, ``margin=None``) and of the default (7x3 patch histogram and 25x13
context histogram, all centres, ``margin``) over ``max_distance``, ``margin`` and
the context's weight and size; ``--ranges`` adds histograms over a band of intensities (``intensity_range``).
Simulating the tours takes about a minute each the first time.

Speed: the stages are fitted on a simulated "light" tour; a second simulated tour of
``--frames`` frames is then run through ``IntensityKeypointSampler``,
``KMeansHistogramVerifier`` and ``MSTClusterer`` (also with ``box="region"``, the
indicator pipeline's setting), in frame mode, the whole tour per call (as in a
Pipeline, so input validation happens once per tour), and the time per frame
is the call's time divided by the number of frames.  The peer is ``cv2.imdecode`` of
the same frames encoded as PNG, per frame.  Medians over ``--repeats`` repeats; one
thread.
"""

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

import argparse  # noqa: E402
import copy  # noqa: E402
import pickle  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import cv2  # noqa: E402
import numpy as np  # noqa: E402

from tunnelsense import to_xy  # noqa: E402
from tunnelsense.datasets import make_tunnel_tour  # noqa: E402
from tunnelsense.tunnel import (  # noqa: E402
    IntensityKeypointSampler,
    KMeansHistogramVerifier,
    MSTClusterer,
)
from tunnelsense.tunnel._common import points_in_boxes  # noqa: E402

cv2.setNumThreads(1)


def median_time(func, repeats):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        func()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def fit_stages(tours, random_state=0):
    X, y, _ = to_xy(tours)
    sampler = IntensityKeypointSampler().fit(X, y)
    Xk = sampler.transform(X)
    verifier = KMeansHistogramVerifier(random_state=random_state).fit(Xk, y)
    return sampler, verifier, MSTClusterer().fit(Xk)


def detection_figures(sampler, verifier, tour, min_height=14.0):
    """Per tour: indicator instances (indicator x frame) taller than ``min_height``
    that keep >= 1 verified keypoint (all; fully visible; taller than 20 and 30 px),
    and the negative keypoints (outside every indicator box) the verifier removes."""
    X, y, _ = to_xy([tour])
    out = verifier.transform(sampler.transform(X))
    gt = tour.gt[(tour.gt["class"] == 1) & (tour.gt["bb_height"] > min_height)]
    by_frame = {f: g for f, g in gt.groupby("frame")}
    f = dict.fromkeys(
        ["instances", "hit", "instances_visible", "hit_visible", "instances_20",
         "hit_20", "instances_30", "hit_30", "negatives", "negatives_kept"], 0)
    for r, boxes in zip(out, y, strict=True):
        S, K = r.payload["sampled_keypoints"], r.payload["keypoints"]
        for b in by_frame.get(r.frame, gt.iloc[:0]).itertuples():
            box = np.array([[b.bb_left, b.bb_top, b.bb_width, b.bb_height]])
            kept = bool(points_in_boxes(K[:, 0], K[:, 1], box).any())
            for key, counted in [("", True), ("_visible", b.visibility >= 1.0),
                                 ("_20", b.bb_height > 20), ("_30", b.bb_height > 30)]:
                if counted:
                    f["instances" + key] += 1
                    f["hit" + key] += kept
        f["negatives"] += int((~points_in_boxes(S[:, 0], S[:, 1], boxes)).sum())
        f["negatives_kept"] += int((~points_in_boxes(K[:, 0], K[:, 1], boxes)).sum())
    return f


def speed(args):
    train = make_tunnel_tour(args.frames, scenario="light", random_state=100)
    tour = make_tunnel_tour(args.frames, scenario="light", random_state=101)
    sampler, verifier, clusterer = fit_stages([train])
    X = tour.frames
    images = [r.image for r in X]
    pngs = [cv2.imencode(".png", im)[1] for im in images]

    region = MSTClusterer(box="region").fit(sampler.transform(X[:1]))
    # the indicator pipeline's verifier: the 7 x 3 patch histogram alone
    Xtr, ytr, _ = to_xy([train])
    patch_only = KMeansHistogramVerifier(
        context_size=None, max_distance=0.32, random_state=0
    ).fit(sampler.transform(Xtr), ytr)

    def stages():
        return clusterer.transform(verifier.transform(sampler.transform(X)))

    def stages_region():
        return region.transform(verifier.transform(sampler.transform(X)))

    def stages_pipeline():
        return region.transform(patch_only.transform(sampler.transform(X)))

    out = stages()
    n = len(X)
    t_s = median_time(lambda: sampler.transform(X), args.repeats) / n
    Xk = sampler.transform(X)
    t_v = median_time(lambda: verifier.transform(Xk), args.repeats) / n
    t_v1 = median_time(lambda: patch_only.transform(Xk), args.repeats) / n
    Xv = verifier.transform(Xk)
    t_c = median_time(lambda: clusterer.transform(Xv), args.repeats) / n
    t_r = median_time(lambda: region.transform(Xv), args.repeats) / n
    t_all = median_time(stages, args.repeats) / n
    t_all_r = median_time(stages_region, args.repeats) / n
    t_all_p = median_time(stages_pipeline, args.repeats) / n
    t_png = median_time(
        lambda: [cv2.imdecode(p, cv2.IMREAD_UNCHANGED) for p in pngs], args.repeats
    ) / n
    sampled = np.mean([len(r.payload["sampled_keypoints"]) for r in out])
    kept = np.mean([len(r.payload["keypoints"]) for r in out])
    clusters = np.mean([len(r.payload["cluster_boxes"]) for r in out])
    print(f"{n} frames of 640x480 (simulated 'light' tour); per frame: "
          f"{sampled:.1f} sampled keypoints, {kept:.1f} verified, {clusters:.1f} clusters")
    print(f"{'stage':<40} {'ms/frame':>10} {'PNG decode ms':>14} {'ratio':>8}")
    print("-" * 76)
    for name, t in [
        ("IntensityKeypointSampler.transform", t_s),
        ("KMeansHistogramVerifier.transform", t_v),
        ("  the same, 7x3 patch only (pipeline's)", t_v1),
        ("MSTClusterer.transform", t_c),
        ("stages 1-3 chained", t_all),
        ("MSTClusterer(box='region').transform", t_r),
        ("stages 1-3 chained, region boxes", t_all_r),
        ("the same, 7x3 patch only (pipeline's)", t_all_p),
    ]:
        print(f"{name:<40} {t * 1e3:>10.3f} {t_png * 1e3:>14.3f} {t / t_png:>8.3f}")
    for name, t in (("stages 1-3", t_all), ("stages 1-3 with region boxes", t_all_r),
                    ("stages 1-3 as in the indicator pipeline", t_all_p)):
        print(f"\n{name}: {t * 1e3:.3f} ms/frame (budget 0.5 ms); "
              f"{t / t_png:.3f} of a PNG decode (budget 1/6 = 0.167)")


CACHE = Path(os.environ.get("TMPDIR", tempfile.gettempdir())) / "tunnelsense-eval"


def cached_tour(n, scenario, seed):
    """A simulated tour, cached like ``eval_indicator_detector.py`` caches it."""
    CACHE.mkdir(exist_ok=True)
    path = CACHE / f"{scenario}-{seed}-{n}.pkl"
    if path.exists():
        return pickle.loads(path.read_bytes())
    t = make_tunnel_tour(n, scenario=scenario, random_state=seed)
    path.write_bytes(pickle.dumps(t))
    return t


#: (label, fit parameters of the verifier, margin, max_distance values) of the
#: validation curves.
ONE_PATCH = {"context_size": None}
CURVES = [
    ("paper's rule: 7x3 patch, 10 centres", {"n_centers": 10, **ONE_PATCH}, None,
     (0.14, 0.25, 0.32)),
    ("7x3 patch, all centres, margin 0.04", ONE_PATCH, 0.04, (0.25, 0.32)),
    ("default: + 25x13 context x1.5", {}, 0.04, (0.32, 0.4, 0.5)),
    ("default, margin 0.03", {}, 0.03, (0.4,)),
    ("default, margin 0.06", {}, 0.06, (0.4,)),
    ("context weight 1", {"context_weight": 1.0}, 0.04, (0.32, 0.4)),
    ("context weight 2", {"context_weight": 2.0}, 0.04, (0.4, 0.5)),
    ("context 19x9", {"context_size": (19, 9)}, 0.04, (0.4,)),
    ("context 31x15", {"context_size": (31, 15)}, 0.04, (0.4,)),
    ("25x13 patch alone", {"patch_size": (25, 13), **ONE_PATCH}, 0.04, (0.4,)),
]

#: ``--ranges``: histograms of the 7x3 patch over a band around the indicator
#: intensities only (``intensity_range``, values outside clipped into the end bins),
#: margin rule.
RANGE_CURVES = [
    ("range 128-224, 16 bins, margin 0.04",
     {"intensity_range": (128, 224), "bins": 16, **ONE_PATCH}, 0.04, (0.25, 0.32)),
    ("range 128-224, 16 bins, margin 0.05",
     {"intensity_range": (128, 224), "bins": 16, **ONE_PATCH}, 0.05, (0.25,)),
    ("range 128-224, 32 bins, margin 0.04",
     {"intensity_range": (128, 224), "bins": 32, **ONE_PATCH}, 0.04, (0.25, 0.32)),
    ("range 144-208, 32 bins, margin 0.04",
     {"intensity_range": (144, 208), "bins": 32, **ONE_PATCH}, 0.04, (0.25, 0.32)),
    ("range 112-240, 32 bins, margin 0.04",
     {"intensity_range": (112, 240), "bins": 32, **ONE_PATCH}, 0.04, (0.25, 0.32)),
]


def validation(args):
    train = cached_tour(args.train_frames, "heavy", args.seed)
    tests = [cached_tour(args.test_frames, sc, args.seed + k)
             for k, sc in enumerate(("light", "heavy", "curved"), 11)]
    print(f"\nDetection figures (issue 4): fitted on {train.name} ({len(train)} frames), "
          f"measured on {', '.join(t.name for t in tests)} ({args.test_frames} frames "
          "each); instances = indicator x frame, taller than 14 px")
    X, y, _ = to_xy([train])
    sampler = IntensityKeypointSampler().fit(X, y)
    Xk = sampler.transform(X)
    print(f"{'rule':<36} {'max_distance':>12} "
          + " ".join(f"{t.name.split('-')[1]:>15}" for t in tests)
          + f" {'all: kept':>10} {'> 20 px':>8} {'removed':>8}")
    for rs in range(args.val_seeds):
        fitted = {}
        for label, params, margin, mds in CURVES + (RANGE_CURVES if args.ranges else []):
            key = tuple(sorted(params.items()))
            if key not in fitted:
                fitted[key] = KMeansHistogramVerifier(
                    random_state=rs, **params).fit(Xk, y)
            for md in mds:
                # margin and max_distance only act in transform: the centres stay
                v = copy.deepcopy(fitted[key]).set_params(margin=margin, max_distance=md)
                figs = [detection_figures(sampler, v, t) for t in tests]
                tot = {k: sum(f[k] for f in figs) for k in figs[0]}
                cells = " ".join(
                    f"{f['hit'] / max(f['instances'], 1):>6.1%}/"
                    f"{1 - f['negatives_kept'] / max(f['negatives'], 1):<6.1%}"
                    for f in figs)
                print(f"{label:<36} {md:>12} {cells} "
                      f"{tot['hit'] / tot['instances']:>10.1%} "
                      f"{tot['hit_20'] / max(tot['instances_20'], 1):>8.1%} "
                      f"{1 - tot['negatives_kept'] / tot['negatives']:>8.1%}", flush=True)
        print(f"(random_state={rs}; {tot['instances']} instances, {tot['negatives']} "
              "negative keypoints; per tour: kept / removed; targets: kept >= 95 %, "
              "removed >= 80 %)")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--validation", action="store_true")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--train-frames", type=int, default=1500)
    parser.add_argument("--test-frames", type=int, default=1500)
    parser.add_argument("--val-seeds", type=int, default=1)
    parser.add_argument("--no-speed", dest="speed", action="store_false")
    parser.add_argument("--ranges", action="store_true",
                        help="also the intensity_range curves (RANGE_CURVES)")
    args = parser.parse_args()
    if args.speed:
        speed(args)
    if args.validation:
        validation(args)


if __name__ == "__main__":
    main()
