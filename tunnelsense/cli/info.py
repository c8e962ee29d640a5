"""``tunnelsense info``: what a tour, laser run or model file holds."""

from __future__ import annotations

import json
from pathlib import Path

from tunnelsense.cli import _common as common
from tunnelsense.cli._extras import require_extras_for_runs

_HELP = ("describe a tour (MOTChallenge folder, image folder, video), a laser run or "
         "a model file (.skops, .joblib)")


def _cmd_info(args) -> int:
    from tunnelsense.io import describe, format_description
    from tunnelsense.io._trust import PICKLE_SUFFIXES

    if Path(args.source).suffix.lower() in (".skops", *PICKLE_SUFFIXES):
        from tunnelsense.io import describe_model

        facts = describe_model(args.source, **common.verify_keys(args))
    else:
        require_extras_for_runs([args.source])
        facts = describe(args.source, mount_height=args.mount_height)
    print(json.dumps(facts, indent=2, sort_keys=True) if args.json
          else format_description(facts, verbose=args.verbose))
    return 0


def register_top(sub) -> None:
    """Add the ``info`` command."""
    p = sub.add_parser("info", help=_HELP, description=_HELP[0].upper() + _HELP[1:]
                       + "; a model file is described by its model card (versions, "
                       "training summary), never loaded. Its signature reads 'not "
                       "verified' unless the key is given (--verify-key).")
    p.add_argument("source", help="MOTChallenge folder, image folder, video file, laser "
                   "run folder (scans.npz + gt.csv), ROS bag, or model file (.skops, "
                   ".joblib)")
    p.add_argument("--json", action="store_true",
                   help="print every fact as JSON (numbers as numbers)")
    p.add_argument("--verbose", action="store_true",
                   help="also list the run information's records (such as every "
                   "simulated vehicle) and long tables")
    p.add_argument("--mount-height", type=float, metavar="METRES",
                   help="a ROS bag's laser height above the road, when the bag does "
                   "not say")
    common.add_verify_arguments(p)
    p.set_defaults(func=_cmd_info)
