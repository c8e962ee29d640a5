"""Whole-process ``tunnelsense train tunnel`` on one tour from disk, beside a bare decode,
on the machine as it is and beside two busy processes.

For one ``--frames`` light-traffic tour (640x480 PNGs, simulated once into
``--workdir``) this script runs, interleaved, ``--repeats`` times each:

* ``decode``: a fresh process that decodes every PNG of the tour and nothing else
  (the floor of any command that reads the tour);
* ``train``: ``tunnelsense train tunnel TOUR --model M --force --quiet``;
* ``train --jobs 1``: the same with one reader thread;
* with ``--sample-rate HZ``, ``train --sample-rate HZ``: the same, decoding and
  fitting HZ frames of each second of the tour only (a model that changes);
* with ``--baseline SRC`` (a source tree, e.g. a ``git worktree`` of an older
  commit), ``baseline train`` and ``baseline train --jobs 1``: the same commands
  run from that tree (``PYTHONPATH=SRC``), for a paired before/after;

first on the machine as it is, then again with two busy-looping processes beside
it (a loaded vehicle computer or CI runner).  It prints the load average before
and after each round, the medians (whole processes, wall time) and each train's
CPU seconds (user + system), the ratio train / decode, and under load the ratio
default / ``--jobs 1`` (goal: at most 1.0, the default never slower under load
than one thread); it exits 1 when the first round's train median exceeds
``--budget`` seconds (default 5 s, for 1,500 frames on a quiet machine).

With ``--phases``, it runs instead, ``--repeats`` times in fresh processes
(interleaved with the baseline's when given), ``train tunnel``'s work phase by
phase in one thread, and prints the median CPU seconds (``time.process_time``)
of each: start-up imports, reading the labels, the decode of every frame, the
imports of the fitting machinery, each step's fit (and transform), the training
output and scores, the model write (with what its writer imports).  The phases' sum
is the work a two-core machine shares out; the decode and the imports run in
reader threads beside each other in the command, the fit in one thread.

With ``--threads``, it runs instead, ``--repeats`` times in fresh processes
(interleaved with the baseline's when given), the whole command (``--jobs`` as
the command's default) with a watcher thread that reads every thread's CPU time
from ``/proc`` every 20 ms, and prints the median CPU seconds of the main
thread (start-up, imports, the fit, the model write), of the reader threads
(the decode) together, and the wall: how much of the wall is the main thread's
fit alone, which no reader thread shares.

    python benchmarks/bench_train_tunnel.py --frames 1500 --repeats 5
    python benchmarks/bench_train_tunnel.py --threads --repeats 3 --baseline /tmp/main-tree
    python benchmarks/bench_train_tunnel.py --phases --repeats 3 --baseline /tmp/main-tree
    python benchmarks/bench_train_tunnel.py --repeats 3 --baseline /tmp/main-tree
    python benchmarks/bench_train_tunnel.py --no-busy --sample-rate 10
"""

import argparse
import multiprocessing as mp
import os
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "docs" / "figures"))
from _common import load as machine_load  # noqa: E402
from _common import timed_process  # noqa: E402

_DECODE = (
    "import sys, glob, cv2, numpy as np\n"
    "for f in sorted(glob.glob(sys.argv[1] + '/img1/*.png')):\n"
    "    cv2.imdecode(np.fromfile(f, np.uint8), cv2.IMREAD_UNCHANGED)\n"
)


# one train tunnel, phase by phase in this thread: a JSON list of (phase, CPU seconds);
# the fit is the command's (fit_indicator_detector, on frames decoded beforehand), its
# steps told apart by its progress calls
_PHASES = """
import json, sys, time
marks, t0 = [], time.process_time()
def mark(name):
    global t0
    t = time.process_time()
    marks.append((name, t - t0))
    t0 = t
from tunnelsense.io import read_tour
from tunnelsense.io._sources import decode_tours
mark("start-up imports")
tours = [read_tour(sys.argv[1])]
mark("read labels")
frames, y, groups, n = decode_tours(tours, n_threads=0)
X = list(frames)
mark("decode")
from tunnelsense.tunnel import fit_indicator_detector
mark("import fitting")
step = []
def progress(stage, done, total):
    if stage.startswith("fitting ") and stage != "fitting fitted":
        if step:
            mark("fit " + step[-1])
        step.append(stage[len("fitting "):])
model, summary = fit_indicator_detector(tours, n_jobs=0, progress=progress,
                                        _decoding=(iter(X), y, groups, n))
mark("fit " + step[-1] + ", training scores")
from tunnelsense.io._model import save_model
save_model(model, sys.argv[2], summary=summary, overwrite=True)
mark("write model")
print(json.dumps(marks))
"""


# the whole command in this process, a watcher reading each thread's CPU seconds
# (utime + stime in /proc/self/task) every 20 ms: a JSON dict of
# {"main": s, "readers": s, "other": s, "wall": s}
_THREADS = """
import json, os, sys, threading, time
tick = os.sysconf("SC_CLK_TCK")
seen, done = {}, threading.Event()
def cpu_of(tid):
    with open(f"/proc/self/task/{tid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / tick
def watch():
    me = threading.get_native_id()
    while True:
        names = {t.native_id: t.name for t in threading.enumerate()}
        for tid in os.listdir("/proc/self/task"):
            tid = int(tid)
            if tid == me:
                continue
            try:
                seen[tid] = (names.get(tid, seen.get(tid, ("?",))[0]), cpu_of(tid))
            except OSError:
                pass
        if done.wait(0.02):
            return
watcher = threading.Thread(target=watch, daemon=True)
watcher.start()
wall = time.perf_counter()
sys.argv = ["tunnelsense", "train", "tunnel", sys.argv[1], "--model", sys.argv[2],
            "--force", "--quiet"]
from tunnelsense._cli import main
code = main()  # as the command runs it (its start-up imports in threads)
assert code == 0, code
wall = time.perf_counter() - wall
done.set()
watcher.join()
main_id = threading.main_thread().native_id
seen[main_id] = ("main", cpu_of(main_id))
out = {"main": 0.0, "readers": 0.0, "other": 0.0, "wall": wall}
for name, seconds in seen.values():
    key = "main" if name == "main" else "readers" if name.startswith("decode") else "other"
    out[key] += seconds
print(json.dumps(out))
"""


def _threads(tour, model, baseline, repeats):
    """Median CPU seconds of the command's main thread and reader threads, and its
    wall (:data:`_THREADS`), this tree beside ``baseline``'s, interleaved."""
    import json
    import subprocess

    trees = {"this tree": Path(__file__).resolve().parents[1]}
    if baseline is not None:
        trees["baseline"] = Path(baseline).resolve()
    got = {k: {} for k in trees}
    before = machine_load()
    for r in range(repeats):
        names = list(trees)
        for name in names[r % len(names):] + names[:r % len(names)]:
            env = {**os.environ, "PYTHONPATH": str(trees[name])}
            done = subprocess.run([sys.executable, "-P", "-c", _THREADS, str(tour),
                                   str(model)], env=env, check=True,
                                  capture_output=True, text=True)
            for key, seconds in json.loads(done.stdout.splitlines()[-1]).items():
                got[name].setdefault(key, []).append(seconds)
    print(f"train tunnel, whole command, CPU seconds by thread and wall, medians of "
          f"{repeats} ({before} before, {machine_load()} after):")
    print(f"  {'':34s}" + "".join(f"{k:>12s}" for k in trees))
    for key, label in (("main", "main thread (imports, fit, write)"),
                       ("readers", "reader threads (decode)"),
                       ("other", "other threads"), ("wall", "wall")):
        print(f"  {label:34s}" + "".join(
            f"{statistics.median(got[k][key]):12.2f}" for k in trees))
    return 0


def _busy():
    while True:
        pass


def _runs(tour, model, baseline, sample_rate=None):
    # -P: the working directory is not put first on the path, so each run imports
    # the tree its PYTHONPATH names (this one, or --baseline) wherever the script
    # is started from (from the repository's root, the baseline ran this tree)
    cli = [sys.executable, "-P", "-m", "tunnelsense._cli", "train", "tunnel", str(tour),
           "--model", str(model), "--force", "--quiet"]
    here = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    runs = {"decode": ([sys.executable, "-c", _DECODE, str(tour)], None),
            "train": (cli, here), "train --jobs 1": ([*cli, "--jobs", "1"], here)}
    if sample_rate is not None:
        runs[f"train --sample-rate {sample_rate:g}"] = (
            [*cli, "--sample-rate", str(sample_rate)], here)
    if baseline is not None:
        env = {**os.environ, "PYTHONPATH": str(Path(baseline).resolve())}
        runs["baseline train"] = (cli, env)
        runs["baseline train --jobs 1"] = ([*cli, "--jobs", "1"], env)
    return runs


def _round(runs, repeats):
    """Medians of wall and CPU seconds, the commands interleaved and their order
    rotated from one repeat to the next."""
    names = list(runs)
    wall = {k: [] for k in names}
    cpu = {k: [] for k in names}
    for r in range(repeats):
        for name in names[r % len(names):] + names[:r % len(names)]:
            cmd, env = runs[name]
            wall[name].append(timed_process(cmd, cpu[name], env=env))
    return ({k: statistics.median(v) for k, v in wall.items()},
            {k: statistics.median(v) for k, v in cpu.items()})


def _phases(tour, model, baseline, repeats):
    """Median CPU seconds of each phase (:data:`_PHASES`), this tree beside
    ``baseline``'s, interleaved; prints them with the load average."""
    import json
    import subprocess

    trees = {"this tree": Path(__file__).resolve().parents[1]}
    if baseline is not None:
        trees["baseline"] = Path(baseline).resolve()
    cpu = {k: {} for k in trees}
    before = machine_load()
    for r in range(repeats):
        names = list(trees)
        for name in names[r % len(names):] + names[:r % len(names)]:
            env = {**os.environ, "PYTHONPATH": str(trees[name])}
            done = subprocess.run([sys.executable, "-P", "-c", _PHASES, str(tour),
                                   str(model)], env=env, check=True,
                                  capture_output=True, text=True)
            for phase, seconds in json.loads(done.stdout.splitlines()[-1]):
                cpu[name].setdefault(phase, []).append(seconds)
    print(f"train tunnel phase by phase, one thread, CPU seconds, medians of {repeats} "
          f"({before} before, {machine_load()} after):")
    print(f"  {'phase':34s}" + "".join(f"{k:>12s}" for k in trees))
    for phase in cpu["this tree"]:
        print(f"  {phase:34s}" + "".join(
            f"{statistics.median(cpu[k].get(phase, [float('nan')])):12.2f}"
            for k in trees))
    print(f"  {'sum':34s}" + "".join(
        f"{sum(statistics.median(v) for v in cpu[k].values()):12.2f}" for k in trees))
    return 0


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--frames", type=int, default=1500)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--budget", type=float, default=5.0)
    p.add_argument("--workdir", type=Path, default=None)
    p.add_argument("--baseline", type=Path, default=None, metavar="SRC",
                   help="also run train from this source tree (PYTHONPATH=SRC)")
    p.add_argument("--no-busy", action="store_true", help="skip the round beside "
                   "two busy processes")
    p.add_argument("--sample-rate", type=float, default=None, metavar="HZ",
                   help="also run train --sample-rate HZ (this tree)")
    p.add_argument("--phases", action="store_true", help="CPU seconds of each phase "
                   "of the work, in one thread (with --baseline, of both trees)")
    p.add_argument("--threads", action="store_true", help="CPU seconds of the whole "
                   "command's main thread and reader threads, and its wall (with "
                   "--baseline, of both trees)")
    args = p.parse_args(argv)
    work = args.workdir or Path(tempfile.mkdtemp(prefix="bench-train-"))
    tour = work / f"light-{args.frames}"
    if not (tour / "seqinfo.ini").is_file():
        from tunnelsense.datasets import make_tunnel_tour
        from tunnelsense.io import write_tour

        write_tour(make_tunnel_tour(args.frames, scenario="light", random_state=0), tour)
    if args.phases:
        return _phases(tour, work / "m.skops", args.baseline, args.repeats)
    if args.threads:
        return _threads(tour, work / "m.skops", args.baseline, args.repeats)
    runs = _runs(tour, work / "m.skops", args.baseline, args.sample_rate)
    rounds = []
    label = "as it is"
    load = machine_load()
    rounds.append((label, load, *_round(runs, args.repeats), machine_load()))
    if not args.no_busy:
        busy = [mp.Process(target=_busy, daemon=True) for _ in range(2)]
        for b in busy:
            b.start()
        try:
            load = machine_load()
            rounds.append(("2 busy processes", load, *_round(runs, args.repeats),
                           machine_load()))
        finally:
            for b in busy:
                b.terminate()
    print(f"train tunnel, one {args.frames}-frame light-traffic tour, whole processes, "
          f"medians of {args.repeats} (interleaved):")
    for label, before, wall, cpu, after in rounds:
        print(f"  {label} ({before} before, {after} after):")
        decode = wall["decode"]
        for name in wall:
            extra = "" if name == "decode" else f"  ({wall[name] / decode:.2f}x decode)"
            print(f"    {name:24s} {wall[name]:6.2f} s  cpu {cpu[name]:6.2f} s{extra}")
        ratio = wall["train"] / wall["train --jobs 1"]
        print(f"    default / --jobs 1: {ratio:.2f}")
        if "baseline train" in wall:
            print(f"    train / baseline train: {wall['train'] / wall['baseline train']:.2f}")
    if len(rounds) > 1:
        print(f"  under load, default / --jobs 1: "
              f"{rounds[1][2]['train'] / rounds[1][2]['train --jobs 1']:.2f} "
              "(goal <= 1.0 within noise)")
    first = rounds[0][2]["train"]
    if first > args.budget:
        print(f"over budget: {first:.2f} s > {args.budget} s")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
