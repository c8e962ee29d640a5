"""Whole-process ``tunnelsense detect tunnel`` on PNG tours from disk, beside a bare decode.

The run that decides how much of the per-frame work the reader threads should do by
default (about 40 s a repeat on two idle cores, so about 5 minutes; tours missing
from --workdir are simulated there first, about a minute, and kept for another run)::

    python benchmarks/bench_detect_end_to_end.py --frames 600 --repeats 7 --tours light,heavy,curved-8bit --no-train --workdir /tmp/bench-e2e-600

What a user runs is the command, from files on disk; its floor is the cost of reading
those files.  For each tour this script runs, interleaved, ``--repeats`` times:

* ``decode``: a fresh Python process that decodes every PNG of the tour with OpenCV
  (``cv2.imdecode(np.fromfile(...), IMREAD_UNCHANGED)``, as the tour reader does) and
  nothing else;
* ``readers=decode``: ``tunnelsense detect tunnel --model M TOUR --out R --force
  --quiet --readers decode`` in a fresh process (imports, model load, reading,
  detection, writing): the reader threads decode, the command's thread runs every
  stage;
* ``readers=keypoints``: the same with ``--readers keypoints`` (the command's
  default): the reader threads also find each frame's keypoints (the first stage);
* ``readers=stages``: the same with ``--readers stages``: the reader threads also run
  the stages that look at one frame alone, the command's thread links the tracks;

the detect modes of ``--modes`` (default ``decode,keypoints,stages``) in an order rotated from
one repeat to the next (and their results checked byte for byte).  It prints, per
mode, the median wall time, frames/s and the ratio to the decode, and for each mode
after the first its ratio to the first mode: of the medians, and the median of the
per-repeat (paired) ratios with their range; beside them the CPU seconds (user +
system) of each process: on a shared machine the wall times move with the load
(printed before and after each tour), the CPU seconds much less.

The tours (640x480, ``--frames`` frames, simulated once into ``--workdir``; pick
them with ``--tours``):

* ``light``: light traffic (the training tour's conditions, another seed);
* ``heavy``: heavy traffic with trucks;
* ``curved-8bit``: the simulator's noisiest built-in scenario (``curved``: another
  camera, sensor noise sigma 4, a curving tunnel), 8-bit PNGs;
* ``curved-16bit``: the same frames as 16-bit PNGs (``x 257``);
* ``dense``: heavy traffic seen with a camera gain of ``--dense-gain`` (1.04) (the
  default detector's radiometry adjusts for the gain: it finds about as many
  keypoints there as in ``heavy``);

with the mean number of keypoints a frame the model's first stage finds (its
``transform`` on 100 frames spread over the tour) printed for each.  The models are trained on one light-traffic tour of ``--frames`` frames; the
16-bit tour is detected with a model trained on the 16-bit version of it (a model
refuses frames of another bit depth).  Unless ``--no-train``, the training time is
measured too: ``tunnelsense train tunnel`` on that tour, whole process, median of
``--repeats``, per 1,000 frames.

    python benchmarks/bench_detect_end_to_end.py --frames 1500 --repeats 3
"""

import argparse
import os
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "docs" / "figures"))
from _common import load, timed_process  # noqa: E402

_DECODE = (
    "import sys, glob, cv2, numpy as np\n"
    "files = sorted(glob.glob(sys.argv[1] + '/img1/*.png'))\n"
    "for f in files:\n"
    "    cv2.imdecode(np.fromfile(f, np.uint8), cv2.IMREAD_UNCHANGED)\n"
)

#: tour name -> (scenario, seed); ``curved-16bit`` and ``dense`` are derived below
_SIMULATED = {"light": ("light", 103), "heavy": ("heavy", 104),
              "curved-8bit": ("curved", 101), "dense": ("heavy", 102)}
TOURS = ("light", "heavy", "curved-8bit", "curved-16bit", "dense")
MODES = ("decode", "keypoints", "stages")


def _cli(*argv):
    return [sys.executable, "-m", "tunnelsense._cli", *argv]


def _wide(tour, name):
    """The same frames as 16-bit PNGs."""
    from tunnelsense import FrameRecord, FrameSequence, Tour

    return Tour(
        name,
        FrameSequence([FrameRecord(name, r.frame, r.image.astype(np.uint16) * 257)
                       for r in tour.frames]),
        tour.gt, frame_rate=tour.frame_rate, info=tour.info,
    )


def _write_tours(workdir: Path, names, frames: int, gain: float):
    """The training tours and the tours ``names``, simulated into ``workdir`` once."""
    from tunnelsense import FrameRecord, FrameSequence, Tour
    from tunnelsense.datasets import make_tunnel_tour
    from tunnelsense.io import write_tour

    train = {"8bit": workdir / "train-light", "16bit": workdir / "train-light-16bit"}
    needed = ["8bit", *(["16bit"] if any(n.endswith("16bit") for n in names) else [])]
    if not all(train[bits].exists() for bits in needed):
        light = make_tunnel_tour(frames, scenario="light", random_state=100)
        if not train["8bit"].exists():
            write_tour(light, train["8bit"])
        if "16bit" in needed and not train["16bit"].exists():
            write_tour(_wide(light, "train-light-16bit"), train["16bit"])
    tours = {}
    for name in names:
        path = tours[name] = workdir / name
        if path.exists():
            continue
        if name == "curved-16bit":
            scenario, seed = _SIMULATED["curved-8bit"]
            tour = _wide(make_tunnel_tour(frames, scenario=scenario, random_state=seed),
                         name)
        elif name == "dense":
            scenario, seed = _SIMULATED[name]
            heavy = make_tunnel_tour(frames, scenario=scenario, random_state=seed)
            tour = Tour(name, FrameSequence([
                FrameRecord(name, r.frame, np.clip(r.image * gain, 0, 255).astype(np.uint8))
                for r in heavy.frames]), heavy.gt, frame_rate=heavy.frame_rate,
                info=heavy.info)
        else:
            scenario, seed = _SIMULATED[name]
            tour = make_tunnel_tour(frames, scenario=scenario, random_state=seed)
        write_tour(tour, path)
    return train, tours


def _in_band_keypoints(model_path, tour_path, n=100):
    """Mean keypoints a frame the model's sampler finds, over ``n`` spread frames."""
    from tunnelsense.io import load_model, open_tour

    kp = load_model(model_path).named_steps["keypoints"]
    tour = open_tour(tour_path)
    step = max(1, len(tour) // n)
    return float(np.mean([len(r.payload["keypoints"])
                          for r in kp.transform(tour.frames[::step])]))


def _tour_names(text):
    names = [n.strip() for n in text.split(",") if n.strip()]
    bad = [n for n in names if n not in TOURS]
    if not names or bad:
        raise argparse.ArgumentTypeError(
            f"expected a comma-separated list of {', '.join(TOURS)}; got {text!r}")
    return names


def _mode_names(text):
    names = [t for t in text.split(",") if t]
    bad = [t for t in names if t not in MODES]
    if bad or not names or len(set(names)) != len(names):
        raise argparse.ArgumentTypeError(
            f"expected distinct modes of {', '.join(MODES)}; got {text!r}")
    return names


def _ratios(num, den):
    return [a / b for a, b in zip(num, den, strict=True)]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=1500, help="frames a tour")
    parser.add_argument("--repeats", type=int, default=3,
                        help="interleaved runs of each process a tour")
    parser.add_argument("--tours", type=_tour_names,
                        default=["curved-8bit", "curved-16bit", "dense"],
                        help=f"comma-separated, of {', '.join(TOURS)} "
                        "(default: curved-8bit,curved-16bit,dense)")
    parser.add_argument("--jobs", type=int, default=None, help="--jobs of the detect "
                        "command (default: not given, the command's own default)")
    parser.add_argument("--no-train", action="store_true",
                        help="do not time the training (the model is trained once)")
    parser.add_argument("--modes", type=_mode_names, default=list(MODES),
                        help=f"comma-separated --readers modes, of {', '.join(MODES)}; "
                        "each is compared to the first (default: all)")
    parser.add_argument("--dense-gain", type=float, default=1.04)
    parser.add_argument("--workdir", default=None,
                        help="where to keep the simulated tours (default: a temp dir)")
    args = parser.parse_args(argv)
    if args.frames < 1 or args.repeats < 1:
        parser.error("--frames and --repeats: expected whole numbers >= 1")
    workdir = Path(args.workdir or tempfile.mkdtemp(prefix="bench-e2e-"))
    workdir.mkdir(parents=True, exist_ok=True)
    stamp = workdir / "frames.txt"  # a kept workdir holds tours of one length
    if stamp.exists() and stamp.read_text().strip() != str(args.frames):
        parser.error(f"--workdir {workdir}: holds tours of {stamp.read_text().strip()} "
                     f"frames, not {args.frames}; give another folder")
    stamp.write_text(f"{args.frames}\n")
    print(f"tours in {workdir} ({args.frames} frames each); {load()}", flush=True)
    train, tours = _write_tours(workdir, args.tours, args.frames, args.dense_gain)
    bits_needed = {"16bit" if n.endswith("16bit") else "8bit" for n in tours}
    models = {bits: workdir / f"model-{bits}.skops" for bits in bits_needed}

    def train_model(bits):
        return timed_process(_cli("train", "tunnel", str(train[bits]), "--model",
                           str(models[bits]), "--force", "--quiet"))

    if not args.no_train:
        train_times = [train_model("8bit") for _ in range(args.repeats)]
        t = statistics.median(train_times)
        print(f"\ntrain tunnel, {args.frames} frames: median {t:.1f} s "
              f"({1000 * t / args.frames:.1f} s per 1,000 frames; runs "
              + ", ".join(f"{v:.1f}" for v in train_times) + ")")
    for bits in sorted(bits_needed):
        if not models[bits].exists() or (bits == "16bit" and not args.no_train):
            # (the 8-bit model was just written by the timed runs)
            train_model(bits)

    jobs = [] if args.jobs is None else ["--jobs", str(args.jobs)]
    print(f"\ndetect tunnel {' '.join(jobs) or '(default --jobs)'}, {args.repeats} "
          f"repeats, medians (wall s; CPU s = user + system); {os.cpu_count()} CPUs")
    modes = args.modes
    print("\n| tour | keypoints / frame | decode (s) | "
          + " | ".join(f"readers={m} (s), frames/s, / decode" for m in modes)
          + " | " + " | ".join(f"{m} / {modes[0]}: medians, paired median (range)"
                               for m in modes[1:])
          + " | CPU s: decode / " + " / ".join(modes) + " | load before -> after |")
    print("|" + "---|" * (5 + 2 * len(modes) - 1))
    for name, path in tours.items():
        model = models["16bit" if name.endswith("16bit") else "8bit"]
        before = os.getloadavg()[0]
        decode, decode_cpu = [], []
        wall = {m: [] for m in modes}
        cpu = {m: [] for m in modes}
        outs = {m: workdir / f"{name}.{m}.txt" for m in modes}
        for k in range(args.repeats):
            decode.append(timed_process([sys.executable, "-c", _DECODE, str(path)], decode_cpu))
            for mode in modes[k % len(modes):] + modes[:k % len(modes)]:
                wall[mode].append(timed_process(_cli(
                    "detect", "tunnel", "--model", str(model), str(path), "--out",
                    str(outs[mode]), "--force", "--quiet", "--readers", mode, *jobs),
                    cpu[mode]))
        for suffix in (".txt", ".clusters.csv"):
            first, *others = (outs[m].with_name(f"{name}.{m}{suffix}").read_bytes()
                              for m in modes)
            if any(other != first for other in others):
                raise RuntimeError(f"{name}: the --readers modes {', '.join(modes)} "
                                   f"wrote different {suffix} files")
        d = statistics.median(decode)
        med = {m: statistics.median(wall[m]) for m in modes}
        cells = [f"{med[m]:.2f}, {args.frames / med[m]:.0f}, {med[m] / d:.2f}"
                 for m in modes]
        for m in modes[1:]:
            paired = _ratios(wall[m], wall[modes[0]])
            cells.append(f"{med[m] / med[modes[0]]:.2f}, {statistics.median(paired):.2f} "
                         f"({min(paired):.2f}-{max(paired):.2f})")
        cpus = " / ".join(f"{statistics.median(cpu[m]):.2f}" for m in modes)
        density = _in_band_keypoints(model, path)
        print(f"| {name} | {density:.0f} | {d:.2f} | " + " | ".join(cells)
              + f" | {statistics.median(decode_cpu):.2f} / {cpus} | "
              f"{before:.1f} -> {os.getloadavg()[0]:.1f} |", flush=True)
    print(f"\n{load()} after")


if __name__ == "__main__":
    main()
