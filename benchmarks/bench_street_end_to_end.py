"""Whole-process ``tunnelsense detect street`` beside a plain NumPy/SciPy reference.

What a user runs is the command, from a run on disk.  The peer is
``street_reference.py`` (beside this script): the paper's section III implemented
plainly with NumPy and SciPy (single linkage by ``scipy.cluster.hierarchy`` per scan),
reading the same ``scans.npz`` and writing an object table.  For each run this script
runs the two, interleaved, ``--repeats`` times, each in a fresh process:

* ``ours``: ``tunnelsense detect street RUN --model M --out O --force --quiet``;
* ``reference``: ``python street_reference.py RUN O``;

and prints the medians and the ratio ours / reference (below 1: ours is faster), and
the objects each found.  The runs (``--scans`` scans, simulated once into
``--workdir``): ``sparse`` (the simulator's plain street) and ``hard``; the model is
trained by ``tunnelsense train street`` on a third run (seed 1).

    python benchmarks/bench_street_end_to_end.py --scans 4000 --repeats 5
"""

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

_REFERENCE = Path(__file__).with_name("street_reference.py")


def _cli(*argv):
    return [sys.executable, "-m", "tunnelsense._cli", *argv]


def _timed(cmd):
    start = time.perf_counter()
    done = subprocess.run(cmd, check=True, capture_output=True, text=True)
    return time.perf_counter() - start, done.stdout.strip().splitlines()[-1]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scans", type=int, default=4000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--workdir", help="keep the runs here (default: a temporary "
                        "folder)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(args.workdir or tmp)
        work.mkdir(parents=True, exist_ok=True)
        runs = {"sparse": 2, "hard": 3, "train": 1}
        for name, seed in runs.items():
            if not (work / name / "scans.npz").exists():
                scenario = "sparse" if name == "train" else name
                subprocess.run(_cli("simulate", "street", str(work / name), "--scans",
                                    str(args.scans), "--seed", str(seed), "--scenario",
                                    scenario, "--force"), check=True,
                               capture_output=True)
        model = work / "street.skops"
        if not model.exists():
            subprocess.run(_cli("train", "street", str(work / "train"), "--model",
                                str(model), "--quiet"), check=True, capture_output=True)
        print(f"whole processes, {args.scans} scans a run, median of {args.repeats} "
              "(interleaved, paired):")
        for name in ("sparse", "hard"):
            run = str(work / name)
            cmds = {
                "ours": _cli("detect", "street", run, "--model", str(model), "--out",
                             str(work / f"{name}-ours.csv"), "--force", "--quiet"),
                "reference": [sys.executable, str(_REFERENCE), run,
                              str(work / f"{name}-reference.csv")],
            }
            times, said = {k: [] for k in cmds}, {}
            for _ in range(args.repeats):
                for key, cmd in cmds.items():
                    seconds, said[key] = _timed(cmd)
                    times[key].append(seconds)
            ratios = [a / b for a, b in zip(times["ours"], times["reference"],
                                            strict=True)]
            ours, ref = (statistics.median(times[k]) for k in ("ours", "reference"))
            print(f"  {name:6s} ours {ours:6.2f} s  reference {ref:6.2f} s  "
                  f"ours/reference {ours / ref:5.2f} (median of paired ratios "
                  f"{statistics.median(ratios):.2f})")
            print(f"         ours: {said['ours']}")
            print(f"         reference: {said['reference']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
