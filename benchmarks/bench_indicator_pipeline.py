"""Speed of the whole FIR indicator pipeline on in-memory 640x480 frames.

Compares, in the same run, on one core:

* the whole pipeline (``predict``) per frame, against the 1 ms budget (1,000 frames/s)
  and the paper's 41 frames/s;
* each stage's share (stages run one after the other on the whole tour);
* OpenCV's PNG decode of the same frames (the pipeline must take at most 1/3 of it);
* the pipeline with canonical radiometry (``keypoints__radiometry="frame"``: every
  frame mapped to the training frames' background level and spread), its cost;
* the pipeline on the same tour seen by a 320x240 sensor (resampled to 640x480).

Figures are medians over ``--repeats`` runs.  Usage::

    python benchmarks/bench_indicator_pipeline.py [--frames 600] [--repeats 5]
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
from tunnelsense.tunnel import make_indicator_pipeline  # noqa: E402

cv2.setNumThreads(1)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=600)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    print("simulating and training (not timed)...", flush=True)
    train = make_tunnel_tour(600, scenario="heavy", random_state=100)
    test = make_tunnel_tour(args.frames, scenario="heavy", random_state=101)
    Xtr, ytr, _ = to_xy([train])
    pipe = make_indicator_pipeline(random_state=0).fit(Xtr, ytr)
    canon = make_indicator_pipeline(random_state=0,
                                    keypoints__radiometry="frame").fit(Xtr, ytr)
    small, _, _ = to_xy([make_tunnel_tour(args.frames, scenario="heavy",
                                          random_state=101, sensor_scale=0.5)])
    X, _, _ = to_xy([test])
    n = len(X)
    pngs = [cv2.imencode(".png", r.image)[1] for r in X]

    whole, decode, stages = [], [], {name: [] for name, _ in pipe.steps}
    whole_raw, whole_small = [], []
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        out = pipe.predict(X)
        whole.append((time.perf_counter() - t0) / n)
        t0 = time.perf_counter()
        canon.predict(X)
        whole_raw.append((time.perf_counter() - t0) / n)
        t0 = time.perf_counter()
        pipe.predict(small)
        whole_small.append((time.perf_counter() - t0) / n)
        Z = X
        for name, step in pipe.steps:
            t0 = time.perf_counter()
            Z = step.predict(Z) if name == "motion" else step.transform(Z)
            stages[name].append((time.perf_counter() - t0) / n)
        t0 = time.perf_counter()
        for p in pngs:
            cv2.imdecode(p, cv2.IMREAD_UNCHANGED)
        decode.append((time.perf_counter() - t0) / n)
    w, d = np.median(whole), np.median(decode)
    clusters = sum(len(r.payload["cluster_boxes"]) for r in out) / n
    print(f"\n{n} frames of 640x480 (heavy traffic), {clusters:.2f} clusters per frame, "
          f"median of {args.repeats} runs, one core\n")
    print("| what | per frame | frames/s | ratio |")
    print("|---|---|---|---|")
    print(f"| whole pipeline (predict) | {w * 1e3:.3f} ms | {1 / w:,.0f} | 1 |")
    for name, ts in stages.items():
        s = np.median(ts)
        print(f"| - stage {name} | {s * 1e3:.3f} ms | {1 / s:,.0f} | {s / w:.2f} of the pipeline |")
    r, sm = np.median(whole_raw), np.median(whole_small)
    print(f"| pipeline with canonical radiometry (option) | {r * 1e3:.3f} ms | "
          f"{1 / r:,.0f} | {r / w:.2f} of the pipeline |")
    print(f"| pipeline on 320x240 frames of the same tour | {sm * 1e3:.3f} ms | "
          f"{1 / sm:,.0f} | {sm / w:.2f} of the pipeline |")
    print(f"| OpenCV PNG decode of the same frame | {d * 1e3:.3f} ms | {1 / d:,.0f} | "
          f"pipeline = {w / d:.2f} x decode (goal <= 0.33) |")
    print(f"| budget: 1,000 frames/s | 1.000 ms | 1,000 | pipeline = {w / 1e-3:.2f} x budget |")
    print(f"| the paper (Core2 Quad 2.6 GHz) | {1e3 / 41:.1f} ms | 41 | pipeline = {41 * w:.3f} x |")


if __name__ == "__main__":
    main()
