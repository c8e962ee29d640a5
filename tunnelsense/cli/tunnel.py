"""``tunnelsense train|detect|evaluate tunnel`` and ``tunnelsense demo``."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from tunnelsense._deferred import end_imports, start_imports
from tunnelsense.cli import _common as common
from tunnelsense.cli import _fleet as fleet
from tunnelsense.cli._extras import require_extra
from tunnelsense.tunnel._search_grid import SEARCH_GRID


def _cmd_train(args) -> int:
    start_imports()  # before scikit-learn's import (the command only), as detect does
    from tunnelsense.io import read_tour
    from tunnelsense.io._sources import decode_tours

    start = time.perf_counter()
    if args.dask_scheduler:
        require_extra("distributed", "--dask-scheduler")
    if args.search and args.sample_rate is not None:
        raise ValueError("--sample-rate: --search fits every frame; give one or the other")
    key = common.check_model_output(args, args.seqdirs)
    tours = [read_tour(d, colour=common.colour(args), missing_frames=args.missing_frames)
             for d in args.seqdirs]
    # the reader threads decode while the fitting machinery (scikit-learn) imports
    rate = args.sample_rate
    decoding = decode_tours(tours, n_threads=args.jobs, sample_rate=rate)
    from tunnelsense.tunnel import fit_indicator_detector
    from tunnelsense.tunnel._reports import format_tours, format_training

    end_imports()  # everything is imported: the fit collects at the usual thresholds
    print(format_tours(tours))
    bars = common.stage_progress(args)
    model, summary = fit_indicator_detector(
        tours, search=args.search, random_state=args.seed, n_jobs=args.jobs,
        dask_scheduler=args.dask_scheduler, progress=bars, sample_rate=rate,
        _decoding=decoding)
    if bars is not None:
        bars.close()
    print(format_training(model, summary))
    common.save_cli_model(model, args, summary=summary, key=key, start=start)
    return 0


#: ``--readers``: what the reader threads run beside the decode (``stream_detect``'s
#: ``stages_in_readers``): nothing, the first stage (keypoints), every per-frame stage.
_READERS = {"decode": False, "keypoints": 1, "stages": True}


def _sample_rate(text):
    """``--sample-rate``: a positive number of frames per second, or 'all' (None)."""
    if text == "all":
        return None
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (value > 0 and value != float("inf")):
        raise argparse.ArgumentTypeError(
            f"expected a positive number of frames per second or 'all'; got {text!r}")
    return value


def _cmd_detect(args) -> int:
    start_imports()  # before scikit-learn's import (the command only)
    sources = fleet.fleet_sources(args)
    if sources is not None:
        return fleet.run_fleet(args, "tunnel", sources,
                               {"colour": common.colour(args),
                                "missing_frames": args.missing_frames,
                                "stages_in_readers": _READERS[args.readers]})
    from tunnelsense.io import clusters_path
    from tunnelsense.tunnel import detect_to_files
    from tunnelsense.tunnel._reports import format_detection

    start, out = time.perf_counter(), Path(args.out)
    common.check_detect_outputs(args, args.source, [out, clusters_path(out)])
    if args.draw_video:
        _check_video_output(args, out)
    facts = detect_to_files(
        common.cli_model(args, "tunnel"), args.source, out, resume=args.resume,
        overwrite=args.force, n_threads=args.jobs, draw=args.draw,
        draw_every=args.draw_every, draw_video=args.draw_video,
        progress=common.progress(args, 1, "detecting"), colour=common.colour(args),
        stages_in_readers=_READERS[args.readers], missing_frames=args.missing_frames)
    if facts["resumed_lines"]:
        print(f"resumed {out}: {facts['resumed_lines']} result lines kept (the source "
              "was replayed and they were checked, not rewritten)", file=sys.stderr)
    print(f"{format_detection(facts, out, draw=args.draw)} "
          f"({time.perf_counter() - start:.1f} s)")
    if args.draw_video:
        size = Path(args.draw_video).stat().st_size / 1e6
        print(f"drew {facts['video_frames']} frames into {args.draw_video} "
              f"({size:.1f} MB)")
    return 0


def _check_video_output(args, out) -> None:
    """Refuse a --draw-video file before any work: a .mp4/.avi name, not an input,
    not another output of the run, and an existing file only with --force."""
    from tunnelsense.io import clusters_path
    from tunnelsense.io._output import check_output, input_files
    from tunnelsense.io._video_out import check_video_path

    video = check_video_path(args.draw_video)
    others = [out, clusters_path(out)]
    if any(video.resolve() == p.resolve() for p in others):
        raise ValueError(f"--draw-video {video}: is also the results file or its "
                         ".clusters.csv")
    if args.draw and video.resolve().is_relative_to(Path(args.draw).resolve()):
        raise ValueError(f"--draw-video {video}: inside the --draw folder")
    check_output(video, overwrite=args.force, what="--draw-video",
                 inputs=[args.model, *input_files(args.source),
                         *filter(None, [args.key_file])])


def _cmd_evaluate(args) -> int:
    from tunnelsense.io import read_tour
    from tunnelsense.metrics import results_scores, tunnel_report

    tour = read_tour(args.seqdir, missing_frames=args.missing_frames)
    scores = results_scores(args.results, tour, min_height=args.min_height)
    print(json.dumps(scores, indent=2) if args.json
          else tunnel_report(scores, f"{tour.name}: {len(tour)} frames"))
    return 0


def _cmd_demo(args) -> int:
    from tunnelsense.tunnel._reports import run_demo

    for text in run_demo(args.frames, random_state=args.seed, min_height=args.min_height,
                         progress=lambda total, desc: common.progress(args, total, desc)):
        print(text)
    return 0


def register(verbs) -> None:
    """Add the ``tunnel`` kind to the ``train``, ``detect`` and ``evaluate`` verbs."""
    p = verbs["train"].add_parser(
        "tunnel", help="fit the indicator detector on MOTChallenge tour folders",
        description="Fit the indicator detector (make_indicator_pipeline) on labelled "
        "tours and write it as a model file.")
    p.add_argument("seqdirs", nargs="+", metavar="SEQDIR", help="labelled tour folders")
    p.add_argument("--search", action="store_true", help="grid-search "
                   f"{', '.join(SEARCH_GRID)} with GroupKFold over the tours (>= 2 tours)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--jobs", type=int, default=common.CPUS, help="threads decoding the "
                   "frames, and parallel fits of --search (default: the number of CPUs)")
    p.add_argument("--sample-rate", type=_sample_rate, default=None, metavar="HZ",
                   help="decode and fit only this many frames per second of each tour "
                   "(every k-th frame; faster, but the model changes), or 'all' "
                   "(default: every frame); --search always uses every frame")
    p.add_argument("--dask-scheduler", metavar="ADDRESS", help="run the fits of "
                   "--search on this Dask cluster (e.g. tcp://10.0.0.5:8786; needs the "
                   "'distributed' extra); the workers must see the tour folders at the "
                   "same paths")
    common.add_output_arguments(p, writes_model=True, quiet=True)
    common.add_colour_arguments(p)
    common.add_missing_frames_argument(p)
    p.set_defaults(func=_cmd_train)

    p = verbs["detect"].add_parser(
        "tunnel", help="find indicators in a tour or video",
        description="Find indicators in a tour or video, frame by frame; write "
        "MOTChallenge results and every keypoint cluster beside them (.clusters.csv).")
    common.add_model_arguments(p, help_model="model written by 'train tunnel' (.skops, "
                               "or a .joblib pickle with --trust-pickle)")
    p.add_argument("source", nargs="*", metavar="SOURCE", help="MOTChallenge folder, "
                   "image folder or video file (several: a fleet, see --tours-from)")
    p.add_argument("--out", required=True, help="MOTChallenge results file to write "
                   "(several sources: the folder of their results files)")
    p.add_argument("--draw", metavar="DIR", help="also draw frames into DIR (clusters, "
                   "trajectories, a legend and the frame number)")
    p.add_argument("--draw-every", type=int, default=1, metavar="N", help="with --draw, "
                   "draw every N-th frame (default 1: every frame, about 0.4 MB each at "
                   "640x480)")
    p.add_argument("--draw-video", metavar="FILE.mp4", help="also draw every frame "
                   "into one video file (.mp4, or .avi for Motion JPEG) at the source's "
                   "frame rate: a few MB where --draw writes hundreds; an existing file "
                   "is replaced only with --force")
    p.add_argument("--resume", action="store_true", help="continue an interrupted run: "
                   "keep the lines of --out (and its .clusters.csv) and append the rest")
    common.add_output_arguments(p, quiet=True)
    p.add_argument("--jobs", type=int, default=common.CPUS, help="reader threads that "
                   "decode the next frames while the detector works (0: decode in the "
                   "detector's thread; several sources: tours detected at once; "
                   "default: the number of CPUs)")
    p.add_argument("--readers", choices=tuple(_READERS), default="decode",
                   help="what the reader threads do: 'decode' the frames only, the "
                   "detector's thread running every stage; also find each frame's "
                   "'keypoints' (the first stage); or also run each frame through "
                   "the 'stages' that look at one frame alone (keypoints, verifier, "
                   "clusters, appearance), the detector's thread then only linking "
                   "the trajectories. The results are the same; the more the readers "
                   "do, the more the work is spread over idle cores, and the slower "
                   "it is when the cores are busy. No effect with --jobs 0 (default: "
                   "decode)")
    common.add_colour_arguments(p)
    common.add_missing_frames_argument(p)
    fleet.add_fleet_arguments(p, "tour")
    p.set_defaults(func=_cmd_detect)

    p = verbs["evaluate"].add_parser(
        "tunnel", help="score indicator detections against a tour's ground truth",
        description="Score a results file of 'detect tunnel' (and its .clusters.csv) "
        "with the paper's cluster and trajectory figures; n/a marks a rate of 0 of 0.")
    p.add_argument("seqdir", help="labelled tour folder (gt/gt.txt)")
    p.add_argument("results", help="results file written by 'detect tunnel'")
    p.add_argument("--json", action="store_true", help="print JSON (null for n/a)")
    p.add_argument("--min-height", type=float, default=14.0, help="indicator boxes at "
                   "least this tall (px) count (default 14)")
    common.add_missing_frames_argument(p)
    p.set_defaults(func=_cmd_evaluate)


def register_top(sub) -> None:
    """Add the top-level ``demo`` command."""
    p = sub.add_parser(
        "demo", help="simulate tunnel tours, train the indicator detector, detect and "
        "report", description="Simulate a light-traffic training tour and "
        "three test tours (light traffic, heavy traffic with trucks, another camera in "
        "a curving tunnel), train the indicator detector on the first, detect on the "
        "others and print the paper's cluster and trajectory figures for each. Nothing "
        "is written to disk.")
    p.add_argument("--frames", type=int, default=900,
                   help="frames per simulated tour (default 900)")
    p.add_argument("--seed", type=int, default=0, help="random seed of the training "
                   "tour; the test tours take the next three (default 0)")
    p.add_argument("--min-height", type=float, default=14.0, help=argparse.SUPPRESS)
    p.set_defaults(func=_cmd_demo)
