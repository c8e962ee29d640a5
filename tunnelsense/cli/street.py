"""``tunnelsense train|detect|evaluate street``: the street-parked vehicle detector."""

from __future__ import annotations

import json
import time
from pathlib import Path

from tunnelsense._deferred import start_imports
from tunnelsense.cli import _common as common
from tunnelsense.cli import _fleet as fleet
from tunnelsense.cli._extras import require_extras_for_runs
from tunnelsense.exceptions import InputFormatError

__all__ = ["register"]


def _read_runs(paths, args):
    from tunnelsense.io import read_run

    runs = []
    for p in paths:
        runs.append(read_run(p, range_unit=args.range_unit, topic=args.topic,
                             mount_height=args.mount_height, speed=args.speed,
                             speed_topic=args.speed_topic))
        _check_speed(p, runs[-1].info)
    return runs


def _check_speed(path, info, model=None) -> None:
    """Refuse a run that gives no ego speed when the model fixes none: its lengths
    would come from a guessed speed (a bag without odometry, a run folder whose
    info_json gives no speed), unless ``--speed`` is given."""
    from tunnelsense.io import ego_speed
    from tunnelsense.io._rosbag import is_bag

    if model is not None and getattr(model[-1], "speed", None) is not None:
        return
    if is_bag(path):
        if "speed" in info or "speed_topic" in info:
            return
        raise InputFormatError(
            f"{path}: the bag gives no ego speed (no nav_msgs/Odometry or "
            "geometry_msgs/TwistStamped topic), which turns scan counts into lengths; "
            "pass --speed M/S (e.g. --speed 11.1 at 40 km/h)")
    if ego_speed(info) is None:
        raise InputFormatError(
            f"{path}: the run gives no ego speed (none of speed, speed_mps, "
            "speed_kmh_mean, speed_kmh in its info_json), which turns scan counts "
            "into lengths; pass --speed M/S (e.g. --speed 11.1 at 40 km/h)")


def _check_speeds(paths, reading, model) -> None:
    """:func:`_check_speed` of every run of a fleet, before any detection."""
    from tunnelsense.io._laser import open_run_stream

    if model is not None and getattr(model[-1], "speed", None) is not None:
        return
    for path in paths:
        _check_speed(path, open_run_stream(path, **reading).info, model)


def _cmd_train(args) -> int:
    from tunnelsense.street._run import format_runs, format_training, train_detector

    start = time.perf_counter()
    require_extras_for_runs(args.rundirs)
    key = common.check_model_output(args, args.rundirs)
    runs = _read_runs(args.rundirs, args)
    print(format_runs(runs, search=args.search, n_jobs=args.jobs))
    bars = common.stage_progress(args)
    model, summary = train_detector(runs, search=args.search, n_jobs=args.jobs,
                                    progress=bars)
    if bars is not None:
        bars.close()
    print(format_training(summary))
    common.save_cli_model(model, args, summary=summary, key=key, start=start)
    return 0


def _cmd_detect(args) -> int:
    start_imports()  # before scikit-learn's import (the command only)
    sources = fleet.fleet_sources(args)
    if sources is not None:
        require_extras_for_runs(sources)
        reading = {"range_unit": args.range_unit, "topic": args.topic,
                   "mount_height": args.mount_height, "speed": args.speed,
                   "speed_topic": args.speed_topic}
        return fleet.run_fleet(args, "street", sources,
                               {"all_objects": args.all_objects, **reading},
                               check=lambda model: _check_speeds(sources, reading, model))
    from tunnelsense.io._laser import open_run_stream
    from tunnelsense.street._run import format_objects_written, write_objects

    require_extras_for_runs([args.source], draw=args.draw)
    common.check_detect_outputs(args, args.source, [args.out])
    model = common.cli_model(args, "street")
    source = open_run_stream(args.source, range_unit=args.range_unit, topic=args.topic,
                             mount_height=args.mount_height, speed=args.speed,
                             speed_topic=args.speed_topic, ground_truth=False)
    _check_speed(args.source, source.info, model)
    counts, resumed = write_objects(
        model, source, args.out, all_objects=args.all_objects, resume=args.resume,
        overwrite=args.force, progress=common.progress(
            args, source.n_scans, f"{source.name}: detecting", unit="scan"))
    print(format_objects_written(source.name, counts, args.out, resumed))
    if args.draw:
        from tunnelsense.plotting import draw_run

        run = _read_runs([args.source], args)[0]
        head = model[:-1].transform(run.scans) if len(model.steps) > 1 else run.scans
        written = draw_run(run, model[-1], args.draw, X=head)
        print(f"drew {len(written)} pictures in {args.draw}")
    return 0


def _cmd_evaluate(args) -> int:
    from tunnelsense.io import read_objects, read_run_gt
    from tunnelsense.metrics import street_class_scores, street_report, street_scores

    rundir = Path(args.rundir)
    gt = read_run_gt(rundir / "gt.csv" if rundir.is_dir() else rundir)
    detected = read_objects(args.objects)
    scores = street_scores(gt, detected, min_iou=args.min_iou, zero_division=None)
    if args.json and "vehicle_class" in gt and "vehicle_class" in detected:
        classes = street_class_scores(gt, detected, min_iou=args.min_iou)
        scores["parked_classes"] = {
            "classes": classes["classes"], "accuracy": classes["accuracy"],
            "confusion": {truth: {k: int(v) for k, v in row.items()}
                          for truth, row in classes["confusion"].iterrows()}}
    print(json.dumps(scores, indent=2) if args.json
          else street_report(gt, detected, min_iou=args.min_iou))
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
    speed = parser.add_mutually_exclusive_group()
    speed.add_argument(
        "--speed", type=float, metavar="M/S",
        help="the ego speed (m/s) of every scan, which turns scan counts into lengths "
        "(default: the run's own; a ROS bag's from its odometry topic)")
    speed.add_argument(
        "--speed-topic", metavar="TOPIC",
        help="a ROS bag's nav_msgs/Odometry or geometry_msgs/TwistStamped topic "
        "giving the ego speed (default: the only one)")


def register(verbs) -> None:
    """Add the ``street`` kind to the ``train``, ``detect`` and ``evaluate`` verbs."""
    p = verbs["train"].add_parser("street", help="fit the parked-vehicle detector")
    p.add_argument("rundirs", nargs="+", metavar="RUNDIR",
                   help="laser run folders (scans.npz + gt.csv)")
    p.add_argument("--search", action="store_true",
                   help="grid-search cut and link distance, GroupKFold by run")
    p.add_argument("--jobs", type=int, default=common.CPUS,
                   help="parallel fits of --search (default: the number of CPUs)")
    common.add_output_arguments(p, writes_model=True, quiet=True)
    _add_range_unit(p)
    p.set_defaults(func=_cmd_train)

    p = verbs["detect"].add_parser("street", help="detect parked and passing vehicles")
    p.add_argument("source", nargs="*", metavar="RUN",
                   help="a laser run folder (scans.npz), a ROS 1 .bag file or a ROS 2 "
                   "bag folder of sensor_msgs/LaserScan (several: a fleet, see "
                   "--tours-from)")
    common.add_model_arguments(p, help_model="a model saved by train street (.skops, "
                               "or a .joblib pickle with --trust-pickle)")
    p.add_argument("--out", required=True, metavar="OBJECTS.csv",
                   help="object table to write (several runs: the folder of their "
                   "object tables)")
    p.add_argument("--all-objects", action="store_true",
                   help="also write roadside objects and non-vehicles ('other')")
    p.add_argument("--resume", action="store_true",
                   help="continue an interrupted OBJECTS.csv (rows are replayed and "
                        "checked, not duplicated)")
    common.add_output_arguments(p, quiet=True)
    _add_range_unit(p)
    p.add_argument("--draw", metavar="DIR",
                   help="draw the range image, a scan and its dendrogram into DIR")
    p.add_argument("--jobs", type=int, default=common.CPUS,
                   help="several runs: runs detected at once (default: the number of "
                   "CPUs)")
    fleet.add_fleet_arguments(p, "run")
    p.set_defaults(func=_cmd_detect)

    p = verbs["evaluate"].add_parser(
        "street", help="score an object table (per vehicle class when both tables "
        "have a vehicle_class column)")
    p.add_argument("rundir", metavar="RUNDIR", help="the run folder (its gt.csv)")
    p.add_argument("objects", metavar="OBJECTS.csv", help="written by detect street")
    p.add_argument("--json", action="store_true",
                   help="print the scores as JSON (null where undefined)")
    p.add_argument("--min-iou", type=float, default=0.5,
                   help="scan-interval IoU of a match (default 0.5)")
    p.set_defaults(func=_cmd_evaluate)
