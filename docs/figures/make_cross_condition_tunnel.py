"""Cross-condition matrix of the FIR indicator detector, drawn as two heat maps.

The detector is fitted on ONE simulated tour of a condition (row) and evaluated on two
tours of every condition (column).  A cell's colour is the share of the indicators
(taller than 14 px) found; its text is ``found/indicators`` and the number of
false-alarm trajectories, as ``tunnelsense evaluate tunnel`` counts them
(:func:`tunnelsense.metrics.indicator_scores`).  Left: the paper's method
(``make_indicator_pipeline(preset="paper")``); right: the default detector
(``make_indicator_pipeline()``).

Run from a source checkout or an unpacked sdist, with the ``plot`` extra installed::

    python docs/figures/make_cross_condition_tunnel.py [--frames 600] [--out PNG]

It writes ``docs/_static/cross_condition_tunnel.png`` and prints the matrix as a
Markdown table.  With 600 frames a tour (18 tours) it takes about 10-15 minutes on a
2-core machine; ``--frames 300`` halves it (fewer indicators per tour).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import machine, output_path, save_figure  # noqa: E402

# the conditions, their tours and the seeds are the table script's, beside this one
from cross_condition_tunnel_table import (  # noqa: E402
    CONDITIONS as ALL_CONDITIONS,
)
from cross_condition_tunnel_table import (
    EVAL_TEST_SEEDS as TEST_SEEDS,
)
from cross_condition_tunnel_table import (
    EVAL_TRAIN_SEED as TRAIN_SEED,
)
from cross_condition_tunnel_table import (
    tour,
)

from tunnelsense import to_xy  # noqa: E402
from tunnelsense.metrics import indicator_scores  # noqa: E402
from tunnelsense.tunnel import make_indicator_pipeline  # noqa: E402

#: The conditions of the heat map (the table adds another unit's gain and offset,
#: automatic gain control, warm air and a 320 x 240 sensor).
CONDITIONS = {name: ALL_CONDITIONS[name] for name in (
    "plain", "heavy", "other-camera", "curve-right", "curve-left", "other-curve-fast")}
#: Method name -> arguments of :func:`~tunnelsense.tunnel.make_indicator_pipeline`.
METHODS = {"the paper's method": dict(preset="paper"), "default": {}}


def matrix(n_frames, log=print):
    """``{method: array (rows, cols, 3)}`` of found, indicators, false alarms."""
    tests = {c: [to_xy([tour(c, s, n_frames)])[:2] for s in TEST_SEEDS]
             for c in CONDITIONS}
    log(f"simulated the test tours ({time.perf_counter() - START:.0f} s)")
    n = len(CONDITIONS)
    out = {m: np.zeros((n, n, 3), int) for m in METHODS}
    for i, a in enumerate(CONDITIONS):
        X, y, _ = to_xy([tour(a, TRAIN_SEED, n_frames)])
        for method, params in METHODS.items():
            model = make_indicator_pipeline(random_state=0, **params).fit(X, y)
            for j, b in enumerate(CONDITIONS):
                for Xt, yt in tests[b]:
                    s = indicator_scores(model.predict(Xt), yt)["trajectory"]
                    out[method][i, j] += (s["detected"], s["indicators"],
                                          s["false_alarms"])
        log(f"fitted on {a} ({time.perf_counter() - START:.0f} s)")
    return out


def draw(result, path, note):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(CONDITIONS)
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.6), layout="constrained")
    for ax, (method, m) in zip(axes, result.items(), strict=True):
        share = m[..., 0] / np.maximum(m[..., 1], 1)
        im = ax.imshow(share, vmin=0, vmax=1, cmap="viridis")
        for i in range(len(names)):
            for j in range(len(names)):
                found, total, fa = m[i, j]
                colour = "black" if share[i, j] > 0.6 else "white"
                ax.text(j, i, f"{found}/{total}\n{fa} FA", ha="center", va="center",
                        fontsize=9, color=colour)
        ax.set_xticks(range(len(names)), names, rotation=35, ha="right")
        ax.set_yticks(range(len(names)), names)
        ax.set_xlabel("evaluated on")
        ax.set_ylabel("fitted on")
        ax.set_title(method)
    fig.colorbar(im, ax=axes, shrink=0.8, label="share of indicators found")
    fig.suptitle("FIR indicator detector: fitted on one condition, evaluated on "
                 "every condition\n(cell: indicators found / indicators, "
                 "false-alarm trajectories (FA))", fontsize=11)
    save_figure(fig, path, note)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=600, help="frames per tour")
    parser.add_argument("--out", default=None, help="PNG to write "
                        "(default: docs/_static/cross_condition_tunnel.png)")
    args = parser.parse_args(argv)
    path = output_path("cross_condition_tunnel.png", args.out)
    result = matrix(args.frames, log=lambda s: print(s, file=sys.stderr, flush=True))
    note = (f"python docs/figures/make_cross_condition_tunnel.py --frames {args.frames}"
            f" | {machine()}")
    draw(result, path, note)
    print("cell: indicators found / indicators, false-alarm trajectories "
          "(paper's method | default)\n")
    print("| fitted on \\ evaluated on | " + " | ".join(CONDITIONS) + " |")
    print("|---" * (len(CONDITIONS) + 1) + "|")
    for i, a in enumerate(CONDITIONS):
        cells = [" \\| ".join("{}/{}, {}".format(*result[m][i, j]) for m in METHODS)
                 for j in range(len(CONDITIONS))]
        print(f"| {a} | " + " | ".join(cells) + " |")
    print(f"\nwrote {path} ({time.perf_counter() - START:.0f} s; {note})")


START = time.perf_counter()

if __name__ == "__main__":
    main()
