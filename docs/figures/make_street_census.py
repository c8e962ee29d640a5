"""A parking census of a simulated hard street: what the detector counts, and the truth.

The detector is fitted on one plain run (``train_detector``, as ``tunnelsense train
street`` does) and run over a hard street (cars, small cars, vans and motorbikes,
touching rows, pedestrians and bins); its objects are counted per 50 m segment
(``tunnelsense.street.census``, as ``tunnelsense survey street`` does), by the
classes the detector gives them.  Below, the census of the run's ground truth with
the simulator's vehicle classes.  Distance comes
from the run's ego speed times the scan periods, as on the command line.

Run from a source checkout or an unpacked sdist, with the ``plot`` extra installed::

    python docs/figures/make_street_census.py [--scans 3000] [--out PNG]

It writes ``docs/_static/street_census.png`` and prints both censuses and the class
confusion matrix of the matched parked vehicles (about 20 s on a 2-core machine).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import load, machine, output_path, save_figure  # noqa: E402

from tunnelsense.datasets import make_street_scans  # noqa: E402
from tunnelsense.io import ego_speed  # noqa: E402
from tunnelsense.metrics import street_class_scores, street_scores  # noqa: E402
from tunnelsense.plotting import plot_census  # noqa: E402
from tunnelsense.street import (  # noqa: E402
    census,
    parked_extents,
    scan_distances,
    train_detector,
)

TRAIN = ("sparse", 1)
SURVEY = ("hard", 2)
SEGMENT = 50.0


def censuses(n_scans):
    """The detected and the true census of the hard street, and their objects."""
    train = make_street_scans(2000, scenario=TRAIN[0], random_state=TRAIN[1])
    run = make_street_scans(n_scans, scenario=SURVEY[0], random_state=SURVEY[1])
    model, _ = train_detector([train])
    detected = model[-1].detect(run.scans)
    truth = run.gt  # the simulator's ground truth carries every vehicle's class
    distances = scan_distances([s.stamp for s in run.scans], ego_speed(run.info))
    scores = street_scores(run.gt, detected)["parked"]
    print(f"detected parked vehicles: {scores['tp']} matched, {scores['fn']} missed, "
          f"{scores['fp']} false (scan-interval IoU >= 0.5)")
    classes = street_class_scores(run.gt, detected)
    print("classes of the matched parked vehicles (rows: truth):")
    print(classes["confusion"].to_string())
    return {name: (census(objects, distances, segment_length=SEGMENT),
                   parked_extents(objects, distances))
            for name, objects in (("detected", detected), ("true", truth))}


def draw(result, path, note):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(12, 6.5), sharex=True, layout="constrained")
    titles = {"detected": "detected (survey street), with the detector's vehicle "
                          "classes",
              "true": "the run's ground truth, with the simulator's vehicle classes"}
    for ax, (name, (table, parked)) in zip(axes, result.items(), strict=True):
        plot_census(table, parked, ax=ax, title=titles[name])
        ax.title.set_fontsize(10)
    axes[0].set_xlabel("")
    save_figure(fig, path, note)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scans", type=int, default=3000, help="scans of the street")
    parser.add_argument("--out", default=None,
                        help="PNG to write (default: docs/_static/street_census.png)")
    args = parser.parse_args(argv)
    path = output_path("street_census.png", args.out)
    result = censuses(args.scans)
    note = (f"python docs/figures/make_street_census.py --scans {args.scans} | "
            f"{machine()} | {load()}")
    draw(result, path, note)
    for name, (table, _) in result.items():
        print(f"{name}:")
        print(table.round(3).to_markdown(index=False) if _has_tabulate()
              else table.round(3).to_string(index=False))
    detected, true = result["detected"][0], result["true"][0]
    print(f"\nparked: {detected['parked'].sum()} detected, {true['parked'].sum()} true; "
          "largest occupancy difference per segment "
          f"{np.abs(detected['occupancy'] - true['occupancy']).max():.3f}")
    print(f"wrote {path} ({time.perf_counter() - START:.0f} s; {note})")


def _has_tabulate():
    try:
        import tabulate  # noqa: F401
    except ImportError:
        return False
    return True


START = time.perf_counter()

if __name__ == "__main__":
    main()
