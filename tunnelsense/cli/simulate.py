"""``tunnelsense simulate tunnel|street``: write a simulated tour or laser run."""

from __future__ import annotations

import time
from pathlib import Path

from tunnelsense._progress import Progress
from tunnelsense.datasets import (
    STREET_SCENARIOS,
    TUNNEL_SCENARIOS,
    make_street_scans,
    make_tunnel_tour,
)
from tunnelsense.io import write_run, write_tour


def _cmd_simulate(args) -> int:
    out = Path(args.outdir)
    if out.exists() and (not out.is_dir() or any(out.iterdir())) and not args.force:
        raise FileExistsError(f"{out}: exists and is not an empty folder; refusing to "
                              "write over it (pass --force to replace its files)")
    start = time.perf_counter()
    if args.kind == "tunnel":
        tour = make_tunnel_tour(args.frames, scenario=args.scenario, name=out.name,
                                random_state=args.seed,
                                progress=Progress(args.frames, "rendering frames"))
        write_tour(tour, out, progress=Progress(len(tour), "writing frames"))
        signs = tour.gt[tour.gt["class"] == 1]
        what = (f"{len(tour)} frames, scenario {args.scenario}, seed {args.seed}, "
                f"{signs['id'].nunique()} indicators in view, "
                f"{signs.loc[signs['bb_height'] >= 14, 'id'].nunique()} of them seen at "
                "least 14 px tall (what 'evaluate tunnel' counts)")
    else:
        run = make_street_scans(args.scans, scenario=args.scenario, name=out.name,
                                random_state=args.seed)
        write_run(run, out)
        counts = run.gt["label"].value_counts()
        what = (f"{len(run)} scans, scenario {args.scenario}, seed {args.seed}, "
                f"{counts.get('parked', 0)} parked and {counts.get('passing', 0)} "
                "passing vehicles")
    print(f"wrote {out}: {what} ({time.perf_counter() - start:.1f} s)")
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
