"""FIR stages 1-3 per 640x480 frame, beside OpenCV's PNG decode of the same frames.

Run: ``python benchmarks/bench_tunnel_stages.py`` (speed), or with ``--validation``
to also print the detection figures of issue 4 on simulated tours not used for
fitting (takes a minute or two: it simulates several tours).

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
import time  # noqa: E402

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

    def stages():
        return clusterer.transform(verifier.transform(sampler.transform(X)))

    def stages_region():
        return region.transform(verifier.transform(sampler.transform(X)))

    out = stages()
    n = len(X)
    t_s = median_time(lambda: sampler.transform(X), args.repeats) / n
    Xk = sampler.transform(X)
    t_v = median_time(lambda: verifier.transform(Xk), args.repeats) / n
    Xv = verifier.transform(Xk)
    t_c = median_time(lambda: clusterer.transform(Xv), args.repeats) / n
    t_r = median_time(lambda: region.transform(Xv), args.repeats) / n
    t_all = median_time(stages, args.repeats) / n
    t_all_r = median_time(stages_region, args.repeats) / n
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
        ("MSTClusterer.transform", t_c),
        ("stages 1-3 chained", t_all),
        ("MSTClusterer(box='region').transform", t_r),
        ("stages 1-3 chained, region boxes", t_all_r),
    ]:
        print(f"{name:<40} {t * 1e3:>10.3f} {t_png * 1e3:>14.3f} {t / t_png:>8.3f}")
    for name, t in (("stages 1-3", t_all), ("stages 1-3 with region boxes (pipeline)", t_all_r)):
        print(f"\n{name}: {t * 1e3:.3f} ms/frame (budget 0.5 ms); "
              f"{t / t_png:.3f} of a PNG decode (budget 1/6 = 0.167)")


def validation(args):
    print("\nDetection figures (fitted on simulated tours, measured on other tours):")
    train = [make_tunnel_tour(args.val_frames, scenario="light", random_state=s)
             for s in (200, 201)]
    tests = [make_tunnel_tour(args.val_frames, scenario=sc, random_state=s)
             for sc, s in [("light", 300), ("heavy", 301), ("curved", 302),
                           ("light", 303), ("heavy", 304), ("curved", 305)]]
    for rs in range(args.val_seeds):
        sampler, verifier, _ = fit_stages(train, random_state=rs)
        total = {}
        print(f"random_state={rs}")
        for tour in tests:
            f = detection_figures(sampler, verifier, tour)
            for k, v in f.items():
                total[k] = total.get(k, 0) + v
            print(f"  {tour.name:<20} indicators >14 px keeping a verified keypoint: "
                  f"{f['hit']}/{f['instances']} ({f['hit'] / max(f['instances'], 1):.1%}),"
                  f" fully visible {f['hit_visible']}/{f['instances_visible']}; "
                  f"negatives removed {1 - f['negatives_kept'] / f['negatives']:.1%} "
                  f"of {f['negatives']}")
        t = total
        print(f"  {'all':<20} indicators >14 px: {t['hit'] / t['instances']:.1%} of "
              f"{t['instances']} (fully visible {t['hit_visible'] / t['instances_visible']:.1%}"
              f"; >20 px {t['hit_20'] / t['instances_20']:.1%}; >30 px "
              f"{t['hit_30'] / t['instances_30']:.1%}), negatives removed "
              f"{1 - t['negatives_kept'] / t['negatives']:.1%} of {t['negatives']}"
              "  [targets: >= 95 %, >= 80 %]")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--validation", action="store_true")
    parser.add_argument("--val-frames", type=int, default=400)
    parser.add_argument("--val-seeds", type=int, default=3)
    args = parser.parse_args()
    speed(args)
    if args.validation:
        validation(args)


if __name__ == "__main__":
    main()
