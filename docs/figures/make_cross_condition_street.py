"""Cross-condition scores of the laser parked-vehicle detector, drawn as a heat map.

The detector is fitted on one simulated run of the plain street, as ``tunnelsense
train street`` does (:func:`tunnelsense.street.train_detector`), and scored on three
runs of every condition (columns): parked-vehicle recall (colour) and precision,
one-to-one matches of scan-interval IoU >= 0.5
(:func:`tunnelsense.metrics.street_scores`), summed over the runs.  Fitting on one
run validates the data and learns nothing else, so the fitting condition does not
change the model: one row per method.  Rows: the paper's method (the options of
:class:`~tunnelsense.street.ScanClusterer` that go beyond the paper switched off,
:data:`PAPER`) and the default detector.

Run from a source checkout or an unpacked sdist, with the ``plot`` extra installed::

    python docs/figures/make_cross_condition_street.py [--scans 3000] [--out PNG]

It writes ``docs/_static/cross_condition_street.png`` and prints the scores as a
Markdown table (under a minute on a 2-core machine).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import machine, output_path, save_figure  # noqa: E402

# the conditions, seeds and the paper's settings are the table script's, beside this one
from cross_condition_street_table import (  # noqa: E402
    CONDITIONS,
    FIT_SEED,
    PAPER,
)
from cross_condition_street_table import (
    EVALUATION_SEEDS as TEST_SEEDS,
)

from tunnelsense.datasets import make_street_scans  # noqa: E402
from tunnelsense.metrics import street_scores  # noqa: E402
from tunnelsense.street import train_detector  # noqa: E402

METHODS = {"the paper's method": PAPER, "default": {}}


def scores(n_scans):
    """``{method: array (conditions, 3)}`` of true positives, false positives, misses."""
    fit = make_street_scans(n_scans, scenario="sparse", random_state=FIT_SEED)
    pipeline = train_detector([fit])[0]
    defaults = {k: v for k, v in pipeline.get_params().items() if k.startswith("cluster__")}
    out = {m: np.zeros((len(CONDITIONS), 3), int) for m in METHODS}
    for j, (scenario, overrides) in enumerate(CONDITIONS.values()):
        for seed in TEST_SEEDS:
            run = make_street_scans(n_scans, scenario=scenario, random_state=seed,
                                    **overrides)
            for method, params in METHODS.items():
                pipeline.set_params(**defaults)
                pipeline.set_params(**{f"cluster__{k}": v for k, v in params.items()})
                s = street_scores(run.gt, pipeline[-1].detect(run.scans))["parked"]
                out[method][j] += (s["tp"], s["fp"], s["fn"])
    return out


def draw(result, path, note):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    methods, names = list(result), list(CONDITIONS)
    tp, fp, fn = (np.array([result[m][:, k] for m in methods]) for k in range(3))
    recall = tp / np.maximum(tp + fn, 1)
    precision = tp / np.maximum(tp + fp, 1)
    fig, ax = plt.subplots(figsize=(9, 3.4), layout="constrained")
    im = ax.imshow(recall, vmin=0, vmax=1, cmap="viridis")
    for i in range(len(methods)):
        for j in range(len(names)):
            colour = "black" if recall[i, j] > 0.6 else "white"
            ax.text(j, i, f"recall {recall[i, j]:.3f}\nprecision {precision[i, j]:.3f}",
                    ha="center", va="center", fontsize=9, color=colour)
    ax.set_xticks(range(len(names)), names)
    ax.set_yticks(range(len(methods)), methods)
    ax.set_xlabel("evaluated on")
    fig.colorbar(im, ax=ax, label="parked-vehicle recall")
    ax.set_title("Laser parked-vehicle detector fitted on a plain street, "
                 "evaluated on every condition", fontsize=11)
    save_figure(fig, path, note)
    return recall, precision


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scans", type=int, default=2000, help="scans per run")
    parser.add_argument("--out", default=None, help="PNG to write "
                        "(default: docs/_static/cross_condition_street.png)")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    path = output_path("cross_condition_street.png", args.out)
    result = scores(args.scans)
    note = (f"python docs/figures/make_cross_condition_street.py --scans {args.scans}"
            f" | {machine()}")
    recall, precision = draw(result, path, note)
    print("| method | " + " | ".join(CONDITIONS) + " |")
    print("|---" * (len(CONDITIONS) + 1) + "|")
    for i, m in enumerate(result):
        print(f"| {m} | " + " | ".join(f"{r:.3f} / {p:.3f}" for r, p in
                                      zip(recall[i], precision[i], strict=True)) + " |")
    print(f"\n(recall / precision) wrote {path} "
          f"({time.perf_counter() - start:.0f} s; {note})")


if __name__ == "__main__":
    main()
