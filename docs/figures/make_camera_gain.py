"""The FIR indicator detector on cameras of another gain, drawn as a heat map.

Another camera, or another gain setting, maps the same scene to other grey levels.
Every frame of a training tour (heavy traffic) and of two test tours (light and heavy
traffic) is mapped by ``gain * I + offset`` (clipped to 8 bits); the detector is
fitted on the mapped training tour and evaluated on the mapped test tours.  Rows: the
paper's method (``make_indicator_pipeline(preset="paper")``, keypoints in the fixed
intensity band [160, 190]), the detector with the grey-level band
(``keypoints__radiometry="raw"``, the earlier default) fixed at [160, 190]
(``keypoints__band="fixed"``) and learned from the training tour, and the default
detector (``make_indicator_pipeline()``: keypoints on local contrast).  A cell gives the indicators found out
of those at least 14 px tall, and the false-alarm trajectories (FA).

Run from a source checkout or an unpacked sdist, with the ``plot`` extra installed::

    python docs/figures/make_camera_gain.py [--frames 600] [--out PNG]

It writes ``docs/_static/camera_gain.png`` and prints the cells as a Markdown table
(about 3 minutes on a 2-core machine).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import load, machine, output_path, save_figure  # noqa: E402
from cross_condition_tunnel_table import GREY  # noqa: E402

from tunnelsense import FrameRecord, FrameSequence, Tour, to_xy  # noqa: E402
from tunnelsense.datasets import make_tunnel_tour  # noqa: E402
from tunnelsense.metrics import indicator_scores  # noqa: E402
from tunnelsense.tunnel import make_indicator_pipeline  # noqa: E402

#: (gain, offset) of each camera; (1, 0) is the simulator's, which renders the signs
#: at about 175.
CAMERAS = [(0.8, 0.0), (1.0, 0.0), (1.2, 5.0)]
#: Method name -> arguments of :func:`~tunnelsense.tunnel.make_indicator_pipeline`.
METHODS = {
    "the paper's method": dict(preset="paper"),
    "grey-level band, fixed": dict(GREY, keypoints__band="fixed"),
    "grey-level band, learned": dict(GREY),
    "default (local contrast)": {},
}
TRAIN = ("heavy", 4001)
TESTS = (("light", 5001), ("heavy", 5002))


def mapped(tour, gain, offset):
    """``tour`` as a camera of ``gain`` and ``offset`` would have recorded it."""
    frames = FrameSequence([
        FrameRecord(tour.name, r.frame,
                    np.clip(gain * r.image.astype(np.float64) + offset, 0, 255)
                    .astype(np.uint8))
        for r in tour.frames
    ])
    return Tour(tour.name, frames, tour.gt, frame_rate=tour.frame_rate, info=tour.info)


def cells(n_frames, log):
    """``{method: [(found, indicators, false alarms) or None per camera]}``."""
    common = dict(indicator_spacing_m=100.0)
    train = make_tunnel_tour(n_frames, scenario=TRAIN[0], random_state=TRAIN[1],
                             **common)
    tests = [make_tunnel_tour(n_frames, scenario=s, random_state=seed, **common)
             for s, seed in TESTS]
    log(f"simulated the tours ({time.perf_counter() - START:.0f} s)")
    out = {m: [] for m in METHODS}
    for gain, offset in CAMERAS:
        X, y, _ = to_xy([mapped(train, gain, offset)])
        test_xy = [to_xy([mapped(t, gain, offset)])[:2] for t in tests]
        for method, params in METHODS.items():
            try:
                model = make_indicator_pipeline(random_state=0, **params).fit(X, y)
            except ValueError as exc:  # e.g. no keypoint on any indicator
                log(f"gain {gain}, {method}: fit refused: {exc}")
                out[method].append(None)
                continue
            total = np.zeros(3, int)
            for Xt, yt in test_xy:
                s = indicator_scores(model.predict(Xt), yt)["trajectory"]
                total += (s["detected"], s["indicators"], s["false_alarms"])
            out[method].append(tuple(int(v) for v in total))
        log(f"gain {gain}, offset {offset} ({time.perf_counter() - START:.0f} s)")
    return out


def draw(result, path, note):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    methods = list(result)
    share = np.array([[np.nan if c is None else c[0] / max(c[1], 1) for c in result[m]]
                      for m in methods])
    fig, ax = plt.subplots(figsize=(9, 4.6), layout="constrained")
    cmap = plt.get_cmap("viridis").copy()
    cmap.set_bad("0.85")
    im = ax.imshow(np.ma.masked_invalid(share), vmin=0, vmax=1, cmap=cmap, aspect="auto")
    for i, m in enumerate(methods):
        for j, c in enumerate(result[m]):
            if c is None:
                text, colour = "fit refused:\nno keypoint on\nany indicator", "black"
            else:
                text = f"{c[0]}/{c[1]}\n{c[2]} FA"
                colour = "black" if share[i, j] > 0.6 else "white"
            ax.text(j, i, text, ha="center", va="center", fontsize=9, color=colour)
    ax.set_xticks(range(len(CAMERAS)),
                  [f"gain {g:g}, offset {o:+g}" + ("\n(the simulator's)" if g == 1 else "")
                   for g, o in CAMERAS])
    ax.set_yticks(range(len(methods)), methods)
    ax.set_xlabel("camera of the training and test tours")
    fig.colorbar(im, ax=ax, label="share of indicators found")
    ax.set_title("FIR indicator detector on cameras of another gain\n(cell: indicators "
                 "found / indicators, false-alarm trajectories (FA))", fontsize=10)
    save_figure(fig, path, note)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=600, help="frames per tour")
    parser.add_argument("--out", default=None,
                        help="PNG to write (default: docs/_static/camera_gain.png)")
    args = parser.parse_args(argv)
    path = output_path("camera_gain.png", args.out)
    result = cells(args.frames, log=lambda s: print(s, file=sys.stderr, flush=True))
    note = (f"python docs/figures/make_camera_gain.py --frames {args.frames} | "
            f"{machine()} | {load()}")
    draw(result, path, note)
    print("| method | " + " | ".join(f"gain {g:g}, offset {o:+g}" for g, o in CAMERAS)
          + " |")
    print("|---" * (len(CAMERAS) + 1) + "|")
    for m, row in result.items():
        print(f"| {m} | " + " | ".join("fit refused" if c is None else
                                       "{}/{}, {}".format(*c) for c in row) + " |")
    print(f"\nwrote {path} ({time.perf_counter() - START:.0f} s; {note})")


START = time.perf_counter()

if __name__ == "__main__":
    main()
