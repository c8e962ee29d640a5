"""Speed of the FIR detector beside the PNG decode of the same frames, drawn as bars.

Two measures, each beside its peer in the same run, interleaved, medians of
``--repeats``:

* **the command**: ``tunnelsense detect tunnel --model M TOUR --out R`` in a fresh
  process (imports, model load, reading, detection, writing) beside a fresh Python
  process that only decodes the tour's PNG files with OpenCV, as the tour reader does;
* **the library**: ``model.predict`` on frames already in memory, per frame, beside
  ``cv2.imdecode`` of the same frames as PNG.

Three simulated 640 x 480 tours: light traffic, heavy traffic and the ``curved``
scenario (another camera, more sensor noise, a curving tunnel).  The model is
``tunnelsense train tunnel`` (the default detector) on one light-traffic tour; the
script also prints that command's time.

Run from a source checkout or an unpacked sdist, with the ``plot`` extra installed::

    python docs/figures/make_speed.py [--frames 600] [--repeats 3] [--out PNG]

It writes ``docs/_static/speed.png`` and prints the figures as a Markdown table
(about 5 minutes on a 2-core machine with the defaults).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import load, machine, output_path, save_figure  # noqa: E402

_DECODE = (
    "import sys, glob, cv2, numpy as np\n"
    "files = sorted(glob.glob(sys.argv[1] + '/img1/*.png'))\n"
    "for f in files:\n"
    "    cv2.imdecode(np.fromfile(f, np.uint8), cv2.IMREAD_UNCHANGED)\n"
)
#: Tour name -> (simulator scenario, seed).
TOURS = {"light traffic": ("light", 102), "heavy traffic": ("heavy", 103),
         "other camera, curve": ("curved", 104)}


def cli(*argv):
    return [sys.executable, "-m", "tunnelsense.cli", *argv]


def timed(cmd):
    start = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - start


def in_memory(model, tour, repeats):
    """Median ms a frame of ``predict`` and of a PNG decode, interleaved."""
    import cv2

    from tunnelsense import to_xy

    X, _, _ = to_xy([tour])
    pngs = [cv2.imencode(".png", r.image)[1] for r in tour.frames]
    pred, dec = [], []
    for _ in range(repeats):
        t = time.perf_counter()
        model.predict(X)
        pred.append(time.perf_counter() - t)
        t = time.perf_counter()
        for p in pngs:
            cv2.imdecode(p, cv2.IMREAD_UNCHANGED)
        dec.append(time.perf_counter() - t)
    n = len(pngs)
    return 1e3 * statistics.median(pred) / n, 1e3 * statistics.median(dec) / n


def measure(frames, repeats, workdir, log):
    from tunnelsense.datasets import make_tunnel_tour
    from tunnelsense.io import load_model, open_tour, write_tour
    from tunnelsense.tunnel import sample_keypoints

    train = workdir / "train"
    write_tour(make_tunnel_tour(frames, scenario="light", random_state=101), train)
    model_path = workdir / "model.skops"
    train_s = [timed(cli("train", "tunnel", str(train), "--model", str(model_path),
                         "--force", "--quiet")) for _ in range(repeats)]
    log(f"trained ({statistics.median(train_s):.1f} s a run)")
    model = load_model(model_path)
    kp = model.named_steps["keypoints"]
    rows = {}
    for name, (scenario, seed) in TOURS.items():
        tour = make_tunnel_tour(frames, scenario=scenario, random_state=seed)
        path = workdir / scenario
        write_tour(tour, path)
        decode, detect = [], []
        for _ in range(repeats):
            decode.append(timed([sys.executable, "-c", _DECODE, str(path)]))
            detect.append(timed(cli("detect", "tunnel", "--model", str(model_path),
                                    str(path), "--out", str(workdir / f"{scenario}.txt"),
                                    "--force", "--quiet")))
        predict_ms, decode_ms = in_memory(model, open_tour(path), repeats)
        keypoints = np.mean([len(sample_keypoints(r.image, kp.low_, kp.high_))
                             for r in tour.frames[::10]])
        rows[name] = dict(decode=statistics.median(decode),
                          detect=statistics.median(detect),
                          predict_ms=predict_ms, decode_ms=decode_ms,
                          keypoints=keypoints)
        log(f"{name}: {rows[name]}")
    return statistics.median(train_s), rows


def draw(rows, frames, path, note):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(rows)
    x = np.arange(len(names))
    w = 0.38
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.6), layout="constrained")
    per_k = 1000 / frames
    for ax, (peer, ours, scale, unit, title) in (
        (a, ("decode", "detect", per_k, "s per 1,000 frames",
             "the command: `tunnelsense detect tunnel`, whole process")),
        (b, ("decode_ms", "predict_ms", 1.0, "ms a frame",
             "the library: `model.predict` on frames in memory")),
    ):
        p = [rows[n][peer] * scale for n in names]
        o = [rows[n][ours] * scale for n in names]
        ax.bar(x - w / 2, p, w, label="PNG decode of the same frames", color="0.7")
        bars = ax.bar(x + w / 2, o, w, label="detector", color="tab:blue")
        for bar, po, oo in zip(bars, p, o, strict=True):
            ax.annotate(f"{oo / po:.2f}x decode", (bar.get_x() + w / 2, oo),
                        ha="center", va="bottom", fontsize=9)
        ax.set_xticks(x, [f"{n}\n({rows[n]['keypoints']:.0f} keypoints a frame)"
                          for n in names], fontsize=9)
        ax.set_ylabel(unit)
        ax.set_title(title, fontsize=10)
        ax.set_ylim(0, 1.25 * max(max(p), max(o)))
        ax.legend(loc="upper left", fontsize=8)
    fig.suptitle(f"FIR indicator detector beside the PNG decode, 640 x 480 frames, "
                 f"{frames}-frame tours (median of runs)", fontsize=11)
    save_figure(fig, path, note)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=600, help="frames per tour")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", default=None,
                        help="PNG to write (default: docs/_static/speed.png)")
    args = parser.parse_args(argv)
    path = output_path("speed.png", args.out)

    def log(s):
        print(s, file=sys.stderr, flush=True)

    before = load()
    with tempfile.TemporaryDirectory(prefix="tunnelsense-speed-") as tmp:
        train_s, rows = measure(args.frames, args.repeats, Path(tmp), log)
    note = (f"python docs/figures/make_speed.py --frames {args.frames} "
            f"--repeats {args.repeats} | {machine()} | {before} before, "
            f"{load()} after")
    draw(rows, args.frames, path, note)
    print(f"train tunnel, {args.frames} frames, whole process: median {train_s:.1f} s\n")
    print("| tour | keypoints a frame | decode (s) | detect (s) | detect / decode "
          "| predict (ms a frame) | decode (ms a frame) | predict / decode |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for n, r in rows.items():
        print(f"| {n} | {r['keypoints']:.0f} | {r['decode']:.2f} | {r['detect']:.2f} | "
              f"{r['detect'] / r['decode']:.2f} | {r['predict_ms']:.2f} | "
              f"{r['decode_ms']:.2f} | {r['predict_ms'] / r['decode_ms']:.2f} |")
    print(f"\nwrote {path} ({note})")


if __name__ == "__main__":
    main()
