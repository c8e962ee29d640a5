"""The ``tunnelsense`` command."""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

from tunnelsense._version import __version__

__all__ = ["main"]


def _cmd_info(args) -> int:
    from tunnelsense.io import describe

    facts = describe(args.source)
    if args.json:
        print(json.dumps(facts, indent=2, sort_keys=True))
        return 0
    if facts["kind"] == "model":
        print(f"{facts['path']}: {facts['format']} model file, {facts['bytes']} bytes")
        for key in ("model", "created"):
            if key in facts:
                print(f"  {key}: {facts[key]}")
        for name, version in sorted(facts.get("versions", {}).items()):
            print(f"  trained under {name} {version}")
        for key, value in sorted(facts.get("summary", {}).items()):
            print(f"  {key}: {value}")
        if "note" in facts:
            print(f"  {facts['note']}")
        return 0
    if facts["kind"] == "tunnel":
        print(
            f"{facts['name']}: far-infrared tour, {facts['frames']} frames of "
            f"{facts['width']}x{facts['height']} px ({facts['dtype']}), "
            f"{facts['frame_rate']:g} fps"
        )
    else:
        rate = facts["scan_rate"]
        print(
            f"{facts['name']}: laser run, {facts['scans']} scans of {facts['beams']} "
            f"beams"
            + (f", {rate:g} scans/s" if rate else "")
            + f", mount height {facts['mount_height']:g} m"
        )
    objects = facts["objects"]
    print(
        "objects: "
        + (
            ", ".join(f"{n} {k}" for k, n in sorted(objects.items()))
            if objects
            else "none in the ground truth"
        )
    )
    for key, value in sorted(facts["info"].items()):
        print(f"  {key}: {value}")
    return 0


def _cmd_simulate(args) -> int:
    from tunnelsense._progress import Progress
    from tunnelsense.datasets import make_street_scans, make_tunnel_tour
    from tunnelsense.io import write_run, write_tour

    out = Path(args.outdir)
    if out.exists() and (not out.is_dir() or any(out.iterdir())) and not args.force:
        raise FileExistsError(
            f"{out}: exists and is not an empty folder; refusing to write over it "
            "(pass --force to replace its files)"
        )
    start = time.perf_counter()
    if args.kind == "tunnel":
        tour = make_tunnel_tour(
            args.frames,
            scenario=args.scenario,
            random_state=args.seed,
            name=out.name,
            progress=Progress(args.frames, "rendering frames"),
        )
        write_tour(tour, out, progress=Progress(len(tour), "writing frames"))
        signs = tour.gt[tour.gt["class"] == 1]
        n_ind = signs["id"].nunique()
        n_big = signs.loc[signs["bb_height"] >= 14, "id"].nunique()
        print(
            f"wrote {out}: {len(tour)} frames, scenario {args.scenario}, seed "
            f"{args.seed}, {n_ind} indicators in view, {n_big} of them seen at least "
            f"14 px tall (what 'evaluate tunnel' counts) "
            f"({time.perf_counter() - start:.1f} s)"
        )
    else:
        run = make_street_scans(
            args.scans, scenario=args.scenario, random_state=args.seed, name=out.name
        )
        write_run(run, out)
        counts = run.gt["label"].value_counts().to_dict()
        print(
            f"wrote {out}: {len(run)} scans, scenario {args.scenario}, seed "
            f"{args.seed}, {counts.get('parked', 0)} parked and "
            f"{counts.get('passing', 0)} passing vehicles "
            f"({time.perf_counter() - start:.1f} s)"
        )
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="tunnelsense",
        description="Find roadside landmarks in vehicle sensor data: emergency-telephone "
        "indicators in far-infrared tunnel video, street-parked vehicles in laser scans.",
    )
    parser.add_argument(
        "--version", action="version", version=f"tunnelsense {__version__}"
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser(
        "info", help="describe a tour folder, video, laser run or model file"
    )
    p.add_argument(
        "source",
        help="MOTChallenge folder, image folder, video file, "
        "laser run folder (scans.npz + gt.csv), or model file (.skops, .joblib)",
    )
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_info)

    p = sub.add_parser("simulate", help="write a simulated tour or laser run")
    kinds = p.add_subparsers(dest="kind", metavar="KIND", required=True)
    from tunnelsense.datasets import STREET_SCENARIOS, TUNNEL_SCENARIOS

    t = kinds.add_parser(
        "tunnel", help="a far-infrared tunnel tour (MOTChallenge folder)"
    )
    t.add_argument("outdir")
    t.add_argument("--frames", type=int, default=1500, help="frames (default 1500)")
    t.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    t.add_argument(
        "--scenario",
        default=TUNNEL_SCENARIOS[0] if TUNNEL_SCENARIOS else None,
        choices=TUNNEL_SCENARIOS or None,
        help="light traffic, heavy traffic with trucks, or another camera in a "
        "curving tunnel (default: light)",
    )
    s = kinds.add_parser("street", help="a laser street run (scans.npz + gt.csv)")
    s.add_argument("outdir")
    s.add_argument("--scans", type=int, default=4000, help="scans (default 4000)")
    s.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    s.add_argument(
        "--scenario",
        default=STREET_SCENARIOS[0] if STREET_SCENARIOS else None,
        choices=STREET_SCENARIOS or None,
        help="the street's traffic and clutter (default: sparse)",
    )
    for k in (t, s):
        k.add_argument(
            "--force",
            action="store_true",
            help="write into OUTDIR even if it exists and holds files",
        )
    p.set_defaults(func=_cmd_simulate)

    _register_methods(sub)
    return parser


def _register_methods(sub) -> None:
    """Let each detector add its ``train`` / ``detect`` / ``evaluate`` commands."""
    import importlib
    import importlib.util

    modules = [
        importlib.import_module(m)
        for m in ("tunnelsense._cli_tunnel", "tunnelsense._cli_street",
                  "tunnelsense._cli_position")
        if importlib.util.find_spec(m) is not None
    ]
    for module in modules:
        if hasattr(module, "register_top"):
            module.register_top(sub)
    if not modules:
        return
    verbs = {}
    for verb, text in (
        ("train", "fit a detector on labelled tours or runs"),
        ("detect", "run a fitted detector"),
        ("evaluate", "score detections against ground truth"),
    ):
        v = sub.add_parser(verb, help=text)
        verbs[verb] = v.add_subparsers(dest="kind", metavar="KIND", required=True)
    for module in modules:
        module.register(verbs)


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    try:
        return int(args.func(args) or 0)
    except BrokenPipeError:  # e.g. `tunnelsense info ... | head -1`: not an error
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # no second error when Python flushes
        return 0
    except (FileNotFoundError, ValueError, OSError) as exc:
        print(f"tunnelsense: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("tunnelsense: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # a defect, not bad input: one line, traceback on request
        if os.environ.get("TUNNELSENSE_DEBUG"):
            raise
        print(
            f"tunnelsense: internal error: {type(exc).__name__}: {exc} "
            "(set TUNNELSENSE_DEBUG=1 to see the traceback, and please report it)",
            file=sys.stderr,
        )
        return 3


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
