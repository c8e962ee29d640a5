"""Fleet throughput: ``detect tunnel`` over many tours, in tours per minute, by workers.

``--tours`` simulated tours of ``--frames`` frames (light traffic, seeds from 200) are
detected by one command, ``tunnelsense detect tunnel --model M TOUR... --out DIR
--jobs N`` (a fresh output folder each time, so no tour is skipped), for each N of
``--workers``, interleaved, ``--repeats`` times; the script prints the median wall time
of the whole command and the tours per minute.  With N = 1 the tours are detected one
after another in the command's process; otherwise in N worker processes.

    python benchmarks/bench_fleet.py --tours 8 --frames 150 --workers 1 2 4
"""

import argparse
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _cli(*argv):
    return [sys.executable, "-m", "tunnelsense._cli", *argv]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tours", type=int, default=8)
    parser.add_argument("--frames", type=int, default=150)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2, 4])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        tours = []
        for i in range(args.tours):
            tours.append(str(work / f"t{i:02d}"))
            subprocess.run(_cli("simulate", "tunnel", tours[-1], "--frames",
                                str(args.frames), "--seed", str(200 + i)),
                           check=True, capture_output=True)
        subprocess.run(_cli("simulate", "tunnel", str(work / "train"), "--frames",
                            "300", "--seed", "199"), check=True, capture_output=True)
        model = str(work / "m.skops")
        subprocess.run(_cli("train", "tunnel", str(work / "train"), "--model", model,
                            "--quiet"), check=True, capture_output=True)
        times = {n: [] for n in args.workers}
        for _ in range(args.repeats):
            for n in args.workers:
                out = work / f"out-{n}"
                shutil.rmtree(out, ignore_errors=True)
                start = time.perf_counter()
                subprocess.run(_cli("detect", "tunnel", "--model", model, *tours,
                                    "--out", str(out), "--jobs", str(n), "--quiet"),
                               check=True, capture_output=True)
                times[n].append(time.perf_counter() - start)
    print(f"{args.tours} tours of {args.frames} frames, one command, median of "
          f"{args.repeats} (interleaved):")
    for n, values in times.items():
        t = statistics.median(values)
        print(f"  --jobs {n}: {t:6.1f} s, {60 * args.tours / t:5.1f} tours per minute")
    return 0


if __name__ == "__main__":
    sys.exit(main())
