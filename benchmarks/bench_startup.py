"""Start-up and exit of the ``tunnelsense`` command, beside ``python -c pass``.

A vehicle runs one short command after another; what counts is a fresh process's wall
time.  Each repeat runs, interleaved, in fresh processes:

* ``python -c pass``: the interpreter alone;
* ``import numpy, cv2`` and ``import sklearn.base``: the floors of a detector (its
  estimators are scikit-learn estimators, and ``sklearn.base`` imports SciPy's stats
  and pandas itself); ``import sklearn.base, deferred`` and ``import sklearn.pipeline,
  deferred``: the same with what the detect commands defer deferred
  (``tunnelsense._deferred``: SciPy's stats and special functions, pandas,
  ``sklearn.preprocessing``, NumPy's f2py and test helpers...; the garbage collector
  run seldom), the floor of any command that loads a model (a Pipeline of
  scikit-learn estimators);
* ``tunnelsense --version``;
* ``tunnelsense detect tunnel`` on a 10-frame tour (imports, model load, detection,
  writing), twice: from a copy of the package whose bytecode is compiled (as ``pip
  install`` leaves an installed package) and from a copy without it, Python told not to
  write it (``PYTHONDONTWRITEBYTECODE``, as in an editable install on a machine that
  sets it: every run compiles the package's modules from source);
* ``tunnelsense detect street`` on a 200-scan run;

and prints each median, of the wall time and of the CPU time (user + system) of the
process, with the machine's load average before and after.  Exit: the same ``detect tunnel`` through a wrapper that prints
the wall clock when the command returns, the parent noting when the process ended; once
as the command runs (``main()``: no final garbage collection) and once with the
interpreter's usual final collection (``main(argv)``, as a call from Python).

Budget check (exit status 1 when broken): ``tunnelsense --version`` within 0.15 s of
``python -c pass``, and building the parser imports none of scikit-learn, pandas, SciPy,
NumPy, OpenCV.  The goal for ``detect`` on 10 frames (0.6 s) is printed, met or not, for the
compiled copy (what an installed package runs).

With ``--baseline SRC`` (a source tree, e.g. ``git archive`` of an older commit), the
compiled ``detect tunnel`` of that tree's package runs too, interleaved (``baseline
detect tunnel, 10 frames``), and the paired ratio is printed: a before/after on one
machine at one time.

    python benchmarks/bench_startup.py [--repeats 7] [--baseline SRC]
"""

import argparse
import compileall
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "docs" / "figures"))
from _common import load, timed_process  # noqa: E402

#: What the detect commands do before they import scikit-learn (the floors): defer
#: modules, collect garbage seldom while importing.
_DEFERRED = ("from tunnelsense._deferred import start_command, start_imports; "
             "start_command(); start_imports(); ")

_EXIT = """
import sys, time
from tunnelsense.cli import main
argv = sys.argv[2:]
if sys.argv[1] == "command":
    sys.argv = ["tunnelsense", *argv]
    status = main()
else:
    status = main(argv)
print(repr(time.time()), file=sys.stderr)
sys.exit(status)
"""

_HEAVY = """
import json, sys
import tunnelsense, tunnelsense.cli
tunnelsense.cli.build_parser()
heavy = {"sklearn", "pandas", "scipy", "numpy", "cv2", "skops", "matplotlib", "dask"}
print(json.dumps(sorted({m.partition(".")[0] for m in sys.modules} & heavy)))
"""


def _cli(*argv):
    return [sys.executable, "-m", "tunnelsense._cli", *argv]


def _exit_time(how, argv):
    done = subprocess.run([sys.executable, "-c", _EXIT, how, *argv], check=True,
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    ended = time.time()
    return ended - float(done.stderr.strip().splitlines()[-1])


def _package_copies(folder: Path, baseline=None) -> dict:
    """Two copies of the package: ``compiled`` (its bytecode written, as ``pip
    install`` does) and ``source`` (none), each a folder to put on ``PYTHONPATH``
    (ahead of an editable install's finder), with the environment to run it in; with
    ``baseline`` (a source tree), ``baseline``: its package, compiled."""
    import tunnelsense

    package = Path(tunnelsense.__file__).parent
    kinds = {"compiled": package, "source": package}
    if baseline is not None:
        kinds["baseline"] = Path(baseline) / "tunnelsense"
    envs = {}
    for kind, origin in kinds.items():
        shutil.copytree(origin, folder / kind / "tunnelsense",
                        ignore=shutil.ignore_patterns("__pycache__"))
        env = dict(os.environ, PYTHONPATH=str(folder / kind))
        if kind != "source":
            compileall.compile_dir(folder / kind / "tunnelsense", quiet=1)
        else:
            env["PYTHONDONTWRITEBYTECODE"] = "1"
        envs[kind] = env
    return envs


def _data(folder: Path) -> dict:
    from tunnelsense import make_indicator_pipeline, make_parking_pipeline, to_xy
    from tunnelsense.datasets import make_street_scans, make_tunnel_tour
    from tunnelsense.io import save_model, write_run, write_tour

    train = make_tunnel_tour(240, scenario="light", random_state=3, name="train")
    X, y, _ = to_xy([train])
    tunnel = save_model(make_indicator_pipeline(random_state=0).fit(X, y),
                        folder / "tunnel.skops")
    write_tour(make_tunnel_tour(10, scenario="light", random_state=4, name="t10"),
               folder / "t10")
    run = make_street_scans(1500, random_state=5, name="train-run")
    X, y, _ = to_xy([run])
    street = save_model(make_parking_pipeline().fit(X, y), folder / "street.skops")
    write_run(make_street_scans(200, random_state=6, name="s200"), folder / "s200")
    return {"tunnel": tunnel, "street": street, "t10": folder / "t10",
            "s200": folder / "s200", "out": folder / "out"}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--baseline", type=Path, default=None, metavar="SRC",
                        help="also run detect tunnel from this source tree's package")
    args = parser.parse_args()
    heavy = json.loads(subprocess.run([sys.executable, "-c", _HEAVY], check=True,
                                      capture_output=True, text=True).stdout)
    with tempfile.TemporaryDirectory() as tmp:
        d = _data(Path(tmp))
        d["out"].mkdir()
        envs = _package_copies(Path(tmp) / "package", args.baseline)
        detect = ["detect", "tunnel", "--model", str(d["tunnel"]), str(d["t10"]),
                  "--out", str(d["out"] / "r.txt"), "--force", "--quiet"]
        cases = {
            "python -c pass": [sys.executable, "-c", "pass"],
            "import numpy, cv2": [sys.executable, "-c", "import numpy, cv2"],
            "import sklearn.base": [sys.executable, "-c", "import sklearn.base"],
            "import sklearn.base, deferred": [sys.executable, "-c", _DEFERRED + (
                "import sklearn.base")],
            "import sklearn.pipeline, deferred": [sys.executable, "-c", _DEFERRED + (
                "import sklearn.pipeline")],
            "tunnelsense --version": _cli("--version"),
            "detect tunnel, 10 frames": (_cli(*detect), envs["compiled"]),
            "same, no bytecode": (_cli(*detect), envs["source"]),
            **({"baseline detect tunnel, 10 frames": (_cli(*detect), envs["baseline"])}
               if args.baseline else {}),
            "detect street, 200 scans": _cli(
                "detect", "street", str(d["s200"]), "--model", str(d["street"]),
                "--out", str(d["out"] / "o.csv"), "--force", "--quiet"),
        }
        times = {k: [] for k in cases}
        cpu = {k: [] for k in cases}
        print(load(), "before", flush=True)
        exits = {"command (no final collection)": [], "with final collection": []}
        for _ in range(args.repeats):
            for name, cmd in cases.items():
                cmd, env = cmd if isinstance(cmd, tuple) else (cmd, None)
                times[name].append(timed_process(cmd, cpu[name], env=env,
                                                 stderr=subprocess.DEVNULL))
            exits["command (no final collection)"].append(_exit_time("command", detect))
            exits["with final collection"].append(_exit_time("call", detect))
    med = {k: statistics.median(v) for k, v in times.items()}
    print(f"fresh processes, median of {args.repeats} (interleaved): wall s, CPU s "
          "(user + system)")
    for name, value in med.items():
        print(f"  {name:34s} {value:6.3f} {statistics.median(cpu[name]):6.3f}")
    print(load(), "after")
    print("process exit after detect tunnel returns (median):")
    for name, values in exits.items():
        print(f"  {name:32s} {statistics.median(values) * 1000:6.0f} ms")
    goal = med["detect tunnel, 10 frames"]
    print(f"detect tunnel on 10 frames, package compiled: {goal:.3f} s (goal <= 0.6 s: "
          f"{'met' if goal <= 0.6 else 'not met'}; its floor, import sklearn.pipeline "
          f"deferred, is {med['import sklearn.pipeline, deferred']:.3f} s)")
    if args.baseline:
        pairs = [a / b for a, b in zip(times["detect tunnel, 10 frames"],
                                       times["baseline detect tunnel, 10 frames"],
                                       strict=True)]
        print(f"detect tunnel / baseline, paired per repeat: median "
              f"{statistics.median(pairs):.3f} (range {min(pairs):.3f}-{max(pairs):.3f})")
    broken = []
    if med["tunnelsense --version"] > med["python -c pass"] + 0.15:
        broken.append("tunnelsense --version is more than 0.15 s over python -c pass")
    if heavy:
        broken.append(f"building the parser imports {', '.join(heavy)}")
    print("import-time budget: " + ("kept" if not broken else "BROKEN: "
                                    + "; ".join(broken)))
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
