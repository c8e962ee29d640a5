"""Render speed of the far-infrared tunnel simulator, beside two peers.

Issue 3 asks for 1,500 frames in at most 30 s on one core (20 ms per frame, all in).
Peers measured in the same run on frames of the same size:

* ``png``: OpenCV PNG encode + decode of the simulated frames (what writing and reading
  a MOTChallenge folder costs per frame);
* ``noise``: ``numpy.random.Generator.standard_normal`` of one 480x640 float32 frame
  cast to uint8 (the cheapest possible "simulator").

Run: ``python benchmarks/bench_tunnel_simulator.py [--frames 300] [--repeats 3]``.
"""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import time  # noqa: E402

import cv2  # noqa: E402
import numpy as np  # noqa: E402

from tunnelsense.datasets import TUNNEL_SCENARIOS, make_tunnel_tour  # noqa: E402

cv2.setNumThreads(1)


def _median_time(fn, repeats):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    n = args.frames

    tour = make_tunnel_tour(n, random_state=0)
    images = [r.image for r in tour.frames]

    def png():
        for im in images:
            ok, buf = cv2.imencode(".png", im)
            cv2.imdecode(buf, cv2.IMREAD_UNCHANGED)

    rng = np.random.default_rng(0)

    def noise():
        for _ in range(n):
            frame = rng.standard_normal((480, 640), dtype=np.float32)
            np.clip(frame * 20 + 100, 0, 255).astype(np.uint8)

    t_png = _median_time(png, args.repeats)
    t_noise = _median_time(noise, args.repeats)
    print(f"{n} frames 640x480, median of {args.repeats} repeats, one thread")
    header = (
        f"{'what':<22}{'ms/frame':>10}{'frames/s':>10}{'1500 frames (s)':>17}"
        f"{'/ png':>8}{'/ noise':>9}"
    )
    print(header)
    print("-" * len(header))

    def row(what, seconds):
        ms = 1e3 * seconds / n
        print(
            f"{what:<22}{ms:>10.2f}{n / seconds:>10.1f}{1500 * seconds / n:>17.1f}"
            f"{seconds / t_png:>8.2f}{seconds / t_noise:>9.2f}"
        )

    for scenario in TUNNEL_SCENARIOS:
        seconds = _median_time(
            lambda s=scenario: make_tunnel_tour(n, scenario=s, random_state=1), args.repeats
        )
        row(f"simulate {scenario}", seconds)
    row("peer: png enc+dec", t_png)
    row("peer: np.random noise", t_noise)
    print("budget (issue 3): 1500 frames <= 30 s, i.e. <= 20 ms/frame")


if __name__ == "__main__":
    main()
