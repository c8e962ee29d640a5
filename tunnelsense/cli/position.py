"""``tunnelsense position`` and ``tunnelsense evaluate position``."""

from __future__ import annotations

import json
import time
from pathlib import Path

from tunnelsense.cli import _common as common
from tunnelsense.cli._extras import require_extra

__all__ = ["register", "register_top"]


def _cmd_position(args) -> int:
    from tunnelsense.positioning import position_tour

    start = time.perf_counter()
    model = common.cli_model(args, "tunnel") if args.model else None
    positions, fixes = position_tour(
        args.tour, args.out, model=model, results=args.results,
        odometry=args.odometry, indicator_map=args.map, smooth=args.smooth,
        overwrite=args.force, inputs=[args.model, *common.key_files(args)],
        colour=common.colour(args),
        progress=lambda total, desc: common.progress(args, total, desc))
    kept = int(fixes["accepted"].sum()) if len(fixes) else 0
    print(f"wrote {args.out}: {len(positions)} frames, {kept} of {len(fixes)} "
          f"trajectories gave a position fix ({time.perf_counter() - start:.1f} s)")
    return 0


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
    p.add_argument("--smooth", action="store_true", help="offline: smooth with every "
                   "fix (default: what was known at each frame)")
    common.add_output_arguments(p, quiet=True)
    common.add_colour_arguments(p)
    p.set_defaults(func=_cmd_position)
