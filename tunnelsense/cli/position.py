"""``tunnelsense position`` and ``tunnelsense evaluate position``."""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

from tunnelsense.cli import _common as common
from tunnelsense.cli._extras import require_extra
from tunnelsense.positioning._defaults import SIDE_ERROR

__all__ = ["register", "register_top"]


def _cmd_position(args) -> int:
    from tunnelsense.positioning import position_tour

    start = time.perf_counter()
    model = common.cli_model(args, "tunnel") if args.model else None
    positions, fixes = position_tour(
        args.tour, args.out, model=model, results=args.results,
        odometry=args.odometry, indicator_map=args.map, smooth=args.smooth,
        start_chainage=args.start_chainage, start_sigma=args.start_sigma,
        odometry_scale=args.odometry_scale,
        odometry_scale_sigma=args.odometry_scale_sigma,
        focal_length_px=args.focal_length, sign_height_m=args.sign_height,
        side_error=args.side_error,
        overwrite=args.force, inputs=[args.model, *common.key_files(args)],
        colour=common.colour(args), missing_frames=args.missing_frames,
        n_threads=args.jobs,
        progress=lambda total, desc: common.progress(args, total, desc))
    kept = int(fixes["accepted"].sum()) if len(fixes) else 0
    print(f"wrote {args.out}: {len(positions)} frames, {kept} of {len(fixes)} "
          f"trajectories gave a position fix ({time.perf_counter() - start:.1f} s)")
    print(fixes.attrs.get("lock_status", ""))
    locked = positions[positions["locked"]]
    if len(locked):
        last = locked.iloc[-1]
        if len(locked) < len(positions):
            print(f"{len(positions) - len(locked)} frames before the lock have no "
                  "chainage (locked=false)")
        print(f"odometry scale at the end: {last['scale']:.5f} +- "
              f"{last['scale_sigma']:.5f} (start the next tunnel with it: "
              f"--odometry-scale {last['scale']:.5f} --odometry-scale-sigma "
              f"{max(last['scale_sigma'], 1e-5):.5f})")
    else:
        print("no frame has a chainage (locked=false everywhere)")
    return 0


def _start(text):
    """``--start-chainage``: metres, or ``unknown``."""
    if text.strip().lower() in ("unknown", "none"):
        return None
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a chainage in metres or 'unknown'; got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite chainage; got {text!r}")
    return value


def _positive(text):
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a number > 0; got {text!r}")
    return value


def _side_error(text):
    """``--side-error``: a probability in (0, 0.5], or ``off``."""
    if text.strip().lower() in ("off", "none"):
        return None
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0.0 < value <= 0.5:  # NaN too
        raise argparse.ArgumentTypeError(
            f"expected a probability above 0 and at most 0.5, or 'off'; got {text!r}")
    return value


def _scale(text):
    value = _positive(text)
    if not 0.5 <= value <= 2.0:
        raise argparse.ArgumentTypeError(
            f"expected a scale factor between 0.5 and 2 (true / odometry distance); "
            f"got {text!r}")
    return value


def _cmd_evaluate_position(args) -> int:
    if args.draw:
        require_extra("plot", "--draw")
    from tunnelsense.positioning import evaluate_positions, format_errors

    errors = evaluate_positions(
        args.tour, args.positions, odometry=args.odometry, indicator_map=args.map,
        draw=args.draw, overwrite=args.force)
    print(json.dumps(errors, indent=2) if args.json else format_errors(
        errors, f"{args.positions} against {Path(args.tour) / 'positions.csv'}"))
    return 0


def _add_tables(p):
    p.add_argument("tour", metavar="TOUR", help="tour folder (simulated: holds "
                   "positions.csv, odometry.csv and indicators.csv)")
    p.add_argument("--odometry", metavar="CSV", help="frame,stamp,speed,yaw_rate "
                   "(default: TOUR/odometry.csv)")
    p.add_argument("--map", metavar="CSV", help="indicator map id,chainage,side "
                   "(default: TOUR/indicators.csv)")
def register(verbs) -> None:
    """Add ``evaluate position``."""
    p = verbs["evaluate"].add_parser(
        "position", help="score a position estimate against a tour's true positions")
    _add_tables(p)
    p.add_argument("positions", metavar="POS.csv", help="written by 'position'")
    p.add_argument("--draw", metavar="FILE.png", help="also plot the errors (fused and "
                   "dead reckoning) against time")
    p.add_argument("--json", action="store_true", help="print JSON")
    common.add_output_arguments(p)
    p.set_defaults(func=_cmd_evaluate_position)


def register_top(sub) -> None:
    """Add the top-level ``position`` command."""
    p = sub.add_parser(
        "position", help="chainage per frame from odometry and detected indicators",
        description="Detect the indicators of a tour (--model) or read a results file "
        "of 'detect tunnel' (--results), and fuse the fixes where the camera passes "
        "them with the odometry: frame,stamp,chainage,sigma per frame.")
    _add_tables(p)
    source = p.add_mutually_exclusive_group(required=True)
    common.add_model_arguments(
        p, group=source, help_model="model written by 'train tunnel' (detect online)")
    source.add_argument("--results", metavar="TXT", help="results file of 'detect tunnel'")
    p.add_argument("--out", required=True, metavar="POS.csv", help="file to write")
    p.add_argument("--smooth", action="store_true", help="smooth: with --results over "
                   "the whole tour (offline), with --model by a fixed-lag smoother "
                   "(rows released some seconds late); default: what was known at "
                   "each frame")
    p.add_argument("--start-chainage", type=_start, default=0.0, metavar="M",
                   help="chainage of the first frame (m), e.g. from GPS before the "
                   "portal; 'unknown' locks on to the map from the spacing of the "
                   "indicators passed (rows before the lock: locked=false, no "
                   "chainage; a map with evenly spaced indicators cannot be locked on "
                   "to). Default 0: the tour starts at the map's chainage 0")
    p.add_argument("--start-sigma", type=_positive, default=1.0, metavar="S",
                   help="standard deviation of --start-chainage (m, default 1)")
    p.add_argument("--odometry-scale", type=_scale, default=1.0, metavar="S",
                   help="the odometry's scale factor (true / odometry distance), e.g. "
                   "the scale the previous tunnel ended with (default 1: uncalibrated)")
    p.add_argument("--odometry-scale-sigma", type=_positive, default=0.05,
                   metavar="S", help="its standard deviation (default 0.05: a wheel "
                   "odometry within about 5 %%)")
    p.add_argument("--focal-length", type=_positive, metavar="PX", help="the camera's "
                   "focal length (px); with --sign-height each sign's box growth "
                   "measures the odometry's scale before the second sign (both known "
                   "to about 1 %%). Default: not known")
    p.add_argument("--sign-height", type=_positive, metavar="M", help="height of the "
                   "indicators (m), with --focal-length")
    p.add_argument("--side-error", type=_side_error, default=SIDE_ERROR, metavar="E",
                   help="while locking on (--start-chainage unknown, or after a "
                   "wrong start is dropped) on a map whose side column names both "
                   "walls, the wall each trajectory is seen on (its box drifts "
                   "towards it as it grows) helps: E is the probability that it is "
                   "read as the other wall (above 0, at most 0.5; default "
                   f"{SIDE_ERROR}); 'off': the side is not used")
    p.add_argument("--jobs", type=int, default=common.CPUS, help="reader threads that "
                   "decode frames ahead of the detector (with --model; default: the "
                   "number of CPUs)")
    common.add_output_arguments(p, quiet=True)
    common.add_colour_arguments(p)
    common.add_missing_frames_argument(p)
    p.set_defaults(func=_cmd_position)
