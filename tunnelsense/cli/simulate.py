"""``tunnelsense simulate tunnel|street``: write a simulated tour or laser run."""

from __future__ import annotations

import time
from pathlib import Path

from tunnelsense.datasets._scenarios import STREET_SCENARIOS, TUNNEL_SCENARIOS


def _cmd_simulate(args) -> int:
    from tunnelsense._progress import Progress
    from tunnelsense.datasets._simulate import simulate_to_folder

    start = time.perf_counter()
    what = simulate_to_folder(
        args.kind, args.outdir, args.frames if args.kind == "tunnel" else args.scans,
        scenario=args.scenario, random_state=args.seed, overwrite=args.force,
        progress=Progress)
    print(f"wrote {Path(args.outdir)}: {what} ({time.perf_counter() - start:.1f} s)")
    return 0


def register_top(sub) -> None:
    """Add the ``simulate`` command."""
    p = sub.add_parser("simulate", help="write a simulated tour or laser run",
                       description="Write a simulated, labelled far-infrared tour or "
                       "laser run, for trying the detectors without data.")
    kinds = p.add_subparsers(dest="kind", metavar="KIND", required=True)
    for kind, text, unit, n, scenarios, help_scenario in (
        ("tunnel", "a far-infrared tunnel tour (MOTChallenge folder)", "frames", 1500,
         TUNNEL_SCENARIOS, "light traffic, heavy traffic with trucks, another "
         "camera in a curving tunnel, or a camera and tunnel drawn at random"),
        ("street", "a laser street run (scans.npz + gt.csv)", "scans", 4000,
         STREET_SCENARIOS, "the street's traffic and clutter"),
    ):
        k = kinds.add_parser(kind, help=text, description=f"Write {text}.")
        k.add_argument("outdir", help="the folder to write (new or empty)")
        k.add_argument(f"--{unit}", type=int, default=n, help=f"{unit} (default {n})")
        k.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
        k.add_argument("--scenario", default=scenarios[0], choices=scenarios,
                       help=f"{help_scenario} (default: {scenarios[0]})")
        k.add_argument("--force", action="store_true",
                       help="write into OUTDIR even if it exists and holds files")
    p.set_defaults(func=_cmd_simulate)
