"""Whole-process ``tunnelsense detect street`` beside a plain NumPy/SciPy reference.

What a user runs is the command, from a run on disk.  The peer is
``street_reference.py`` (beside this script): the paper's section III implemented
plainly with NumPy and SciPy (single linkage by ``scipy.cluster.hierarchy`` per scan),
reading the same ``scans.npz`` and writing an object table.  For each run this script
runs the two, interleaved, ``--repeats`` times, each in a fresh process:

* ``ours``: ``tunnelsense detect street RUN --model M --out O --force --quiet``;
* ``reference``: ``python street_reference.py RUN O``;

and prints the medians (CPU time of the process, user + sys, and wall time) and the
ratio ours / reference (below 1: ours is faster), and the objects each found.
``--also-region-depth near`` also times the same model with ``region_depth="near"``
(saved beside it), interleaved with the others, and prints ours / that.  The runs (``--scans`` scans, simulated once into
``--workdir``): ``sparse`` (the simulator's plain street) and ``hard``; the model is
trained by ``tunnelsense train street`` on a third run (seed 1).

    python benchmarks/bench_street_end_to_end.py --scans 4000 --repeats 5

Measured 2026-11-29 with ``region_depth="across"`` the default, ``--scans 4000
--repeats 5 --also-region-depth near``, shared 2-core machine (load average 5.9),
CPU seconds (user + sys), medians of paired ratios: sparse ours 1.35 s, reference
1.67 s, ours/reference 0.81, ours/near 1.00; hard ours 1.33 s, reference 1.55 s,
ours/reference 0.94, ours/near 1.02 (wall: 0.67 and 0.84 against the reference).
The same objects with either region depth on both runs (46 and 92).

Measured 2026-11-29 (street12: hidden ends bounded by the beams, objects cut by the
run's end tested, the wet road's beams ending at the road), ``--scans 4000
--repeats 5``, load average 9.9, CPU medians of paired ratios: sparse ours 1.43 s,
reference 1.87 s, ours/reference 0.76; hard ours 1.52 s, reference 1.69 s,
ours/reference 0.90 (wall 0.76 and 0.90). Objects 46 and 92, as before.
"""

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

_REFERENCE = Path(__file__).with_name("street_reference.py")


def _cli(*argv):
    return [sys.executable, "-m", "tunnelsense._cli", *argv]


def _cpu():
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    return used.ru_utime + used.ru_stime


def _timed(cmd):
    """Wall and CPU seconds (user + sys) of one process, and its last line."""
    start, cpu = time.perf_counter(), _cpu()
    done = subprocess.run(cmd, check=True, capture_output=True, text=True)
    return (time.perf_counter() - start, _cpu() - cpu,
            done.stdout.strip().splitlines()[-1])


def _other_model(model, region_depth):
    """A copy of ``model`` with another ``region_depth`` (the same fit)."""
    from tunnelsense.io import load_model, save_model

    path = model.with_name(f"{model.stem}-{region_depth}{model.suffix}")
    pipe = load_model(model)
    pipe.set_params(cluster__region_depth=region_depth)
    return save_model(pipe, path, overwrite=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scans", type=int, default=4000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--workdir", help="keep the runs here (default: a temporary "
                        "folder)")
    parser.add_argument("--also-region-depth", default=None,
                        help="also time the model with this region_depth")
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
        other = (None if args.also_region_depth is None
                 else _other_model(model, args.also_region_depth))
        print(f"whole processes, {args.scans} scans a run, median of {args.repeats} "
              f"(interleaved, paired), load average {os.getloadavg()[0]:.1f}:")
        for name in ("sparse", "hard"):
            run = str(work / name)
            cmds = {
                "ours": _cli("detect", "street", run, "--model", str(model), "--out",
                             str(work / f"{name}-ours.csv"), "--force", "--quiet"),
                "reference": [sys.executable, str(_REFERENCE), run,
                              str(work / f"{name}-reference.csv")],
            }
            if other is not None:
                cmds["other"] = _cli("detect", "street", run, "--model", str(other),
                                     "--out", str(work / f"{name}-other.csv"),
                                     "--force", "--quiet")
            wall, cpu, said = {k: [] for k in cmds}, {k: [] for k in cmds}, {}
            for _ in range(args.repeats):
                for key, cmd in cmds.items():
                    seconds, cpu_seconds, said[key] = _timed(cmd)
                    wall[key].append(seconds)
                    cpu[key].append(cpu_seconds)
            for what, times in (("cpu", cpu), ("wall", wall)):
                pairs = [k for k in ("reference", "other") if k in cmds]
                line = f"  {name:6s} {what:4s} ours {statistics.median(times['ours']):6.2f} s"
                for k in pairs:
                    ratios = [a / b for a, b in zip(times["ours"], times[k], strict=True)]
                    label = k if k == "reference" else args.also_region_depth
                    line += (f"  {label} {statistics.median(times[k]):6.2f} s  ours/{label}"
                             f" {statistics.median(ratios):5.2f}")
                print(line + " (medians of paired ratios)")
            for key in cmds:
                print(f"         {key}: {said[key]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
