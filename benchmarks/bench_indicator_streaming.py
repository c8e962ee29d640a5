"""Streaming FIR indicator detector: per-frame latency beside batch throughput, memory.

Latency (default): a fitted ``make_indicator_pipeline`` is run over the same in-memory
640x480 frames twice per repeat -- online through ``StreamingPipeline.push`` (one frame
at a time, timing every push) and in batch through ``predict`` -- and the table gives
the median over repeats of the push time's p50 and p99 beside the batch time per frame.

Memory (``--memory``): simulates ``--frames`` frames, writes them as an MJPG video once
and repeated 10 times, trains a model on another simulated tour, and runs
``tunnelsense detect tunnel`` on each video in a fresh process, reading that process's
peak resident memory (``os.wait4`` -> ``ru_maxrss``).

    python benchmarks/bench_indicator_streaming.py --frames 600 --repeats 5
    python benchmarks/bench_indicator_streaming.py --memory --frames 2000
"""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402


def _fit(train_frames, seed):
    from tunnelsense import to_xy
    from tunnelsense.datasets import make_tunnel_tour
    from tunnelsense.tunnel import make_indicator_pipeline

    train = make_tunnel_tour(train_frames, scenario="heavy", random_state=seed)
    X, y, _ = to_xy([train])
    return make_indicator_pipeline(random_state=seed).fit(X, y)


def latency(args):
    from tunnelsense import to_xy
    from tunnelsense._streaming import StreamingPipeline
    from tunnelsense.datasets import make_tunnel_tour

    model = _fit(args.train_frames, 0)
    tour = make_tunnel_tour(args.frames, scenario="heavy", random_state=1)
    X = to_xy([tour])[0]
    X = type(X)(r.evolve() for r in X)  # in-memory frames
    n = len(X)
    p50, p99, pmax, stream_mean, batch = [], [], [], [], []
    waiting = 0
    for _ in range(args.repeats):
        stream = StreamingPipeline(model)
        times = np.empty(n)
        released = 0
        t_all = time.perf_counter()
        for k, r in enumerate(X):
            t0 = time.perf_counter()
            released += len(stream.push(r))
            times[k] = time.perf_counter() - t0
            waiting = max(waiting, k + 1 - released)
        released += len(stream.close())
        stream_mean.append((time.perf_counter() - t_all) / n)
        assert released == n
        p50.append(np.percentile(times, 50))
        p99.append(np.percentile(times, 99))
        pmax.append(times.max())
        t0 = time.perf_counter()
        model.predict(X)
        batch.append((time.perf_counter() - t0) / n)
    b = float(np.median(batch))
    clusters = sum(len(r.payload["cluster_boxes"]) for r in model.predict(X)) / n
    print(
        f"\n{n} in-memory frames of 640x480 (heavy traffic, {clusters:.2f} clusters per "
        f"frame), median of {args.repeats} runs, one core; at most {waiting} frames held "
        "by the stream\n"
    )
    print("| what | per frame | frames/s | ratio to batch |")
    print("|---|---|---|---|")
    rows = [
        ("batch `predict` (time / frames)", b),
        ("streaming: mean push time (incl. close)", float(np.median(stream_mean))),
        ("streaming: p50 push time", float(np.median(p50))),
        ("streaming: p99 push time", float(np.median(p99))),
        ("streaming: max push time", float(np.median(pmax))),
    ]
    for name, t in rows:
        print(f"| {name} | {1e3 * t:.3f} ms | {1 / t:,.0f} | {t / b:.2f} |")
    _per_stage(model, X, args.repeats)


def _per_stage(model, X, repeats):
    """Each step: one push per frame beside one batch call over all frames."""
    from tunnelsense._streaming import start_stream

    n = len(X)
    steps = [(name, s) for name, s in model.steps if s != "passthrough"]
    print(f"\nper step (its input: the previous steps' batch output), median of {repeats}\n")
    print("| step | streaming, per frame | batch, per frame | ratio |")
    print("|---|---|---|---|")
    inputs = X
    for k, (name, stage) in enumerate(steps):
        final = k == len(steps) - 1
        batch_call = stage.predict if final else stage.transform
        st, bt = [], []
        for _ in range(repeats):
            state = start_stream(stage, final=final)
            t0 = time.perf_counter()
            for r in inputs:
                state.push(r)
            state.close()
            st.append((time.perf_counter() - t0) / n)
            t0 = time.perf_counter()
            out = batch_call(inputs)
            bt.append((time.perf_counter() - t0) / n)
        a, b = float(np.median(st)), float(np.median(bt))
        print(f"| {name} | {1e3 * a:.3f} ms | {1e3 * b:.3f} ms | {a / b:.2f} |")
        inputs = out


def _write_video(path, frames, repeat):
    import cv2

    h, w = frames[0].shape
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (w, h), False)
    if not writer.isOpened():
        raise RuntimeError("OpenCV cannot write MJPG video here")
    for _ in range(repeat):
        for image in frames:
            writer.write(image)
    writer.release()


# A bare Python process runs the command and reports its peak memory: on Linux a child
# starts with the resident size of the process that forked it as its high-water mark, so
# forking from this (large) benchmark process would hide the command's own peak.
_WRAPPER = (
    "import resource, subprocess, sys; p = subprocess.run(sys.argv[1:], "
    "stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True); "
    "print(p.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss); "
    "print(p.stdout.strip())"
)


def _peak_rss_mb(argv):
    t0 = time.perf_counter()
    out = subprocess.run(
        [sys.executable, "-S", "-c", _WRAPPER, *argv], capture_output=True, text=True,
        check=True,
    ).stdout
    elapsed = time.perf_counter() - t0
    head, _, rest = out.partition("\n")
    code, rss_kb = (int(v) for v in head.split())
    if code:
        raise RuntimeError(f"{argv} failed ({code})")
    return rss_kb / 1024.0, elapsed, rest.strip()


def memory(args):
    from tunnelsense.datasets import make_tunnel_tour
    from tunnelsense.io import save_model

    root = Path(tempfile.mkdtemp(prefix="bench-streaming-"))
    model_path = root / "model.skops"
    save_model(_fit(args.train_frames, 0), model_path)
    tour = make_tunnel_tour(args.frames, scenario="light", random_state=1)
    frames = [r.image for r in tour.frames]
    small, large = root / "tour-1x.avi", root / "tour-10x.avi"
    _write_video(small, frames, 1)
    _write_video(large, frames, 10)
    del frames, tour
    cli = [sys.executable, "-c", "import sys; from tunnelsense._cli import main; sys.exit(main())"]
    rows = []
    for video, n in ((small, args.frames), (large, 10 * args.frames)):
        argv = [*cli, "detect", "tunnel", "--model", str(model_path), str(video),
                "--out", str(root / f"{video.stem}.txt")]
        rss, elapsed, out = _peak_rss_mb(argv)
        rows.append((n, video.stat().st_size / 2**20, rss, elapsed, out))
    print(f"\nsources under {root} (MJPG video, {args.frames} simulated frames written once "
          "and 10 times)\n")
    print("| frames | video | peak memory (ru_maxrss) | time | ratio to the short tour |")
    print("|---|---|---|---|---|")
    for n, size, rss, elapsed, _ in rows:
        print(f"| {n:,} | {size:.0f} MiB | {rss:.1f} MiB | {elapsed:.0f} s | "
              f"{rss / rows[0][2]:.3f} |")
    for *_, out in rows:
        print(f"  {out}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=600)
    parser.add_argument("--train-frames", type=int, default=600)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--memory", action="store_true")
    args = parser.parse_args()
    if args.memory:
        memory(args)
    else:
        latency(args)


if __name__ == "__main__":
    main()
