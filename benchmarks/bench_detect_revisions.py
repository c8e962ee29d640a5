"""The detector's thread at two revisions of the package, paired: is a change faster?

A change to the per-frame path is a few per cent of the detector's time, less than a
shared machine's load moves it between runs.  This script extracts the package of
each revision (``git archive``) into a temporary folder, compiles its bytecode, and
runs, alternating from one repeat to the next, a fresh process per revision that
streams every tour's frames (decoded into memory first, not timed) through the
fitted ``--model`` one frame at a time (``StreamingPipeline``, as ``tunnelsense
detect tunnel`` does in its own thread; one BLAS and one OpenCV thread) and reports
its CPU time (``time.process_time``) and wall time a frame.  It prints, per tour,
the median of each revision, the median of the per-repeat (paired) ratios with
their range, for CPU and wall, the load before and after, and whether both
revisions gave the same detections and trajectory ids on every frame.

    python benchmarks/bench_detect_revisions.py BASE HEAD --model M.skops TOUR [TOUR ...] [--repeats 7]

The revisions are anything ``git rev-parse`` takes (``main``, ``HEAD~2``, a commit);
the model must load at both (the same model format).  The tours are MOTChallenge
folders (``tunnelsense simulate tunnel``; ``bench_detect_end_to_end.py --workdir``
keeps its tours and model).
"""

import argparse
import hashlib
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "docs" / "figures"))
from _common import load  # noqa: E402

_ONE_RUN = """
import os
for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[v] = "1"
import hashlib, json, sys, time
import cv2
import numpy as np
cv2.setNumThreads(1)
from tunnelsense import FrameRecord
from tunnelsense._streaming import StreamingPipeline
from tunnelsense.io import load_model, open_tour
from tunnelsense.tunnel._kmeans import blas_threads
model = load_model(sys.argv[1])
tour = open_tour(sys.argv[2], ground_truth=False)
frames = [FrameRecord(r.tour, r.frame, r.image, dict(r.payload)) for r in tour.frames]
stream = StreamingPipeline(model)
out = []
with blas_threads(1):
    cpu, wall = time.process_time(), time.perf_counter()
    for r in frames:
        out.extend(stream.push(r))
    out.extend(stream.close())
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
digest = hashlib.sha256()
for r in out:
    for key in ("detections", "track_ids"):
        digest.update(np.ascontiguousarray(r.payload.get(key, np.empty(0))).tobytes())
print(json.dumps({"frames": len(frames), "cpu": cpu, "wall": wall,
                  "results": digest.hexdigest()}))
"""


def _package(repo: Path, rev: str, into: Path) -> Path:
    """The package of ``rev``, extracted into ``into`` and compiled; the folder to put
    on ``PYTHONPATH``."""
    into.mkdir(parents=True)
    archive = subprocess.run(["git", "-C", str(repo), "archive", rev, "tunnelsense"],
                             check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    subprocess.run([sys.executable, "-m", "compileall", "-q", str(into)], check=True)
    return into


def _run(folder: Path, model: str, tour: str) -> dict:
    env = dict(os.environ, PYTHONPATH=str(folder))
    done = subprocess.run([sys.executable, "-c", _ONE_RUN, model, tour], check=True,
                          capture_output=True, text=True, env=env)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("base", help="the revision to compare against (e.g. main)")
    parser.add_argument("head", help="the revision compared (e.g. HEAD)")
    parser.add_argument("--model", required=True, help="a model of 'train tunnel'")
    parser.add_argument("tours", nargs="+", help="MOTChallenge tour folders")
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats: expected a whole number >= 1")
    repo = Path(__file__).resolve().parents[1]
    revs = {}
    for rev in (args.base, args.head):
        sha = subprocess.run(["git", "-C", str(repo), "rev-parse", "--short", rev],
                             check=True, capture_output=True, text=True).stdout.strip()
        revs[rev] = sha
    with tempfile.TemporaryDirectory() as tmp:
        folders = {rev: _package(repo, rev, Path(tmp) / hashlib.sha1(rev.encode())
                                 .hexdigest()) for rev in revs}
        names = (args.base, args.head)
        print(f"{args.base} ({revs[args.base]}) against {args.head} ({revs[args.head]}); "
              f"{args.repeats} repeats, alternating; ms a frame (CPU / wall); "
              "1 BLAS and 1 OpenCV thread")
        print(f"\n| tour | frames | {names[0]} | {names[1]} | {names[1]} / {names[0]}, CPU: "
              "median (range) | same, wall | same results | load before -> after |")
        print("|---|---|---|---|---|---|---|---|")
        for tour in args.tours:
            before = load()
            runs = {rev: [] for rev in names}
            for k in range(args.repeats):
                for rev in (names if k % 2 == 0 else names[::-1]):
                    runs[rev].append(_run(folders[rev], args.model, tour))
            n = runs[names[0]][0]["frames"]

            def ms(rev, key, n=n, runs=runs):
                return 1e3 * statistics.median(r[key] for r in runs[rev]) / n

            cells = [f"{ms(rev, 'cpu'):.2f} / {ms(rev, 'wall'):.2f}" for rev in names]
            ratios = {key: [b[key] / a[key] for a, b in zip(*runs.values(), strict=True)]
                      for key in ("cpu", "wall")}
            same = len({r["results"] for rs in runs.values() for r in rs}) == 1
            rc, rw = ratios["cpu"], ratios["wall"]
            print(f"| {Path(tour).name} | {n} | {cells[0]} | {cells[1]} | "
                  f"{statistics.median(rc):.3f} ({min(rc):.3f}-{max(rc):.3f}) | "
                  f"{statistics.median(rw):.3f} ({min(rw):.3f}-{max(rw):.3f}) | "
                  f"{'yes' if same else 'NO'} | {before} -> {load()} |", flush=True)


if __name__ == "__main__":
    main()
