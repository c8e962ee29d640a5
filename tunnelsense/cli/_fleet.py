"""``detect tunnel|street`` over many tours at once (a fleet): the shared arguments."""

from __future__ import annotations

import sys
import time
from pathlib import Path

from tunnelsense.cli import _common as common
from tunnelsense.cli._extras import require_extra

__all__ = ["add_fleet_arguments", "fleet_sources", "run_fleet"]


def add_fleet_arguments(parser, what) -> None:
    """``--tours-from FILE`` and ``--dask-scheduler ADDRESS``."""
    parser.add_argument(
        "--tours-from", metavar="FILE", help=f"also detect the {what}s listed in FILE "
        "(one path a line, relative to the current folder, not to FILE; # "
        "comments). With more than one "
        f"{what}, --out is a folder that gets one results file per {what}, a "
        f"{what} a fleet finished before is skipped (a stopped run resumes), one "
        "that fails is reported at the end without stopping the others (exit "
        "status 1), and --jobs is the number detected at once")
    parser.add_argument(
        "--dask-scheduler", metavar="ADDRESS", help=f"with several {what}s: detect "
        f"them on this Dask cluster, one task per {what} (e.g. tcp://10.0.0.5:8786; "
        f"needs the 'distributed' extra); the workers must see the {what}s and --out "
        "at the same paths")


def fleet_sources(args) -> list[str] | None:
    """The sources of a fleet run, or None for a single one (left in ``args.source``)."""
    sources = list(args.source)
    if args.tours_from is not None:  # the fleet's modules only for a fleet
        from tunnelsense.fleet import read_tour_list

        sources += read_tour_list(args.tours_from)
    if not sources:
        raise ValueError("give the source to detect (or --tours-from FILE)")
    if len(sources) == 1 and args.tours_from is None:
        if args.dask_scheduler:
            raise ValueError("--dask-scheduler: runs several sources (one task each); "
                             "give more than one, or --tours-from FILE")
        args.source = sources[0]
        return None
    for option in ("draw", "draw_video", "resume"):
        if getattr(args, option, None):
            raise ValueError(f"--{option.replace('_', '-')}: of a single source; a "
                             "run over several resumes by itself (finished ones are "
                             "skipped)")
    return sources


def run_fleet(args, kind, sources, options, check=None) -> int:
    """Detect ``sources`` into the folder ``--out``; print a line per source.

    ``check(model)``, if given, refuses bad sources before any detection.
    """
    from tunnelsense.fleet import detect_tours, tour_outputs

    start = time.perf_counter()
    if args.jobs < 1:
        raise ValueError(f"--jobs: expected a whole number >= 1 ({kind}s detected at "
                         f"once); got {args.jobs}")
    if args.dask_scheduler:
        require_extra("distributed", "--dask-scheduler")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out}: with several sources --out is a folder; this "
                         "is a file")
    inputs = {Path(p).resolve() for p in (args.model, *common.key_files(args))}
    for source in sources:
        for path in tour_outputs(kind, source, out):
            if path.resolve() in inputs:
                raise ValueError(f"--out {out}: would write {path}, an input")
    model = common.cli_model(args, kind)
    if check is not None:
        check(model)
    bar = common.progress(args, len(sources), f"{kind} fleet", unit="tour")
    done = detect_tours(model, sources, out, kind=kind, n_jobs=args.jobs,
                        dask_scheduler=args.dask_scheduler, overwrite=args.force,
                        options=options,
                        progress=None if bar is None else lambda n, _: bar.update(n))
    if bar is not None:
        bar.close()
    skipped = sum(d["skipped"] for d in done)
    failed = [d for d in done if d["error"] is not None]
    for d in done:
        if d["error"] is not None:
            print(f"{d['source']}: failed (see below)")
            continue
        print(f"{d['source']}: " + ("finished before, skipped" if d["skipped"] else
                                    _summary(kind, d)) + f" -> {d['results']}")
    print(f"{len(done)} {'tours' if kind == 'tunnel' else 'runs'} into {out}: "
          f"{len(done) - skipped - len(failed)} detected, {skipped} skipped, "
          f"{len(failed)} failed ({time.perf_counter() - start:.1f} s)")
    for d in failed:
        print(f"tunnelsense: error: {d['source']}: {d['error']}", file=sys.stderr)
    return 1 if failed else 0


def _summary(kind, facts) -> str:
    if kind == "tunnel":
        return (f"{facts['detections']} detections on {facts['frames']} frames, "
                f"{facts['trajectories']} indicator trajectories")
    counts = facts["counts"]
    return f"{sum(counts.values())} objects" + "".join(
        f", {n} {label}" for label, n in sorted(counts.items()))
