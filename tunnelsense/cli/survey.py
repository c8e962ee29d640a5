"""``tunnelsense survey street``: a parking census of a laser run."""

from __future__ import annotations

import math
from pathlib import Path

from tunnelsense.cli import _common as common
from tunnelsense.cli._extras import require_extra, require_extras_for_runs
from tunnelsense.cli.position import _positive
from tunnelsense.cli.street import _add_range_unit, _check_speed
from tunnelsense.exceptions import InputFormatError
from tunnelsense.io._output import atomic_write, check_output, input_files

__all__ = ["register_top"]

#: Picture formats of ``--plot``, by file suffix.
_PLOT_SUFFIXES = (".png", ".pdf", ".svg")


def _check_outputs(args) -> None:
    """Refuse ``--out`` and ``--plot`` before any work: not an input, not each other,
    an existing file only with ``--force``; a picture format matplotlib writes."""
    inputs = [args.model, args.objects, *input_files(args.rundir),
              *common.key_files(args)]
    check_output(args.out, overwrite=args.force, inputs=inputs, what="--out")
    if args.plot is None:
        return
    if Path(args.plot).suffix.lower() not in _PLOT_SUFFIXES:
        raise ValueError(f"--plot {args.plot}: expected a file name ending in "
                         f"{', '.join(_PLOT_SUFFIXES)}")
    if Path(args.plot).resolve() == Path(args.out).resolve():
        raise ValueError(f"--plot {args.plot}: is also the --out file")
    check_output(args.plot, overwrite=args.force, inputs=inputs, what="--plot")


def _scans(source, bar, stamps, speeds):
    """The scans of ``source``, their stamps and speeds kept as they pass."""
    for i, record in enumerate(source):
        if record.scan != i:
            raise InputFormatError(f"{source.name}: scan {record.scan} comes where scan "
                                   f"{i} was expected; the scans must be numbered from 0")
        stamps.append(record.stamp)
        speeds.append(float(record.payload.get("speed", math.nan)))
        if bar is not None:
            bar.update(i + 1)
        yield record


def _speeds(args, speeds, model):
    """The ego speed of every scan: the run's (or ``--speed``), else the model's."""
    import numpy as np

    speeds = np.asarray(speeds, dtype=np.float64)
    if not np.isnan(speeds).any():
        return speeds
    fixed = getattr(model[-1], "speed", None) if model is not None else None
    if np.isnan(speeds).all() and fixed is not None:
        return np.full(len(speeds), float(fixed))
    raise InputFormatError(
        f"{args.rundir}: the run gives no ego speed for "
        f"{int(np.isnan(speeds).sum())} of its {len(speeds)} scans, which turns scan "
        "times into distance along the street; pass --speed M/S (e.g. --speed 11.1 "
        "at 40 km/h)")


def _check_objects_file(args, objects, n_scans):
    """Refuse an object table of ``--objects`` whose scans are beyond the run's."""
    import numpy as np

    beyond = np.flatnonzero(objects["last_scan"].to_numpy() >= n_scans)
    if beyond.size:
        raise InputFormatError(
            f"{args.objects}, line {beyond[0] + 2}: last_scan "
            f"{objects['last_scan'].iloc[beyond[0]]} is beyond the {n_scans} scans of "
            f"{args.rundir} (numbered from 0): is it the objects file of this run?")


def _cmd_survey_street(args) -> int:
    import pandas as pd

    from tunnelsense.io import open_run_stream, read_objects
    from tunnelsense.street import (
        CENSUS_CLASSES,
        OBJECT_COLUMNS,
        census,
        parked_extents,
        scan_distances,
        stream_objects,
    )

    require_extras_for_runs([args.rundir])
    if args.plot is not None:
        require_extra("plot", "--plot")
    _check_outputs(args)
    model = common.cli_model(args, "street") if args.model is not None else None
    objects = read_objects(args.objects) if model is None else None  # before the run
    source = open_run_stream(args.rundir, range_unit=args.range_unit, topic=args.topic,
                             mount_height=args.mount_height, speed=args.speed,
                             speed_topic=args.speed_topic)
    _check_speed(args.rundir, source.info, model)
    what = "detecting" if model is not None else "reading the scans"
    bar = common.progress(args, source.n_scans, f"{source.name}: {what}", unit="scan")
    stamps, speeds = [], []
    scans = _scans(source, bar, stamps, speeds)
    if model is not None:
        objects = pd.DataFrame(list(stream_objects(model, scans)),
                               columns=list(OBJECT_COLUMNS))
    else:
        for _ in scans:
            pass
    if bar is not None:
        bar.close()
    if len(stamps) < 2:
        raise InputFormatError(f"{args.rundir}: {len(stamps)} scan(s); a census needs "
                               "at least two (the time between scans gives distance)")
    if model is None:
        _check_objects_file(args, objects, len(stamps))
    distances = scan_distances(stamps, _speeds(args, speeds, model))
    table = census(objects, distances, segment_length=args.segment_length)
    with atomic_write(args.out, "w") as f:
        table.to_csv(f, index=False, float_format="%.3f", lineterminator="\n")
    totals = table[list(CENSUS_CLASSES)].sum()
    classes = ", ".join(f"{totals[c]} {c}" for c in CENSUS_CLASSES if totals[c])
    driven = distances[-1, 1]
    occupied = (table["occupancy"] * table["kerb_length_m"]).sum() / driven
    print(f"{source.name}: {int(table['parked'].sum())} parked vehicles"
          f"{f' ({classes})' if classes else ''} along {driven:.0f} m, "
          f"{len(table)} segment(s) of {args.segment_length:g} m, kerb occupancy "
          f"{100 * occupied:.0f} % -> {args.out}")
    if args.plot is not None:
        _plot(args, table, parked_extents(objects, distances), source.name)
    return 0


def _plot(args, table, parked, name) -> None:
    from tunnelsense.plotting import plot_census
    from tunnelsense.plotting._scans import _pyplot

    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(14, 4), layout="constrained")
    plot_census(table, parked, ax=ax, title=f"{name}: parked vehicles and kerb "
                f"occupancy per {args.segment_length:g} m")
    try:
        with atomic_write(args.plot, "wb") as f:
            fig.savefig(f, format=Path(args.plot).suffix.lower()[1:], dpi=110)
    finally:
        plt.close(fig)
    print(f"drew {args.plot}")


def register_top(sub) -> None:
    """Add the ``survey`` command and its ``street`` kind."""
    survey = sub.add_parser(
        "survey", help="count what a run passed: a parking census of a street",
        description="Count what a run passed.")
    kinds = survey.add_subparsers(dest="kind", metavar="KIND", required=True)
    p = kinds.add_parser(
        "street", help="parked vehicles per street segment, by class, and the kerb "
        "occupancy",
        description="A parking census of a laser run: per street segment, the parked "
        "vehicles by class (car, van, motorbike, as the detector tells them; "
        "'unclassified' for an object table without classes), their length and the fraction of the kerb they cover. "
        "Distance along the street comes from the ego speed of each scan (the run's "
        "own, a ROS bag's odometry, or --speed) times the time between scans. Detect "
        "with --model, or count an object table of 'detect street' (--objects).")
    p.add_argument("rundir", metavar="RUN",
                   help="a laser run folder (scans.npz), a ROS 1 .bag file or a ROS 2 "
                   "bag folder of sensor_msgs/LaserScan")
    source = p.add_mutually_exclusive_group(required=True)
    common.add_model_arguments(
        p, group=source, help_model="a model saved by train street (.skops, or a "
        ".joblib pickle with --trust-pickle): detect the parked vehicles")
    source.add_argument("--objects", metavar="OBJECTS.csv",
                        help="count the objects of this table, written by 'detect "
                        "street' on the same run, instead of detecting")
    p.add_argument("--out", required=True, metavar="CENSUS.csv",
                   help="the census to write: segment,start_m,end_m,kerb_length_m,"
                   "car,van,motorbike,unclassified,parked,parked_length_m,occupancy")
    p.add_argument("--segment-length", type=_positive, default=50.0, metavar="METRES",
                   help="length of a street segment (m, default 50)")
    p.add_argument("--plot", metavar="FILE", help="also draw the street along the "
                   "distance driven, parked vehicles coloured by class under the "
                   "occupancy of each segment (.png, .pdf or .svg)")
    common.add_output_arguments(p, quiet=True)
    _add_range_unit(p)
    p.set_defaults(func=_cmd_survey_street)
