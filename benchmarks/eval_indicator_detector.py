"""Detection figures of the FIR indicator detector on simulated tours.

Trains on ONE simulated tour (``--train-scenario``, default heavy traffic, camera A;
seed ``--seed``) and evaluates on other seeds (``--seed + 11, 12, 13``) of every
scenario: "light", "heavy", and "curved", which is another camera (focal length
620 px, mounted 1.35 m high, noise sigma 4, a curving tunnel).  Prints, as markdown:

0. (on by default; ``--no-search`` skips it) the grid search of the motion
   thresholds by ``GridSearchCV`` with ``GroupKFold`` over
   ``--segments`` consecutive segments of the training tour (the only data it sees);
   its best parameters are used for everything below;
1. the cluster-level table (the paper's Table 1) and trajectory figures per tour;
2. the cross-camera figures on the other camera's tour: the paper's raw histograms
   (keypoint rectangles, margin 0) against the robust default;
3. the ablation table (sums over the test tours): no motion check, no positive
   weighting, no keypoint verifier, greedy vs Hungarian linking, and the paper's
   stages 3-5 (keypoint rectangles, margin 0, max_gap 3);
4. a camera with another gain (all frames mapped by ``gain * I + offset``): the
   default pipeline, which learns its keypoint band from the training tour, beside
   the paper's fixed band [160, 190];
5. the paper's bias-weight experiment: training correct rates of the appearance
   machine, evenly weighted vs positives x7;
6. issue 4's keypoint-verifier figures on the test tours (indicators taller than
   14 px keeping a verified keypoint, negative keypoints removed) for the stages
   fitted on the training tour, and the trade-off curve over ``max_distance`` for
   ``n_centers`` None (all centres, the default) and 20.

Usage::

    python benchmarks/eval_indicator_detector.py [--frames 3000] [--train-frames 1500]
        [--seed 0] [--no-search]

Simulated tours are cached under ``$TMPDIR/tunnelsense-eval`` (delete to refresh).
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import json
import os
import pickle
import tempfile
import time
from pathlib import Path

import numpy as np
from bench_tunnel_stages import detection_figures  # benchmarks/ is on the path
from sklearn.base import clone
from sklearn.model_selection import GridSearchCV, GroupKFold

from tunnelsense import FrameSequence, to_xy
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.metrics import indicator_scores, make_tunnel_scorer
from tunnelsense.tunnel import WeightedAdaBoost, make_indicator_pipeline
from tunnelsense.tunnel._appearance import centres_in_boxes

CACHE = Path(os.environ.get("TMPDIR", tempfile.gettempdir())) / "tunnelsense-eval"

#: Grid of the search; the first value of each is the default (ties go to it).
#: max_distance values of the verifier's trade-off curve.
CURVE = (0.14, 0.2, 0.25, 0.28, 0.3, 0.32, 0.35, 0.4, 0.5)

#: (gain, offset) of the "camera with another gain" check: indicators at 175 move to
#: 215 and to 140.
GAINS = ((1.2, 5.0), (0.8, 0.0))


def other_gain(X, gain, offset):
    """The frames seen by a camera with another gain and offset (8-bit)."""
    images = np.stack([
        np.clip(np.rint(gain * r.image.astype(np.float32) + offset), 0, 255).astype(np.uint8)
        for r in X
    ])
    return FrameSequence.from_array(images, tour=X[0].tour)


SEARCH_GRID = {
    "motion__min_r": [0.95, 0.9, 0.98],
    "motion__min_length": [10, 5, 20],
}


def tour(n, scenario, seed):
    CACHE.mkdir(exist_ok=True)
    path = CACHE / f"{scenario}-{seed}-{n}.pkl"
    if path.exists():
        return pickle.loads(path.read_bytes())
    t0 = time.perf_counter()
    t = make_tunnel_tour(n, scenario=scenario, random_state=seed)
    path.write_bytes(pickle.dumps(t))
    print(f"  simulated {t.name}: {n} frames ({time.perf_counter() - t0:.0f} s)", flush=True)
    return t


def segments(X, y, n_segments):
    """Cut one tour into ``n_segments`` consecutive tours (groups for GroupKFold)."""
    bounds = np.linspace(0, len(X), n_segments + 1).astype(int)
    recs, groups = [], []
    for k in range(n_segments):
        for r in X[bounds[k] : bounds[k + 1]]:
            name = f"{r.tour}/part{k + 1}"
            recs.append(dataclasses.replace(r, tour=name))
            groups.append(name)
    return FrameSequence(recs), list(y), np.asarray(groups, dtype=object)


def row(name, s):
    c, t = s["cluster"], s["trajectory"]
    return (
        f"| {name} | {c['total']} | {c['correct']} | {c['misses']} | {c['false_alarms']} | "
        f"{100 * c['detection_rate']:.1f} % | {100 * c['false_alarm_rate']:.2f} % | "
        f"{t['indicators']} | {t['detected']} | {t['false_alarms']} |"
    )


HEADER = (
    "| {} | clusters on indicators | correct | misses | false alarms | detection rate | "
    "false-alarm rate | indicators | detected | false-alarm trajectories |\n"
    "|---|---|---|---|---|---|---|---|---|---|"
)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=3000)
    ap.add_argument("--train-frames", type=int, default=1500)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--train-scenario", default="heavy", choices=["light", "heavy", "curved"])
    ap.add_argument("--no-search", dest="search", action="store_false")
    ap.add_argument("--segments", type=int, default=3)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument(
        "--before-cross-condition", action="store_true",
        help="the defaults these tables were measured with: raw histograms "
             "(appearance__features='histogram', appearance__augment=0) and the "
             "straight-line motion check (motion__criterion='pearson')",
    )
    args = ap.parse_args()
    t_start = time.perf_counter()
    print("simulating tours", flush=True)
    train = tour(args.train_frames, args.train_scenario, args.seed)
    tests = {
        sc: tour(args.frames, sc, args.seed + k)
        for k, sc in enumerate(("light", "heavy", "curved"), 11)
    }
    Xtr, ytr, _ = to_xy([train])
    data = {sc: to_xy([t])[:2] for sc, t in tests.items()}
    base = {"random_state": args.seed}
    if args.before_cross_condition:
        base.update(appearance__features="histogram", appearance__augment=0,
                    motion__criterion="pearson")

    if args.search:
        print("grid search on the training tour", flush=True)
        t0 = time.perf_counter()
        Xs, ys, gs = segments(Xtr, ytr, args.segments)
        search = GridSearchCV(
            make_indicator_pipeline(**base),
            SEARCH_GRID,
            cv=GroupKFold(args.segments),
            scoring={
                "youden": make_tunnel_scorer(),
                "trajectory_detection_rate": make_tunnel_scorer("trajectory_detection_rate"),
                "trajectory_false_alarms": make_tunnel_scorer("trajectory_false_alarms"),
            },
            refit=False,
            error_score="raise",
            n_jobs=args.jobs,
        ).fit(Xs, ys, groups=gs)
        res = search.cv_results_
        best = int(np.argmin(res["rank_test_youden"]))
        base.update(res["params"][best])
        print(f"  {time.perf_counter() - t0:.0f} s", flush=True)

    results = {}

    def evaluate(name, params, verifier=True):
        t0 = time.perf_counter()
        pipe = make_indicator_pipeline(verifier=verifier, **{**base, **params}).fit(Xtr, ytr)
        outs = {sc: pipe.predict(X) for sc, (X, _) in data.items()}
        results[name] = {sc: indicator_scores(o, data[sc][1]) for sc, o in outs.items()}
        results[name]["all"] = indicator_scores(
            [r for o in outs.values() for r in o],
            [b for sc in outs for b in data[sc][1]],
        )
        print(f"  evaluated: {name} ({time.perf_counter() - t0:.0f} s)", flush=True)
        return pipe

    default = evaluate("default", {})
    variants = {
        "paper's raw histograms (keypoint rectangle, margin 0)": {
            "clusters__box": "keypoints", "appearance__margin": 0.0},
        "region rectangle, margin 0": {"appearance__margin": 0.0},
        "paper's fixed keypoint band [160, 190]": {"keypoints__band": "fixed"},
        "no motion check": {"motion__min_r": 0.0, "motion__min_length": 1},
        "no positive weighting": {"appearance__positive_weight": 1.0},
        "Hungarian linking": {"tracks__assignment": "hungarian"},
        "paper's stages 3-5 (keypoint rectangle, margin 0, max_gap 3)": {
            "clusters__box": "keypoints", "appearance__margin": 0.0, "tracks__max_gap": 3},
        "paper's stages 2-5 (also the paper's verifier: 10 centres, 0.14, no margin)": {
            "clusters__box": "keypoints", "appearance__margin": 0.0, "tracks__max_gap": 3,
            "verifier__n_centers": 10, "verifier__max_distance": 0.14,
            "verifier__margin": None, "verifier__context_size": None},
        "verifier with the context histogram (the verifier's own defaults: 25 x 13, "
        "weight 1.5, max_distance 0.4)": {
            "verifier__context_size": (25, 13), "verifier__max_distance": 0.4},
    }
    for name, params in variants.items():
        evaluate(name, params)
    evaluate("no keypoint verifier", {}, verifier=False)

    # a camera with another gain: every frame (training and test) mapped by
    # gain * I + offset; the keypoint band learned from the training tour (default)
    # against the paper's fixed [160, 190]
    gains = {}
    for gain, offset in GAINS:
        Xg = other_gain(Xtr, gain, offset)
        tests_g = {sc: (other_gain(X, gain, offset), y) for sc, (X, y) in data.items()}
        for band in ("learned", "fixed"):
            t0 = time.perf_counter()
            try:
                pipe = make_indicator_pipeline(**base, keypoints__band=band).fit(Xg, ytr)
            except ValueError as exc:  # no keypoint on any indicator: nothing to fit
                gains[(gain, offset, band)] = str(exc)
                continue
            outs = [r for X, _ in tests_g.values() for r in pipe.predict(X)]
            gains[(gain, offset, band)] = (
                indicator_scores(outs, [b for _, y in tests_g.values() for b in y]),
                (pipe.named_steps["keypoints"].low_, pipe.named_steps["keypoints"].high_),
            )
            print(f"  evaluated: gain {gain}, offset {offset}, {band} band "
                  f"({time.perf_counter() - t0:.0f} s)", flush=True)

    # bias-weight experiment: training correct rates of the appearance machine, on
    # the paper's raw histograms and on the default ones
    bias = {}
    verified = default[:2].transform(Xtr)
    for hist_name, box, margin in (("paper's raw histograms", "keypoints", 0.0),
                                   ("default histograms", "region", None)):
        clusters = clone(default.named_steps["clusters"]).set_params(box=box)
        train_clusters = clusters.fit_transform(verified)
        probe = clone(default.named_steps["appearance"])
        if margin is not None:
            probe.set_params(margin=margin)
        H, labels = [], []
        for (_, b, h), gt in zip(probe._frame_histograms(list(train_clusters)), ytr,
                                 strict=True):
            H.append(h)
            labels.append(centres_in_boxes(b, gt))
        H, labels = np.concatenate(H), np.concatenate(labels)
        for w in (1.0, 7.0):
            clf = WeightedAdaBoost(positive_weight=w).fit(H, labels)
            pred = clf.predict(H)
            bias[f"{hist_name}, positives x{w:g}"] = {
                "overall": float((pred == labels).mean()),
                "positive": float(pred[labels].mean()),
                "negative": float((~pred[~labels]).mean()),
                "n_positive": int(labels.sum()),
                "n_negative": int((~labels).sum()),
            }

    # issue 4: the keypoint verifier of the default pipeline, and its trade-off curve
    sampler = default.named_steps["keypoints"]
    verifier = default.named_steps["verifier"]
    curve = {}
    wide = clone(verifier).set_params(n_centers=20).fit(sampler.transform(Xtr), ytr)
    for nc, ver in ((verifier.n_centers, verifier), (20, wide)):
        for md in CURVE:
            # max_distance is used by transform only: the fitted centres stay
            v = copy.deepcopy(ver).set_params(max_distance=md)
            figs = {sc: detection_figures(sampler, v, t) for sc, t in tests.items()}
            curve[(nc, md)] = figs

    # ---------------------------------------------------------------- report
    print()
    if args.search:
        print(f"## Grid search (GroupKFold({args.segments}) over segments of {train.name})\n")
        print("| min_r | min_length | youden | trajectory detection rate "
              "| false-alarm trajectories |\n|---|---|---|---|---|")
        for k, p in enumerate(res["params"]):
            mark = " **(best)**" if k == best else ""
            print(f"| {p['motion__min_r']} | {p['motion__min_length']} | "
                  f"{res['mean_test_youden'][k]:.4f}{mark} | "
                  f"{res['mean_test_trajectory_detection_rate'][k]:.3f} | "
                  f"{-res['mean_test_trajectory_false_alarms'][k]:.2f} |")
        print()
    print(f"## Detection (train: {train.name}, {len(train)} frames; "
          f"parameters: {json.dumps({k: v for k, v in base.items()})})\n")
    print(HEADER.format("test tour"))
    for sc, t in tests.items():
        print(row(f"{t.name} ({len(t)} frames)", results["default"][sc]))
    print(row("all three", results["default"]["all"]))
    print("\n## Ablation (sums over the three test tours)\n")
    print(HEADER.format("variant"))
    for name, per in results.items():
        print(row(name, per["all"]))
    print("\n## A camera with another gain (every frame mapped by gain * I + offset; "
          "sums over the three test tours)\n")
    print(HEADER.format("gain, offset, keypoint band | band") + "---|")  # one more column
    for (gain, offset, band), res in gains.items():
        if isinstance(res, str):
            print(f"| {gain}, {offset}, {band} | | fit fails: {res} |")
        else:
            sc, (lo, hi) = res
            print(row(f"{gain}, {offset}, {band} | [{lo:.1f}, {hi:.1f}]", sc))
    print("\n## Cross-camera (test tour: curved, the other camera)\n")
    print(HEADER.format("histogram"))
    for name in ("paper's raw histograms (keypoint rectangle, margin 0)",
                 "region rectangle, margin 0", "default"):
        print(row(name, results[name]["curved"]))
    print("\n## Bias weight (training correct rates of WeightedAdaBoost)\n")
    print("| histograms, initial weights | overall | positive | negative | positive / "
          "negative training clusters |\n|---|---|---|---|---|")
    for name, b in bias.items():
        print(
            f"| {name} | {100 * b['overall']:.1f} % | {100 * b['positive']:.1f} % | "
            f"{100 * b['negative']:.1f} % | {b['n_positive']} / {b['n_negative']} |"
        )
    print("\n## Keypoint verifier (issue 4) on the test tours\n")
    print("| n_centers | max_distance | " + " | ".join(
        f"{sc}: indicators > 14 px kept / negatives removed" for sc in tests)
        + " | all: kept | all: > 20 px kept | all: negatives removed |")
    print("|---" * (len(tests) + 5) + "|")
    for (nc, md), figs in curve.items():
        tot = {k: sum(f[k] for f in figs.values()) for k in next(iter(figs.values()))}
        cells = [f"{f['hit'] / max(f['instances'], 1):.1%} / "
                 f"{1 - f['negatives_kept'] / max(f['negatives'], 1):.1%}" for f in figs.values()]
        mark = " **(default)**" if (nc, md) == (verifier.n_centers, verifier.max_distance) else ""
        print(f"| {nc} | {md}{mark} | " + " | ".join(cells)
              + f" | {tot['hit'] / tot['instances']:.1%} of {tot['instances']} | "
              f"{tot['hit_20'] / max(tot['instances_20'], 1):.1%} | "
              f"{1 - tot['negatives_kept'] / tot['negatives']:.1%} of {tot['negatives']} |")
    out = CACHE / f"eval_results-{args.seed}.json"
    out.write_text(json.dumps({"params": base, "results": results, "bias": bias,
                               "verifier_curve": {f"{k[0]}/{k[1]}": v for k, v in curve.items()}},
                              indent=1, default=int))
    print(f"\nwrote {out}; total {time.perf_counter() - t_start:.0f} s")


if __name__ == "__main__":
    main()
