"""Command-line verbs of positioning: ``position`` and ``evaluate position``.

:mod:`tunnelsense.cli` calls :func:`register` with the ``train`` / ``detect`` /
``evaluate`` sub-parsers and :func:`register_top` with the top-level ones.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from tunnelsense.cli._common import add_output_arguments
from tunnelsense.io._output import input_files

__all__ = ["register", "register_top"]

_TABLES = ("positions.csv", "odometry.csv", "indicators.csv")


def _tables(args):
    """The odometry and map files (default: the tour's own) and every input."""
    tour = Path(args.tour)
    odometry = Path(args.odometry or tour / "odometry.csv")
    imap = Path(args.map or tour / "indicators.csv")
    inputs = [*input_files(tour), *(tour / n for n in _TABLES), odometry, imap]
    return odometry, imap, inputs


def _cmd_position(args) -> int:
    from tunnelsense._progress import Progress
    from tunnelsense.cli._common import load_cli_model, signing_key
    from tunnelsense.io import open_tour, read_mot_results
    from tunnelsense.io._output import atomic_write, check_output
    from tunnelsense.positioning import (
        TunnelPositioner,
        locate_online,
        read_indicator_map,
        read_odometry,
    )

    start = time.perf_counter()
    odometry, imap, inputs = _tables(args)
    inputs += [p for p in (args.model, args.results, args.key_file) if p]
    check_output(args.out, overwrite=args.force, inputs=inputs, what="--out")
    odo, positioner = read_odometry(odometry), TunnelPositioner(smooth=args.smooth)
    positioner.fit(read_indicator_map(imap))
    if args.results:
        positions, fixes = positioner.predict(read_mot_results(args.results), odo,
                                              return_fixes=True)
    else:
        model = load_cli_model(args.model, last_step="motion", command="train tunnel",
                               trust_pickle=args.trust_pickle, key=signing_key(args))
        positioner.set_params(max_gap=max(model.named_steps["tracks"].max_gap, 0))
        frames = open_tour(args.tour).frames
        bar = None if args.quiet else Progress(len(frames), "detecting and positioning")
        positions, fixes = locate_online(model, frames, odo, positioner, progress=bar)
    with atomic_write(args.out, "w") as f:
        positions.to_csv(f, index=False, lineterminator="\n")
    kept = int(fixes["accepted"].sum()) if len(fixes) else 0
    print(f"wrote {args.out}: {len(positions)} frames, {kept} of {len(fixes)} "
          f"trajectories gave a position fix ({time.perf_counter() - start:.1f} s)")
    return 0


def _cmd_evaluate_position(args) -> int:
    from tunnelsense.io._output import atomic_write, check_output
    from tunnelsense.positioning import (
        format_errors,
        plot_positioning,
        position_errors,
        read_indicator_map,
        read_odometry,
        read_positions,
    )

    odometry, imap, inputs = _tables(args)
    if args.draw:
        check_output(args.draw, overwrite=args.force, inputs=[*inputs, args.positions],
                     what="--draw")
    truth = read_positions(Path(args.tour) / "positions.csv")
    estimate = read_positions(args.positions, sigma=True)
    odo = read_odometry(odometry) if odometry.is_file() else None
    indicators = read_indicator_map(imap)
    errors = position_errors(truth, estimate, odo, indicators)
    if args.draw:
        import matplotlib.pyplot as plt

        ax = plot_positioning(truth, estimate, odo, indicator_map=indicators)
        with atomic_write(args.draw, "wb") as f:
            ax.figure.savefig(f, format="png", dpi=100)
        plt.close(ax.figure)
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
    add_output_arguments(p)
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
    source.add_argument("--model", help="model written by 'train tunnel' (detect online)")
    source.add_argument("--results", metavar="TXT", help="results file of 'detect tunnel'")
    p.add_argument("--trust-pickle", action="store_true", help="allow a .joblib model")
    p.add_argument("--key-file", metavar="FILE", help="key the .skops model is signed with")
    p.add_argument("--out", required=True, metavar="POS.csv", help="file to write")
    p.add_argument("--smooth", action="store_true", help="offline: smooth with every "
                   "fix (default: what was known at each frame)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_output_arguments(p)
    p.set_defaults(func=_cmd_position)
