"""Whole-process ``tunnelsense detect tunnel`` on PNG tours from disk, beside a bare decode.

What a user runs is the command, from files on disk; its floor is the cost of reading
those files.  For each tour this script runs, interleaved, ``--repeats`` times:

* ``decode``: a fresh Python process that decodes every PNG of the tour with OpenCV
  (``cv2.imdecode(np.fromfile(...), IMREAD_UNCHANGED)``, as the tour reader does) and
  nothing else;
* ``detect``: ``tunnelsense detect tunnel --model M TOUR --out R --force --quiet`` in a
  fresh process (imports, model load, reading, detection, writing);

and prints the medians, frames/s and the ratio detect / decode, and beside them the
CPU seconds (user + system) of each process and their ratio: on a shared machine the
wall times move with the load (printed before and after), the CPU seconds much less.  The tours (640x480,
``--frames`` frames, simulated once into ``--workdir``):

* ``curved-8bit``: the simulator's noisiest built-in scenario (``curved``: another
  camera, sensor noise sigma 4, a curving tunnel), 8-bit PNGs;
* ``curved-16bit``: the same frames as 16-bit PNGs (``x 257``);
* ``dense``: heavy traffic seen with a camera gain of ``--dense-gain`` (1.04), so that
  more grid keypoints fall in the learned band (the script prints how many).

Training time: ``tunnelsense train tunnel`` on one ``--frames`` light-traffic tour, whole
process, median of ``--repeats``, per 1,000 frames.  The 16-bit tour is detected with
a model trained on the 16-bit version of the training tour (a model refuses frames of
another bit depth).

    python benchmarks/bench_detect_end_to_end.py --frames 1500 --repeats 3
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

import numpy as np

_DECODE = (
    "import sys, glob, cv2, numpy as np\n"
    "files = sorted(glob.glob(sys.argv[1] + '/img1/*.png'))\n"
    "for f in files:\n"
    "    cv2.imdecode(np.fromfile(f, np.uint8), cv2.IMREAD_UNCHANGED)\n"
)


def _cli(*argv):
    return [sys.executable, "-m", "tunnelsense._cli", *argv]


def _timed(cmd, cpu=None):
    """Wall seconds of ``cmd``; its CPU seconds appended to ``cpu`` when given."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if cpu is not None:
        cpu.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    return wall


def _load():
    return "load average " + ", ".join(f"{v:.1f}" for v in os.getloadavg())


def _write_tours(workdir: Path, frames: int, gain: float) -> dict:
    from tunnelsense import FrameRecord, FrameSequence, Tour
    from tunnelsense.datasets import make_tunnel_tour
    from tunnelsense.io import write_tour

    def wide(tour, name):  # the same frames as 16-bit PNGs
        return Tour(
            name,
            FrameSequence([FrameRecord(name, r.frame, r.image.astype(np.uint16) * 257)
                           for r in tour.frames]),
            tour.gt, frame_rate=tour.frame_rate, info=tour.info,
        )

    tours = {}
    train = {"8bit": workdir / "train-light", "16bit": workdir / "train-light-16bit"}
    if not all(p.exists() for p in train.values()):
        light = make_tunnel_tour(frames, scenario="light", random_state=100)
        write_tour(light, train["8bit"])
        write_tour(wide(light, "train-light-16bit"), train["16bit"])
    if not (workdir / "curved-16bit").exists():
        curved = make_tunnel_tour(frames, scenario="curved", random_state=101)
        write_tour(curved, workdir / "curved-8bit")
        write_tour(wide(curved, "curved-16bit"), workdir / "curved-16bit")
    tours["curved-8bit"] = workdir / "curved-8bit"
    tours["curved-16bit"] = workdir / "curved-16bit"
    path = workdir / "dense"
    if not path.exists():
        heavy = make_tunnel_tour(frames, scenario="heavy", random_state=102)
        frames_g = FrameSequence([
            FrameRecord("dense", r.frame,
                        np.clip(r.image * gain, 0, 255).astype(np.uint8))
            for r in heavy.frames
        ])
        write_tour(Tour("dense", frames_g, heavy.gt, frame_rate=heavy.frame_rate,
                        info=heavy.info), path)
    tours["dense"] = path
    return train, tours


def _in_band_keypoints(model_path, tour_path, n=100):
    from tunnelsense.io import load_model, open_tour
    from tunnelsense.tunnel import sample_keypoints

    kp = load_model(model_path).named_steps["keypoints"]
    tour = open_tour(tour_path)
    step = max(1, len(tour) // n)
    counts = [len(sample_keypoints(r.image, kp.low_, kp.high_))
              for r in tour.frames[::step]]
    return float(np.mean(counts))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=1500)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--dense-gain", type=float, default=1.04)
    parser.add_argument("--workdir", default=None,
                        help="where to keep the simulated tours (default: a temp dir)")
    args = parser.parse_args(argv)
    workdir = Path(args.workdir or tempfile.mkdtemp(prefix="bench-e2e-"))
    workdir.mkdir(parents=True, exist_ok=True)
    print(f"tours in {workdir} ({args.frames} frames each)", flush=True)
    train, tours = _write_tours(workdir, args.frames, args.dense_gain)
    models = {bits: workdir / f"model-{bits}.skops" for bits in train}

    train_times = [
        _timed(_cli("train", "tunnel", str(train["8bit"]), "--model",
                    str(models["8bit"]), "--force", "--quiet"))
        for _ in range(args.repeats)
    ]
    _timed(_cli("train", "tunnel", str(train["16bit"]), "--model",
                str(models["16bit"]), "--force", "--quiet"))
    t = statistics.median(train_times)
    print(f"\ntrain tunnel, {args.frames} frames: median {t:.1f} s "
          f"({1000 * t / args.frames:.1f} s per 1,000 frames; runs "
          + ", ".join(f"{v:.1f}" for v in train_times) + ")")

    print(f"\n{_load()} before the detection runs")
    print("\n| tour | in-band keypoints / frame | decode (s) | detect (s) | "
          "detect frames/s | detect / decode | CPU s: decode | detect | ratio |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, path in tours.items():
        model = models["16bit" if name.endswith("16bit") else "8bit"]
        decode, detect, decode_cpu, detect_cpu = [], [], [], []
        out = workdir / f"{name}.txt"
        for _ in range(args.repeats):
            decode.append(_timed([sys.executable, "-c", _DECODE, str(path)], decode_cpu))
            detect.append(_timed(_cli("detect", "tunnel", "--model", str(model),
                                      str(path), "--out", str(out), "--force",
                                      "--quiet"), detect_cpu))
        d, e = statistics.median(decode), statistics.median(detect)
        dc, ec = statistics.median(decode_cpu), statistics.median(detect_cpu)
        density = _in_band_keypoints(model, path)
        print(f"| {name} | {density:.0f} | {d:.2f} | {e:.2f} | "
              f"{args.frames / e:.0f} | {e / d:.2f} | {dc:.2f} | {ec:.2f} | "
              f"{ec / dc:.2f} |", flush=True)
    print(f"\n{_load()} after")


if __name__ == "__main__":
    main()
