"""The detector's per-frame work, stage by stage, beside the PNG decode of the same frames.

What ``tunnelsense detect tunnel`` does in its own thread for every frame, measured on
frames already in memory: a fitted model (``--model``, as ``tunnelsense train tunnel``
writes it) is streamed over each tour's frames one at a time
(``StreamingPipeline``, as the command streams them), the time of every stage's
``push`` summed per stage; interleaved with it in every repeat, ``cv2.imdecode`` of the
same frames encoded as PNG (the work of the command's reader threads).  Each figure is
the median over ``--repeats`` of milliseconds a frame, both as CPU time of this
process (``time.process_time``: it moves less with the load of a shared machine) and
as wall time; the ratio of the detector's total to the decode is paired per repeat
(median and range).  The machine's load average is printed before and after each
tour: on a busy machine both times grow, the wall time most.

    python benchmarks/bench_detect_stages.py --model M.skops TOUR [TOUR ...] [--repeats 5]

One BLAS and one OpenCV thread (as the command's detection thread).  The tours are
MOTChallenge folders (``tunnelsense simulate tunnel``; ``bench_detect_end_to_end.py
--workdir`` keeps its tours and model).
"""

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

import argparse  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import cv2  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "docs" / "figures"))
from _common import load  # noqa: E402

cv2.setNumThreads(1)


def _one_pass(stream, names, frames, clock):
    """Seconds of each stage's pushes over ``frames``, and of the whole pass."""
    spent = dict.fromkeys(names, 0.0)
    start = clock()
    for record in frames:
        batch = [record]
        for name, state in zip(names, stream._states, strict=True):
            t = clock()
            out = []
            for r in batch:
                out.extend(state.push(r))
            spent[name] += clock() - t
            batch = out
            if not batch:
                break
    for state in stream._states:  # what the stateful stages still hold
        state.close()
    return spent, clock() - start


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", required=True, help="a model of 'train tunnel'")
    parser.add_argument("tours", nargs="+", help="MOTChallenge tour folders")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats: expected a whole number >= 1")

    from tunnelsense import FrameRecord
    from tunnelsense._streaming import StreamingPipeline
    from tunnelsense.io import load_model, open_tour
    from tunnelsense.tunnel._kmeans import blas_threads

    model = load_model(args.model)
    names = [n for n, s in model.steps if s != "passthrough"]
    print(f"model {args.model}; {args.repeats} repeats, medians of ms a frame "
          "(CPU time / wall time); 1 BLAS and 1 OpenCV thread")
    head = ("| tour | frames | keypoints / frame | clusters / frame | "
            + " | ".join(names) + " | detector | PNG decode | detector / decode, "
            "CPU: median (range) | same, wall | load before -> after |")
    print("\n" + head)
    print("|" + "---|" * (head.count("|") - 1))
    for path in args.tours:
        before = load()
        tour = open_tour(path, ground_truth=False)
        frames = [FrameRecord(r.tour, r.frame, r.image, dict(r.payload))
                  for r in tour.frames]
        pngs = [cv2.imencode(".png", r.image)[1] for r in frames]
        cpu = {n: [] for n in [*names, "detector", "decode"]}
        wall = {n: [] for n in [*names, "detector", "decode"]}
        with blas_threads(1):
            for _ in range(args.repeats):
                for clock, into in ((time.process_time, cpu), (time.perf_counter, wall)):
                    spent, total = _one_pass(StreamingPipeline(model), names, frames,
                                             clock)
                    for n in names:
                        into[n].append(spent[n])
                    into["detector"].append(total)
                    start = clock()
                    for p in pngs:
                        cv2.imdecode(p, cv2.IMREAD_UNCHANGED)
                    into["decode"].append(clock() - start)
        counted = model[:3].transform(frames[::10])
        kp = np.mean([len(r.payload["sampled_keypoints"]) for r in counted])
        clusters = np.mean([len(r.payload["cluster_boxes"]) for r in counted])
        n = len(frames)

        def ms(into, key, n=n):
            return 1e3 * statistics.median(into[key]) / n

        ratios = {k: [a / b for a, b in zip(v["detector"], v["decode"], strict=True)]
                  for k, v in (("cpu", cpu), ("wall", wall))}
        cells = " | ".join(f"{ms(cpu, k):.2f} / {ms(wall, k):.2f}"
                           for k in [*names, "detector", "decode"])
        rc, rw = ratios["cpu"], ratios["wall"]
        print(f"| {tour.name} | {n} | {kp:.0f} | {clusters:.1f} | {cells} | "
              f"{statistics.median(rc):.2f} ({min(rc):.2f}-{max(rc):.2f}) | "
              f"{statistics.median(rw):.2f} ({min(rw):.2f}-{max(rw):.2f}) | "
              f"{before} -> {load()} |", flush=True)


if __name__ == "__main__":
    main()
