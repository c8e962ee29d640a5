"""``tunnelsense train|detect|evaluate street``: the street-parked vehicle detector.

* ``tunnelsense train street RUNDIR... --model PATH [--search]`` fits the detector
  (a :func:`~tunnelsense.street.make_parking_pipeline`) on labelled runs and saves it,
  by the extension of ``PATH``: ``.skops`` the safe format (no code runs on load;
  versions, training summary, checksum), ``.joblib`` a pickle; ``--search``
  grid-searches its thresholds with ``GroupKFold`` by run.
* ``tunnelsense detect street --model PATH RUNDIR --out OBJECTS.csv [--resume]
  [--draw DIR]`` reads the run scan by scan and streams it through the detector
  (memory bounded by the longest object in view), writing the object table
  (``id,first_scan,last_scan,label,mean_depth,...``) row by row as objects finish,
  flushed; ``--resume`` continues an interrupted file by deterministic replay.
* ``tunnelsense evaluate street RUNDIR OBJECTS.csv [--json]`` scores it against the
  run's ``gt.csv``.
"""

from __future__ import annotations

import json
import os
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

_SEARCH_GRID = {
    "cluster__cut": [0.4, 0.6, 0.8],
    "cluster__link_distance": [0.3, 0.5, 0.7],
}


def _read_runs(paths, args):
    from tunnelsense.io import read_run

    return [read_run(p, range_unit=args.range_unit, topic=args.topic,
                     mount_height=args.mount_height) for p in paths]


def _speed_of(run):
    """Ego speed (m/s) from the run information, when it has one."""
    info = run.info or {}
    for key, scale in (("speed", 1.0), ("speed_mps", 1.0), ("speed_kmh_mean", 1 / 3.6),
                       ("speed_kmh", 1 / 3.6)):
        try:
            v = float(info[key]) * scale
        except (KeyError, TypeError, ValueError):
            continue
        if v > 0:
            return v
    return None


def _with_speed(run):
    """The run's scans, each carrying the run's ego speed in its payload if known."""
    v = _speed_of(run)
    if v is None:
        return list(run.scans)
    return [r.evolve(speed=v) for r in run.scans]


def _cmd_train(args) -> int:
    from sklearn.model_selection import GridSearchCV, GroupKFold

    from tunnelsense._records import to_xy
    from tunnelsense.io import save_model
    from tunnelsense.io._output import check_output
    from tunnelsense.metrics import make_street_scorer
    from tunnelsense.street import make_parking_pipeline

    if Path(args.model).suffix.lower() not in (".skops", ".joblib"):
        raise ValueError(f"--model {args.model}: expected a .skops (safe) or .joblib "
                         "(pickle) file name")
    inputs = [f for d in args.rundirs for f in input_files(d)]
    inputs += [args.key_file] if args.key_file else []
    check_output(args.model, overwrite=args.force, inputs=inputs, what="--model")
    key = signing_key(args)
    runs = _read_runs(args.rundirs, args)
    X, y, groups = to_xy(runs)
    X = [r for run in runs for r in _with_speed(run)]
    pipe = make_parking_pipeline()
    summary = {"task": "street", "runs": [run.name for run in runs],
               "scans": int(len(X))}
    if args.search:
        n_groups = len(set(groups))
        if n_groups < 2:
            raise ValueError("--search needs at least two runs (folds are runs)")
        search = GridSearchCV(pipe, _SEARCH_GRID, cv=GroupKFold(min(n_groups, 5)),
                              scoring=make_street_scorer("parked", "f1"),
                              error_score="raise", n_jobs=args.jobs)
        search.fit(X, y, groups=groups)
        pipe = search.best_estimator_
        summary["search"] = {"grid": _SEARCH_GRID, "best_params": search.best_params_,
                             "best_score": float(search.best_score_),
                             "scoring": "parked F1", "folds": min(n_groups, 5)}
        print(f"best parameters: {search.best_params_} "
              f"(parked F1 {search.best_score_:.3f} over {n_groups} runs)")
    else:
        pipe.fit(X, y)
    summary["parameters"] = {k: v for k, v in pipe.get_params(deep=True).items()
                             if "__" in k}
    save_model(pipe, args.model, summary=summary, key=key, overwrite=args.force)
    print(f"saved {args.model}" + (" (signed)" if key is not None else ""))
    return 0


def _load_model(args):
    return load_cli_model(args.model, last_step="cluster", command="train street",
                          trust_pickle=args.trust_pickle, key=signing_key(args))


#: Columns written by ``detect street`` (the object table without ``run``).
DETECT_COLUMNS = ("id", "first_scan", "last_scan", "label", "mean_depth", "region",
                  "length", "top_height", "n_points")

#: Scans pushed into the stream at once (decisions are the same at any chunking).
_CHUNK = 64


def _format_row(row):
    _run, oid, first, last, label, depth, region, length, top, n_points = row
    return (f"{oid},{first},{last},{label},{depth:.4f},{region},{length:.4f},"
            f"{top:.4f},{n_points}")


def _cmd_detect(args) -> int:
    from tunnelsense._progress import Progress
    from tunnelsense._records import RUN_LABELS
    from tunnelsense._streaming import ResultsWriter
    from tunnelsense.io import open_run_stream
    from tunnelsense.io._output import check_output

    out = Path(args.out)
    inputs = [args.model, *input_files(args.rundir),
              *([args.key_file] if args.key_file else [])]
    check_output(out, overwrite=args.force or args.resume, inputs=inputs, what="--out")
    if args.draw:
        check_draw_dir(args.draw, force=args.force, inputs=inputs)
    model = _load_model(args)
    source = open_run_stream(args.rundir, chunk_scans=1024,
                             range_unit=args.range_unit, topic=args.topic,
                             mount_height=args.mount_height)
    speed = _speed_of(source)
    step = model.steps[-1][1] if hasattr(model, "steps") else model
    head = model[:-1] if hasattr(model, "steps") and len(model.steps) > 1 else None
    if not hasattr(step, "start_stream"):
        raise TypeError(f"--model {args.model}: its last step "
                        f"{type(step).__name__} cannot stream (no start_stream)")
    state = step.start_stream()
    keep = None if args.all_objects else set(RUN_LABELS)
    counts = {}
    progress = Progress(source.n_scans, f"{source.name}: detecting",
                        enabled=not args.quiet)
    done = 0
    with ResultsWriter(out, header=",".join(DETECT_COLUMNS), resume=args.resume,
                       overwrite=args.force) as w:

        def feed(chunk):
            if head is not None and chunk:
                chunk = list(head.transform(chunk))
            state.push_many(chunk) if chunk else state.close()
            for row in state.pop_objects():
                if keep is None or row[4] in keep:
                    w.write(_format_row(row))
                    counts[row[4]] = counts.get(row[4], 0) + 1
            w.flush()

        chunk = []
        for record in source:
            chunk.append(record if speed is None else record.evolve(speed=speed))
            if len(chunk) == _CHUNK:
                feed(chunk)
                done += len(chunk)
                progress.update(done)
                chunk = []
        if chunk:
            feed(chunk)
            done += len(chunk)
            progress.update(done)
        feed([])
        resumed = w.resumed_lines
    n = sum(counts.values())
    print(f"{source.name}: {n} objects "
          + (", ".join(f"{c} {k}" for k, c in sorted(counts.items())) or "")
          + f" -> {out}" + (f" (resumed after {resumed} rows)" if resumed else ""))
    if args.draw:
        from tunnelsense.street._plotting import draw_run

        run = _read_runs([args.rundir], args)[0]
        X = _with_speed(run)
        Xt = head.transform(X) if head is not None else X
        written = draw_run(run, step, args.draw, X=Xt)
        print(f"drew {len(written)} pictures in {args.draw}")
    return 0


def _cmd_evaluate(args) -> int:
    import pandas as pd

    from tunnelsense.io import read_run_gt
    from tunnelsense.metrics import street_confusion_matrix, street_scores

    rundir = Path(args.rundir)
    gt_path = rundir / "gt.csv" if rundir.is_dir() else rundir
    gt = read_run_gt(gt_path)
    path = Path(args.objects)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: objects file not found")
    try:
        det = pd.read_csv(path)
    except (pd.errors.ParserError, UnicodeDecodeError, pd.errors.EmptyDataError) as exc:
        raise ValueError(f"{path}: not a CSV object table ({exc})") from None
    missing = [c for c in ("first_scan", "last_scan", "label") if c not in det]
    if missing:
        raise ValueError(f"{path}: lacks column(s) {', '.join(missing)}: expected "
                         "id,first_scan,last_scan,label,mean_depth")
    scores = street_scores(gt, det, min_iou=args.min_iou)
    if args.json:
        print(json.dumps(scores, indent=2))
        return 0
    for label, s in scores.items():
        print(f"{label:8s} tp {s['tp']:4d}  fp {s['fp']:4d}  fn {s['fn']:4d}  "
              f"recall {s['recall']:.3f}  precision {s['precision']:.3f}")
    print("\nparked vehicles, the paper's confusion matrix (rows: truth):")
    m = street_confusion_matrix(gt, det, min_iou=args.min_iou).astype(object)
    print(m.where(m.notna(), "N/A").to_string())
    return 0


def _add_range_unit(parser) -> None:
    parser.add_argument(
        "--range-unit", choices=("m", "mm"), default="m",
        help="unit of the ranges in scans.npz: m (ROS, floats; default) or mm "
        "(integer millimetres, as some drivers write)",
    )
    parser.add_argument(
        "--topic", help="a ROS bag's sensor_msgs/LaserScan topic (default: the only one)"
    )
    parser.add_argument(
        "--mount-height", type=float, metavar="METRES",
        help="a ROS bag's laser height above the road, when the bag does not say",
    )


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
    p.add_argument("--json", action="store_true", help="print JSON")
    p.add_argument("--min-iou", type=float, default=0.5,
                   help="scan-interval IoU of a match (default 0.5)")
    p.set_defaults(func=_cmd_evaluate)
