"""Whole-process ``tunnelsense train tunnel`` on one tour from disk, beside a bare decode,
on a quiet machine and beside two busy processes.

For one ``--frames`` light-traffic tour (640x480 PNGs, simulated once into
``--workdir``) this script runs, interleaved, ``--repeats`` times each:

* ``decode``: a fresh process that decodes every PNG of the tour and nothing else;
* ``train``: ``tunnelsense train tunnel TOUR --model M --force --quiet``;
* ``train --jobs 1``: the same with one reader thread;

first on the machine as it is, then again with two busy-looping processes beside
it (a loaded vehicle computer or CI runner).  It prints the medians, the ratio
train / decode, and under load the ratio default / ``--jobs 1`` (goal: at most 1.0,
the default never slower under load than one thread), and exits 1 when the quiet
median exceeds ``--budget`` seconds (default 5 s, for 1,500 frames).

    python benchmarks/bench_train_tunnel.py --frames 1500 --repeats 5
"""

import argparse
import multiprocessing as mp
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

_DECODE = (
    "import sys, glob, cv2, numpy as np\n"
    "for f in sorted(glob.glob(sys.argv[1] + '/img1/*.png')):\n"
    "    cv2.imdecode(np.fromfile(f, np.uint8), cv2.IMREAD_UNCHANGED)\n"
)


def _busy():
    while True:
        pass


def _timed(cmd):
    start = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - start


def _round(tour, model, repeats):
    cli = [sys.executable, "-m", "tunnelsense._cli", "train", "tunnel", str(tour),
           "--model", str(model), "--force", "--quiet"]
    runs = {"decode": [sys.executable, "-c", _DECODE, str(tour)],
            "train": cli, "train --jobs 1": [*cli, "--jobs", "1"]}
    times = {k: [] for k in runs}
    for _ in range(repeats):
        for name, cmd in runs.items():
            times[name].append(_timed(cmd))
    return {k: statistics.median(v) for k, v in times.items()}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--frames", type=int, default=1500)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--budget", type=float, default=5.0)
    p.add_argument("--workdir", type=Path, default=None)
    args = p.parse_args(argv)
    work = args.workdir or Path(tempfile.mkdtemp(prefix="bench-train-"))
    tour = work / "light"
    if not (tour / "seqinfo.ini").is_file():
        from tunnelsense.datasets import make_tunnel_tour
        from tunnelsense.io import write_tour

        write_tour(make_tunnel_tour(args.frames, scenario="light", random_state=0), tour)
    model = work / "m.skops"
    quiet = _round(tour, model, args.repeats)
    busy = [mp.Process(target=_busy, daemon=True) for _ in range(2)]
    for b in busy:
        b.start()
    try:
        loaded = _round(tour, model, args.repeats)
    finally:
        for b in busy:
            b.terminate()
    print(f"train tunnel, {args.frames} frames, medians of {args.repeats}:")
    for label, m in (("quiet", quiet), ("2 busy processes", loaded)):
        print(f"  {label:17s} decode {m['decode']:6.2f} s  train {m['train']:6.2f} s "
              f"({m['train'] / m['decode']:.2f}x decode)  --jobs 1 {m['train --jobs 1']:6.2f} s")
    ratio = loaded["train"] / loaded["train --jobs 1"]
    print(f"  under load, default / --jobs 1: {ratio:.2f} (goal <= 1.0 within noise)")
    if quiet["train"] > args.budget:
        print(f"over budget: {quiet['train']:.2f} s > {args.budget} s")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
