"""Detection figures of the FIR indicator detector on simulated tours.

Trains on one simulated tour (``--train-scenario``, default heavy traffic, camera A:
traffic supplies the negative clusters the appearance machine learns from) and evaluates on other seeds of
every scenario ("light", "heavy", and "curved", which is another camera: focal length
620 px, mounted 1.35 m high, noise sigma 4, a curving tunnel).  Prints, as markdown:

1. the cluster-level table (the paper's Table 1) and trajectory figures per tour;
2. the cross-camera figures: the paper's bare-rectangle histograms (margin 0) against
   the default grown rectangle;
3. the ablation table: no motion check, no positive weighting, no keypoint verifier,
   greedy vs Hungarian linking;
4. the paper's bias-weight experiment: training correct rates of the appearance
   machine, evenly weighted vs positives x7.

Usage::

    python benchmarks/eval_indicator_detector.py [--frames 3000] [--train-frames 1500]

Simulated tours are cached under ``$TMPDIR/tunnelsense-eval`` (delete to refresh).
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import tempfile
import time
from pathlib import Path

import numpy as np

from tunnelsense import to_xy
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.metrics import indicator_scores
from tunnelsense.tunnel import WeightedAdaBoost, make_indicator_pipeline
from tunnelsense.tunnel._appearance import centres_in_boxes

CACHE = Path(os.environ.get("TMPDIR", tempfile.gettempdir())) / "tunnelsense-eval"


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


def run_tail(head_out, y_train_out, train_clusters, variant_params, test_clusters):
    """Fit stages 4-6 (with params) on the training clusters; predict test tours."""
    pipe = make_indicator_pipeline(**variant_params)
    tail = pipe[3:]
    tail.fit(train_clusters, y_train_out)
    return {name: tail.predict(Z) for name, Z in test_clusters.items()}


def row(name, s):
    c, t = s["cluster"], s["trajectory"]
    return (
        f"| {name} | {c['total']} | {c['correct']} | {c['misses']} | {c['false_alarms']} | "
        f"{100 * c['detection_rate']:.1f} % | {100 * c['false_alarm_rate']:.2f} % | "
        f"{t['detected']} / {t['indicators']} | {t['false_alarms']} |"
    )


HEADER = (
    "| {} | clusters on indicators | correct | misses | false alarms | detection rate | "
    "false-alarm rate | indicators found | false-alarm trajectories |\n"
    "|---|---|---|---|---|---|---|---|---|"
)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=3000)
    ap.add_argument("--train-frames", type=int, default=1500)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--train-scenario", default="heavy", choices=["light", "heavy", "curved"])
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

    print("fitting stages 1-3", flush=True)
    t0 = time.perf_counter()
    base = make_indicator_pipeline(random_state=args.seed)
    head = base[:3].fit(Xtr, ytr)
    train_clusters = head.transform(Xtr)
    test_clusters = {sc: head.transform(X) for sc, (X, _) in data.items()}
    print(f"  {time.perf_counter() - t0:.0f} s", flush=True)

    results = {}

    def evaluate(name, params, clusters=None, train_c=None):
        outs = run_tail(None, ytr, train_c or train_clusters, params, clusters or test_clusters)
        results[name] = {sc: indicator_scores(o, data[sc][1]) for sc, o in outs.items()}
        results[name]["all"] = indicator_scores(
            [r for o in outs.values() for r in o],
            [b for sc in outs for b in data[sc][1]],
        )
        return results[name]

    variants = {
        "default": {},
        "bare rectangle (margin 0, paper)": {"appearance__margin": 0.0},
        "no motion check": {"motion__min_r": 0.0, "motion__min_length": 1},
        "no positive weighting": {"appearance__positive_weight": 1.0},
        "Hungarian linking": {"tracks__assignment": "hungarian"},
    }
    for name, params in variants.items():
        evaluate(name, params)
        print(f"  evaluated: {name}", flush=True)

    print("fitting without the keypoint verifier", flush=True)
    head_nv = make_indicator_pipeline(verifier=False)[:3].fit(Xtr, ytr)
    evaluate(
        "no keypoint verifier",
        {},
        {sc: head_nv.transform(X) for sc, (X, _) in data.items()},
        head_nv.transform(Xtr),
    )

    # bias-weight experiment: training correct rates of the appearance machine
    bias = {}
    probe = WeightedAdaBoost()
    H, labels = [], []
    for (_, b, h), gt in zip(probe._frame_histograms(list(train_clusters)), ytr, strict=True):
        H.append(h)
        labels.append(centres_in_boxes(b, gt))
    H, labels = np.concatenate(H), np.concatenate(labels)
    for w in (1.0, 7.0):
        clf = WeightedAdaBoost(positive_weight=w).fit(H, labels)
        pred = clf.predict(H)
        bias[w] = {
            "overall": float((pred == labels).mean()),
            "positive": float(pred[labels].mean()),
            "negative": float((~pred[~labels]).mean()),
            "n_positive": int(labels.sum()),
            "n_negative": int((~labels).sum()),
        }

    # ---------------------------------------------------------------- report
    print()
    print(f"## Detection (train: {train.name}, {len(train)} frames)\n")
    print(HEADER.format("test tour"))
    for sc, t in tests.items():
        print(row(f"{t.name} ({len(t)} frames)", results["default"][sc]))
    print(row("all three", results["default"]["all"]))
    print("\n## Ablation (sums over the three test tours)\n")
    print(HEADER.format("variant"))
    for name, per in results.items():
        print(row(name, per["all"]))
    print("\n## Cross-camera (test tour: curved, the other camera)\n")
    print(HEADER.format("histogram"))
    for name in ("bare rectangle (margin 0, paper)", "default"):
        print(row(name, results[name]["curved"]))
    print("\n## Bias weight (training correct rates of WeightedAdaBoost)\n")
    print("| initial weights | overall | positive | negative |\n|---|---|---|---|")
    for w, b in bias.items():
        print(
            f"| positives x{w:g} | {100 * b['overall']:.1f} % | {100 * b['positive']:.1f} % | "
            f"{100 * b['negative']:.1f} % |"
        )
    n = bias[1.0]
    print(f"\n({n['n_positive']} positive and {n['n_negative']} negative training clusters)")
    out = CACHE / "eval_results.json"
    out.write_text(json.dumps({"results": results, "bias": bias}, indent=1))
    print(f"\nwrote {out}; total {time.perf_counter() - t_start:.0f} s")


if __name__ == "__main__":
    main()
