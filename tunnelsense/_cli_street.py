"""``tunnelsense train|detect|evaluate street``: the street-parked vehicle detector.

* ``tunnelsense train street RUNDIR... --model PATH [--search]`` fits the detector
  (:func:`~tunnelsense.street.train_detector`) on labelled runs and saves it, by the
  extension of ``PATH``: ``.skops`` the safe format (no code runs on load; versions,
  training summary, checksum), ``.joblib`` a pickle.
* ``tunnelsense detect street --model PATH RUN --out OBJECTS.csv [--resume]
  [--draw DIR]`` streams the run scan by scan through the detector
  (:func:`~tunnelsense.street.write_objects`), writing the object table row by row
  as objects finish; ``--resume`` continues an interrupted file by replay.
* ``tunnelsense evaluate street RUNDIR OBJECTS.csv [--json]`` scores it against the
  run's ``gt.csv`` (:func:`~tunnelsense.metrics.street_report`).
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

from tunnelsense._cli_common import (
    add_model_arguments,
    add_output_arguments,
    check_draw_dir,
    input_files,
    load_cli_model,
    signing_key,
)

__all__ = ["register"]


def _read_runs(paths, args):
    from tunnelsense.io import read_run

    return [read_run(p, range_unit=args.range_unit, topic=args.topic,
                     mount_height=args.mount_height) for p in paths]


def _cmd_train(args) -> int:
    import numpy as np
    import pandas as pd

    from tunnelsense.io import save_model
    from tunnelsense.io._output import check_output
    from tunnelsense.street import SEARCH_GRID, train_detector

    start = time.perf_counter()
    if Path(args.model).suffix.lower() not in (".skops", ".joblib"):
        raise ValueError(f"--model {args.model}: expected a .skops (safe) or .joblib "
                         "(pickle) file name")
    inputs = [f for d in args.rundirs for f in input_files(d)]
    inputs += [args.key_file] if args.key_file else []
    check_output(args.model, overwrite=args.force, inputs=inputs, what="--model")
    key = signing_key(args)
    runs = _read_runs(args.rundirs, args)
    labels = pd.concat([run.gt["label"] for run in runs]).value_counts()
    print(f"training on {len(runs)} run(s), {sum(map(len, runs))} scans, "
          f"{labels.get('parked', 0)} parked, {labels.get('passing', 0)} passing vehicles"
          + (f"; searching {np.prod([len(v) for v in SEARCH_GRID.values()])} settings "
             f"on {args.jobs} job(s)" if args.search else ""))
    model, summary = train_detector(runs, search=args.search, n_jobs=args.jobs)
    if args.search:
        s = summary["search"]
        print(f"best parameters: {s['best_params']} (parked F1 {s['best_score']:.3f}, "
              f"{s['folds']} folds)")
    for label, s in summary["training_scores"].items():
        print(f"training {label}: recall {_rate(s['recall'])}, precision "
              f"{_rate(s['precision'])} ({s['tp']} of {s['tp'] + s['fn']} found)")
    save_model(model, args.model, summary=summary, key=key, overwrite=args.force)
    kind = "safe skops" if Path(args.model).suffix.lower() == ".skops" else "pickle"
    print(f"wrote {args.model} ({kind}{', signed' if key is not None else ''}; "
          f"{time.perf_counter() - start:.1f} s)")
    return 0


def _rate(value):
    return "n/a" if value is None or value != value else f"{100 * value:.1f} %"


def _cmd_detect(args) -> int:
    from tunnelsense._progress import Progress
    from tunnelsense.io import open_run_stream
    from tunnelsense.io._output import check_output
    from tunnelsense.street import write_objects

    inputs = [args.model, *input_files(args.rundir),
              *([args.key_file] if args.key_file else [])]
    check_output(args.out, overwrite=args.force or args.resume, inputs=inputs,
                 what="--out")
    if args.draw:
        check_draw_dir(args.draw, force=args.force, inputs=inputs)
    model = load_cli_model(args.model, last_step="cluster", command="train street",
                           trust_pickle=args.trust_pickle, key=signing_key(args))
    source = open_run_stream(args.rundir, range_unit=args.range_unit, topic=args.topic,
                             mount_height=args.mount_height)
    progress = Progress(source.n_scans, f"{source.name}: detecting",
                        enabled=not args.quiet, unit="scan")
    scans = (progress.update(i) or r for i, r in enumerate(source, 1))
    counts, resumed = write_objects(model, scans, args.out,
                                    all_objects=args.all_objects, resume=args.resume,
                                    overwrite=args.force)
    progress.close()
    print(f"{source.name}: {sum(counts.values())} objects "
          + ", ".join(f"{c} {k}" for k, c in sorted(counts.items()))
          + f" -> {args.out}" + (f" (resumed after {resumed} rows)" if resumed else ""))
    if args.draw:
        from tunnelsense.plotting import draw_run

        run = _read_runs([args.rundir], args)[0]
        head = model[:-1].transform(run.scans) if len(model.steps) > 1 else run.scans
        written = draw_run(run, model[-1], args.draw, X=head)
        print(f"drew {len(written)} pictures in {args.draw}")
    return 0


def _cmd_evaluate(args) -> int:
    from tunnelsense.io import read_objects, read_run_gt
    from tunnelsense.metrics import street_report, street_scores

    rundir = Path(args.rundir)
    gt = read_run_gt(rundir / "gt.csv" if rundir.is_dir() else rundir)
    detected = read_objects(args.objects)
    if args.json:
        print(json.dumps(street_scores(gt, detected, min_iou=args.min_iou,
                                       zero_division=None), indent=2))
    else:
        print(street_report(gt, detected, min_iou=args.min_iou))
    return 0


def _add_range_unit(parser) -> None:
    parser.add_argument(
        "--range-unit", choices=("m", "mm"), default="m",
        help="unit of the ranges in scans.npz: m (ROS, floats; default) or mm "
        "(integer millimetres, as some drivers write)")
    parser.add_argument(
        "--topic", help="a ROS bag's sensor_msgs/LaserScan topic (default: the only one)")
    parser.add_argument(
        "--mount-height", type=float, metavar="METRES",
        help="a ROS bag's laser height above the road, when the bag does not say")


def register(verbs) -> None:
    """Add the ``street`` commands to the ``train``, ``detect`` and ``evaluate`` verbs.

    Parameters
    ----------
    verbs : dict
        ``{"train": sub, "detect": sub, "evaluate": sub}`` of argparse sub-parser
        actions.
    """
    p = verbs["train"].add_parser("street", help="fit the parked-vehicle detector")
    p.add_argument("rundirs", nargs="+", metavar="RUNDIR",
                   help="laser run folders (scans.npz + gt.csv)")
    p.add_argument("--model", required=True,
                   help="where to save the model: .skops (safe) or .joblib (pickle)")
    p.add_argument("--search", action="store_true",
                   help="grid-search cut and link distance, GroupKFold by run")
    p.add_argument("--jobs", type=int, default=os.cpu_count() or 1,
                   help="parallel fits of --search (default: the number of CPUs)")
    add_output_arguments(p, signs=True)
    _add_range_unit(p)
    p.set_defaults(func=_cmd_train)

    p = verbs["detect"].add_parser("street", help="detect parked and passing vehicles")
    p.add_argument("rundir", metavar="RUN",
                   help="a laser run folder (scans.npz), a ROS 1 .bag file or a ROS 2 "
                   "bag folder of sensor_msgs/LaserScan")
    add_model_arguments(p, help_model="a model saved by train street (.skops, or a "
                        ".joblib pickle with --trust-pickle)")
    p.add_argument("--out", required=True, metavar="OBJECTS.csv",
                   help="object table to write")
    p.add_argument("--all-objects", action="store_true",
                   help="also write roadside objects and non-vehicles ('other')")
    p.add_argument("--resume", action="store_true",
                   help="continue an interrupted OBJECTS.csv (rows are replayed and "
                        "checked, not duplicated)")
    add_output_arguments(p)
    _add_range_unit(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--draw", metavar="DIR",
                   help="draw the range image, a scan and its dendrogram into DIR")
    p.set_defaults(func=_cmd_detect)

    p = verbs["evaluate"].add_parser("street", help="score an object table")
    p.add_argument("rundir", metavar="RUNDIR", help="the run folder (its gt.csv)")
    p.add_argument("objects", metavar="OBJECTS.csv", help="written by detect street")
    p.add_argument("--json", action="store_true",
                   help="print the scores as JSON (null where undefined)")
    p.add_argument("--min-iou", type=float, default=0.5,
                   help="scan-interval IoU of a match (default 0.5)")
    p.set_defaults(func=_cmd_evaluate)
