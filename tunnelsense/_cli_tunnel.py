"""Command-line verbs of the FIR indicator detector: train, detect, evaluate, demo.

``tunnelsense._cli`` calls :func:`register` with the ``train`` / ``detect`` /
``evaluate`` sub-parsers and :func:`register_top` with the top-level ones.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np
import pandas as pd

from tunnelsense._cli_common import (
    add_model_arguments,
    add_output_arguments,
    check_draw_dir,
    input_files,
    load_cli_model,
    signing_key,
)
from tunnelsense._fitting import fit_pipeline

__all__ = [
    "CLUSTERS_HEADER",
    "CLUSTERS_SUFFIX",
    "detect_tour",
    "open_frames",
    "read_hypotheses",
    "register",
    "register_top",
    "score_results",
    "stream_detect",
]

#: ``detect`` writes every keypoint cluster beside ``RESULTS.txt`` as
#: ``RESULTS.clusters.csv`` (the negatives are needed for the false-alarm rate).
CLUSTERS_SUFFIX = ".clusters.csv"

#: The small grid ``train tunnel --search`` explores.
SEARCH_GRID = {
    "appearance__positive_weight": [1.0, 7.0],
    "motion__min_r": [0.9, 0.95],
    "motion__min_length": [5, 10],
}


def _progress(total, desc, **kwargs):
    from tunnelsense._progress import Progress

    return Progress(total, desc, **kwargs)


def _chunks(n, size=256):
    return [(lo, min(lo + size, n)) for lo in range(0, n, size)]


def detect_tour(model, frames, *, progress=None):
    """Run a fitted indicator pipeline over frames, stages 1-4 in chunks.

    Parameters
    ----------
    model : Pipeline
        From :func:`tunnelsense.tunnel.make_indicator_pipeline`, fitted.
    frames : FrameSequence
    progress : Progress or None

    Returns
    -------
    records : FrameSequence
        The output of ``model.predict(frames)``.
    """
    from tunnelsense import FrameSequence

    head, tail = model[:-2], model[-2:]
    parts = []
    done = 0
    for lo, hi in _chunks(len(frames)):
        parts.append(head.transform(frames[lo:hi]))
        done = hi
        if progress is not None:
            progress.update(done)
    return tail.predict(FrameSequence.concat(parts))


def _clusters_path(results) -> Path:
    results = Path(results)
    return results.with_name(results.stem + CLUSTERS_SUFFIX)


def read_hypotheses(results, tour_name) -> tuple[pd.DataFrame, bool]:
    """The hypotheses behind a results file: every cluster when its companion exists.

    The companion ``*.clusters.csv`` is read strictly (``indicator`` and
    ``trajectory_positive`` must be ``True`` or ``False``) and must agree with the
    results file: its positive-trajectory rows are exactly the detections of the
    results file, else it is stale (another run's) and refused.

    Returns
    -------
    hypotheses : DataFrame (see :data:`tunnelsense.metrics.HYPOTHESIS_COLUMNS`)
    complete : bool
        Whether the companion ``*.clusters.csv`` (every cluster) was found; otherwise
        the rows are the detections of the results file, all labelled indicator.
    """
    from tunnelsense.io import read_mot_results

    res = read_mot_results(results)
    detections = pd.DataFrame(
        {
            "tour": tour_name,
            "frame": res["frame"].astype(np.int64),
            "track_id": res["id"].astype(np.int64),
            "bb_left": res["bb_left"].astype(np.float64),
            "bb_top": res["bb_top"].astype(np.float64),
            "bb_width": res["bb_width"].astype(np.float64),
            "bb_height": res["bb_height"].astype(np.float64),
            "indicator": True,
            "trajectory_positive": True,
        }
    )
    companion = _clusters_path(results)
    if not companion.is_file():
        return detections, False
    h = _read_companion(companion)
    h.insert(0, "tour", tour_name)
    _check_companion(h, detections, companion, Path(results))
    return h, True


def _read_companion(path: Path) -> pd.DataFrame:
    """A ``*.clusters.csv`` file, every field checked (the message names the line)."""
    from tunnelsense.exceptions import InputFormatError

    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise InputFormatError(f"{path}: not UTF-8 text") from None
    lines = text.splitlines()
    if not lines or lines[0].strip() != CLUSTERS_HEADER:
        raise InputFormatError(
            f"{path}: expected the header {CLUSTERS_HEADER!r} on line 1"
        )
    columns = CLUSTERS_HEADER.split(",")
    rows = []
    for n, line in enumerate(lines[1:], 2):
        fields = line.split(",")
        if len(fields) != len(columns):
            raise InputFormatError(
                f"{path}, line {n}: expected {len(columns)} fields, got {len(fields)}"
            )
        try:
            frame, track = int(fields[0]), int(fields[1])
            box = [float(v) for v in fields[2:6]]
        except ValueError:
            raise InputFormatError(
                f"{path}, line {n}: frame and track_id must be integers and the box "
                "numbers"
            ) from None
        flags = []
        for name, v in zip(columns[6:], fields[6:], strict=True):
            if v not in ("True", "False"):
                raise InputFormatError(
                    f"{path}, line {n}: {name} is {v!r}, expected True or False"
                )
            flags.append(v == "True")
        if frame < 1 or not np.all(np.isfinite(box)):
            raise InputFormatError(
                f"{path}, line {n}: expected a frame >= 1 and a finite box"
            )
        rows.append((frame, track, *box, *flags))
    return pd.DataFrame(
        {c: pd.Series([r[i] for r in rows], dtype=d)
         for i, (c, d) in enumerate(zip(columns, [np.int64] * 2 + [np.float64] * 4
                                         + [bool] * 2, strict=True))}
    )


def _check_companion(h, detections, companion: Path, results: Path) -> None:
    """Refuse a companion whose positive trajectories are not the results file."""
    from tunnelsense.exceptions import InputFormatError

    keys = ["frame", "track_id", "bb_left", "bb_top", "bb_width", "bb_height"]

    def rows(table):
        return sorted(map(tuple, table[keys].to_numpy(np.float64).round(6).tolist()))

    if rows(h[h["trajectory_positive"]]) != rows(detections):
        raise InputFormatError(
            f"{companion}: does not match {results} (its positive trajectories are not "
            "the detections of the results file); is it from another run? Delete it "
            "to score the results file alone"
        )


def score_results(tour, results, *, min_height=14.0) -> dict:
    """Score a results file (and its companion, if any) against a tour's ground truth."""
    from tunnelsense.metrics import tunnel_scores

    hyp, complete = read_hypotheses(results, tour.name)
    gt = tour.gt.assign(tour=tour.name)
    scores = tunnel_scores(hyp, gt, min_height=min_height, complete=complete)
    return {**scores, "complete": complete}


def _percent(rate) -> str:
    """A rate as a percentage; ``None`` (0 of 0) as ``n/a``."""
    return "n/a (0 of 0)" if rate is None else f"{100 * rate:.1f} %"


def _format_report(scores, title=None) -> str:
    c, t = scores["cluster"], scores["trajectory"]
    far = (
        "n/a (no .clusters.csv companion: the negatives are unknown)"
        if not scores.get("complete", True)
        else _percent(c["false_alarm_rate"])
    )
    lines = [] if title is None else [title]
    lines += [
        "keypoint clusters (Table 1)",
        f"  total number        {c['total']}",
        f"  correctly labelled  {c['correct']}",
        f"  miss detections     {c['misses']}",
        f"  false alarms        {c['false_alarms']}",
        f"  detection rate      {_percent(c['detection_rate'])}",
        f"  false alarm rate    {far}",
        "trajectories",
        f"  indicators          {t['indicators']}",
        f"  detected            {t['detected']}",
        f"  false alarms        {t['false_alarms']}",
        f"  detection rate      {_percent(t['detection_rate'])}",
    ]
    return "\n".join(lines)


# --------------------------------------------------------------------------------------
# commands
# --------------------------------------------------------------------------------------
def _training_summary(tours, model, output, y, search=None) -> dict:
    """Tours, parameters and scores stored in a model file (``tunnelsense info``).

    ``output`` is the fitted model's output on the training frames.
    """
    from tunnelsense.metrics import indicator_scores

    params = {
        k: v
        for k, v in model.get_params(deep=True).items()
        if "__" in k and not hasattr(v, "get_params")
    }
    summary = {
        "detector": "tunnel indicator (make_indicator_pipeline)",
        "tours": [
            {
                "name": t.name,
                "frames": len(t),
                "indicators": int(t.gt.loc[t.gt["class"] == 1, "id"].nunique()),
                **{k: t.info[k] for k in ("scenario", "seed") if k in t.info},
            }
            for t in tours
        ],
        "parameters": params,
        # the band in use (learned from the training tours by default)
        "keypoint_band": [
            round(float(model.named_steps["keypoints"].low_), 2),
            round(float(model.named_steps["keypoints"].high_), 2),
        ],
        "training_scores": indicator_scores(output, y),
    }
    if search is not None:
        summary["search"] = {
            "grid": SEARCH_GRID,
            "best_parameters": search.best_params_,
            "best_score": float(search.best_score_),
            "scoring": "youden (GroupKFold over tours)",
        }
    return summary


def _decoded(X, n_threads, *, quiet):
    """The training frames decoded once, in ``n_threads`` reader threads.

    Every stage of a fit, and every fold of a search run in this process, then reads
    the decoded images; the memory is that of the training tours' pixels.
    """
    from tunnelsense import FrameSequence
    from tunnelsense._streaming import decode_ahead

    progress = _progress(len(X), "decoding frames", enabled=not quiet)
    frames = decode_ahead(X, n_threads=max(n_threads, 1), ahead=max(len(X), 1))
    out = [first] if (first := next(frames, None)) is not None else []
    # every frame is queued now; the model writer's import (about 1 s, in this
    # thread) overlaps the decoding threads, which run without the interpreter lock
    import skops.io  # noqa: F401
    for record in frames:
        out.append(record)
        progress.update(len(out))
    return FrameSequence(out)


def _search_backend(args):
    """Where the search's fits run: this machine (``--jobs``), or a Dask cluster."""
    import contextlib

    if not args.dask_scheduler:
        return contextlib.nullcontext()
    try:
        import joblib
        from distributed import Client
    except ImportError:
        raise ValueError(
            "--dask-scheduler needs Dask's distributed scheduler: pip install "
            "'tunnelsense[distributed]'"
        ) from None
    stack = contextlib.ExitStack()
    stack.enter_context(Client(args.dask_scheduler))
    stack.enter_context(joblib.parallel_config(backend="dask"))
    return stack


class _StepBar:
    """Progress of a pipeline fit, one step at a time (``fit_pipeline``)."""

    def __init__(self):
        self._bar = None

    def __call__(self, name, k, n):
        if self._bar is None:
            self._bar = _progress(n, "fitting", unit="step")
        self._bar.update(k)
        if name is not None:
            self._bar._bar.set_postfix_str(name)


def _cmd_train(args) -> int:
    from sklearn.model_selection import GridSearchCV, GroupKFold

    from tunnelsense import to_xy
    from tunnelsense.io import read_tour, save_model
    from tunnelsense.io._output import check_output
    from tunnelsense.metrics import make_tunnel_scorer
    from tunnelsense.tunnel import make_indicator_pipeline

    start = time.perf_counter()
    out = Path(args.model)
    if out.suffix.lower() not in (".skops", ".joblib", ".pkl", ".pickle"):
        raise ValueError(
            f"--model {out}: the extension chooses the format: .skops (safe, no code "
            "runs on load) or .joblib (pickle)"
        )
    inputs = [f for d in args.seqdirs for f in input_files(d)]
    inputs += [args.key_file] if args.key_file else []
    check_output(out, overwrite=args.force, inputs=inputs, what="--model")
    key = signing_key(args)
    tours = [read_tour(d) for d in args.seqdirs]
    if args.search and len(tours) < 2:
        raise ValueError("--search needs at least 2 tours (folds are whole tours)")
    X, y, groups = to_xy(tours)
    n_ind = sum(t.gt.loc[t.gt["class"] == 1, "id"].nunique() for t in tours)
    print(f"training on {len(tours)} tour(s), {len(X)} frames, {n_ind} indicators")
    X = _decoded(X, args.jobs, quiet=args.quiet)
    model = make_indicator_pipeline(random_state=args.seed, verifier__n_jobs=args.jobs)
    search = None
    if args.search:
        search = GridSearchCV(
            model,
            SEARCH_GRID,
            cv=GroupKFold(n_splits=min(len(tours), 3)),
            scoring=make_tunnel_scorer("youden"),
            error_score="raise",
            n_jobs=args.jobs,
            verbose=0 if args.quiet else 2,
        )
        n_candidates = int(np.prod([len(v) for v in SEARCH_GRID.values()]))
        n_fits = n_candidates * min(len(tours), 3)
        print(f"searching {n_candidates} settings x {min(len(tours), 3)} folds = "
              f"{n_fits} fits on {args.jobs} job(s), then the best on all tours")
        with _search_backend(args):
            search.fit(X, y, groups=groups)
        model = search.best_estimator_
        print(
            f"best parameters: {search.best_params_} (score {search.best_score_:.4f})"
        )
        output = model.predict(X)
    else:
        model, output = fit_pipeline(model, X, y,
                                     progress=None if args.quiet else _StepBar())
    kp = model.named_steps["keypoints"]
    print(f"keypoint band: [{kp.low_:.1f}, {kp.high_:.1f}] ({kp.band})")
    summary = _training_summary(tours, model, output, y, search)
    save_model(model, out, summary=summary, key=key, overwrite=args.force)
    kind = "safe skops" if out.suffix.lower() == ".skops" else "pickle"
    if key is not None:
        kind += ", signed"
    print(f"wrote {out} ({kind}; {time.perf_counter() - start:.1f} s)")
    return 0


def _load_model(args):
    return load_cli_model(
        args.model,
        last_step="motion",
        command="train tunnel",
        trust_pickle=args.trust_pickle,
        key=signing_key(args),
    )


#: A line of a MOTChallenge results file as ``detect tunnel`` writes it.
RESULT_LINE = r"\d+,-?\d+(?:,[^,]+){5},-1,-1,-1"


#: Header of the ``*.clusters.csv`` companion of a results file.
CLUSTERS_HEADER = (
    "frame,track_id,bb_left,bb_top,bb_width,bb_height,indicator,trajectory_positive"
)


def _result_lines(record):
    """MOTChallenge result lines of one released frame."""
    f = record.frame
    return [
        f"{f},{int(d[4])},{d[0]!r},{d[1]!r},{d[2]!r},{d[3]!r},{d[5]!r},-1,-1,-1"
        for d in np.asarray(record.payload["detections"], np.float64)
        .reshape(-1, 6)
        .tolist()
    ]


def _cluster_lines(record):
    """``*.clusters.csv`` lines of one released frame (every keypoint cluster)."""
    p = record.payload
    f = record.frame
    boxes = np.asarray(p["cluster_boxes"], np.float64).reshape(-1, 4).tolist()
    return [
        f"{f},{t},{b[0]!r},{b[1]!r},{b[2]!r},{b[3]!r},{bool(i)},{bool(tp)}"
        for b, t, i, tp in zip(
            boxes,
            np.asarray(p["track_ids"]).tolist(),
            np.asarray(p["indicator"]).tolist(),
            np.asarray(p["trajectory_positive"]).tolist(),
            strict=True,
        )
    ]


def open_frames(source):
    """The frames of a source, read lazily, and their number.

    A MOTChallenge or image folder gives records that decode their PNG on access; a
    video file is decoded sequentially (:func:`tunnelsense.io.iter_video`), records
    built on the fly.

    Returns
    -------
    frames : iterable of FrameRecord
    total : int
        Number of frames (for a video, as its header states).
    """
    import cv2

    from tunnelsense import FrameRecord
    from tunnelsense.io import iter_video, open_tour

    source = Path(source)
    if source.is_file():
        from tunnelsense.io._images import open_video

        capture = open_video(source)
        total = int(capture.get(cv2.CAP_PROP_FRAME_COUNT) or 0)
        capture.release()
        name = source.stem
        frames = (
            FrameRecord(name, i, image) for i, image in enumerate(iter_video(source), 1)
        )
        return frames, total
    tour = open_tour(source)
    return iter(tour.frames), len(tour)


def stream_detect(model, frames, *, progress=None, n_threads=0):
    """Run a fitted indicator pipeline online; yield the frames as they are final.

    Parameters
    ----------
    model : Pipeline
        From :func:`tunnelsense.tunnel.make_indicator_pipeline`, fitted.
    frames : iterable of FrameRecord
        In frame order within each tour.
    progress : Progress or None
    n_threads : int, default=0
        Reader threads decoding the next frames while this one is detected (0: none).

    Yields
    ------
    record : FrameRecord
        As ``model.predict`` gives them, in input order, each as soon as every
        trajectory through it has ended (in-memory images are released).
    """
    from threadpoolctl import threadpool_limits

    from tunnelsense._streaming import StreamingPipeline, decode_ahead

    stream = StreamingPipeline(model)
    if n_threads > 0:
        frames = decode_ahead(frames, n_threads=n_threads)
    # one frame's matrix products are small: BLAS threads would only contend with
    # the reader threads
    with threadpool_limits(limits=1, user_api="blas"):
        for k, record in enumerate(frames, 1):
            yield from stream.push(record)
            if progress is not None:
                progress.update(k)
        yield from stream.close()


def _cmd_detect(args) -> int:
    import sys

    from tunnelsense._streaming import ResultsWriter
    from tunnelsense.io._output import check_output

    start = time.perf_counter()
    out = Path(args.out)
    inputs = [args.model, *input_files(args.source),
              *([args.key_file] if args.key_file else [])]
    for path in (out, _clusters_path(out)):
        check_output(path, overwrite=args.force or args.resume, inputs=inputs,
                     what="--out")
    if args.draw is not None:
        check_draw_dir(args.draw, force=args.force, inputs=inputs)
    if args.draw_every < 1:
        raise ValueError(f"--draw-every must be at least 1; got {args.draw_every}")
    model = _load_model(args)
    frames, total = open_frames(args.source)
    results = ResultsWriter(out, resume=args.resume, overwrite=args.force,
                            line_pattern=RESULT_LINE)
    clusters = ResultsWriter(
        _clusters_path(out), header=CLUSTERS_HEADER, resume=args.resume,
        overwrite=args.force,
    )
    if args.resume and (results.resumed_lines or clusters.resumed_lines):
        print(
            f"resuming {out}: {results.resumed_lines} result lines kept, replaying the "
            "source to rebuild the trajectories (kept lines are checked, not rewritten)",
            file=sys.stderr,
        )
    images = {}
    if args.draw is not None and Path(args.source).is_file():
        # video frames are decoded once; keep each until its frame is released
        def keep_images(frames):
            for r in frames:
                images[r.frame] = r.image
                yield r

        frames = keep_images(frames)
    progress = None if args.quiet else _progress(total, "detecting")
    released = stream_detect(model, frames, progress=progress, n_threads=args.jobs)
    if args.draw is not None:
        import cv2

        from tunnelsense import FrameRecord
        from tunnelsense.tunnel._pipeline import draw_detections

        draw = Path(args.draw)
        draw.mkdir(parents=True, exist_ok=True)

        def with_images(records):
            for r in records:
                image = images.pop(r.frame, None)
                yield (
                    r
                    if image is None
                    else FrameRecord(r.tour, r.frame, image, r.payload)
                )

        pictures = draw_detections(with_images(released))
    else:
        pictures = ((r, None) for r in released)
    n_frames = n_det = 0
    ids = set()
    drawn = []
    with results, clusters:
        for r, pic in pictures:
            lines = _result_lines(r)
            for line in lines:
                results.write(line)
            for line in _cluster_lines(r):
                clusters.write(line)
            results.flush()
            clusters.flush()
            n_frames += 1
            n_det += len(lines)
            if lines:
                ids.update(int(d[4]) for d in r.payload["detections"])
            if pic is not None and (r.frame - 1) % args.draw_every == 0:
                target = draw / f"{r.frame:06d}.png"
                if not cv2.imwrite(str(target), pic):
                    raise OSError(f"{target}: OpenCV could not write the picture")
                drawn.append(target.stat().st_size)
    elapsed = time.perf_counter() - start
    if drawn:
        print(f"drew {len(drawn)} pictures ({sum(drawn) / 1e6:.1f} MB) in {draw}")
    print(
        f"wrote {out}: {n_det} detections on {n_frames} frames, {len(ids)} indicator "
        f"trajectories, and every keypoint cluster to {_clusters_path(out)} (for "
        f"'evaluate tunnel') ({elapsed:.1f} s)"
    )
    return 0


def _cmd_evaluate(args) -> int:
    from tunnelsense.io import read_tour

    tour = read_tour(args.seqdir)
    if not Path(args.results).is_file():
        raise FileNotFoundError(f"{args.results}: results file not found")
    scores = score_results(tour, args.results, min_height=args.min_height)
    if args.json:
        print(json.dumps(scores, indent=2))
    else:
        print(_format_report(scores, f"{tour.name}: {len(tour)} frames"))
    return 0


def _cmd_demo(args) -> int:
    from tunnelsense import to_xy
    from tunnelsense.datasets import make_tunnel_tour
    from tunnelsense.metrics import indicator_scores
    from tunnelsense.tunnel import make_indicator_pipeline

    start = time.perf_counter()
    n = args.frames
    print(f"simulating a training tour (light traffic, {n} frames, seed {args.seed})")
    train = make_tunnel_tour(n, scenario="light", random_state=args.seed,
                             progress=_progress(n, "rendering frames"))
    tests = []
    for k, scenario in enumerate(("light", "heavy", "curved"), 1):
        print(f"simulating a test tour ({scenario}, {n} frames, seed {args.seed + k})")
        tests.append(make_tunnel_tour(n, scenario=scenario, random_state=args.seed + k,
                                      progress=_progress(n, "rendering frames")))
    X, y, _ = to_xy([train])
    if not any(len(b) for b in train.boxes(min_height=args.min_height)):
        raise ValueError(
            f"--frames {n} is too short: the simulated training tour holds no indicator "
            f"at least {args.min_height:g} px tall to learn from (use --frames 300 or "
            "more)"
        )
    print("training the indicator detector")
    model = make_indicator_pipeline(random_state=args.seed).fit(X, y)
    all_scores = []
    for tour in tests:
        X, y, _ = to_xy([tour])
        records = detect_tour(
            model, X, progress=_progress(len(X), f"detecting {tour.name}")
        )
        scores = indicator_scores(records, y, min_height=args.min_height)
        all_scores.append(scores)
        print()
        print(_format_report(scores, f"{tour.name} ({tour.info.get('scenario')})"))
    total = sum(s["trajectory"]["indicators"] for s in all_scores)
    found = sum(s["trajectory"]["detected"] for s in all_scores)
    fa = sum(s["trajectory"]["false_alarms"] for s in all_scores)
    print(
        f"\n{found} of {total} indicators found, {fa} false-alarm trajectories "
        f"({time.perf_counter() - start:.0f} s)"
    )
    return 0


# --------------------------------------------------------------------------------------
# registration
# --------------------------------------------------------------------------------------
def register(verbs) -> None:
    """Add the ``tunnel`` kind to the ``train``, ``detect`` and ``evaluate`` verbs."""
    p = verbs["train"].add_parser(
        "tunnel", help="fit the indicator detector on MOTChallenge tour folders"
    )
    p.add_argument("seqdirs", nargs="+", metavar="SEQDIR", help="labelled tour folders")
    p.add_argument(
        "--model",
        required=True,
        help="where to write the model: .skops (safe, no code runs on load) or "
        ".joblib (pickle), by extension",
    )
    p.add_argument(
        "--search",
        action="store_true",
        help="grid-search the thresholds with GroupKFold over the tours (>= 2 tours)",
    )
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument(
        "--jobs",
        type=int,
        default=os.cpu_count() or 1,
        help="threads decoding the frames, and parallel fits of --search (default: "
        "the number of CPUs)",
    )
    p.add_argument(
        "--dask-scheduler",
        metavar="ADDRESS",
        help="run the fits of --search on this Dask cluster (e.g. "
        "tcp://10.0.0.5:8786; needs the 'distributed' extra); the workers must see "
        "the tour folders at the same paths",
    )
    p.add_argument("--quiet", action="store_true", help="no progress")
    add_output_arguments(p, signs=True)
    p.set_defaults(func=_cmd_train)

    p = verbs["detect"].add_parser("tunnel", help="find indicators in a tour or video")
    add_model_arguments(
        p, help_model="model written by 'train tunnel' (.skops, or a .joblib pickle "
        "with --trust-pickle)"
    )
    p.add_argument("source", help="MOTChallenge folder, image folder or video file")
    p.add_argument("--out", required=True, help="MOTChallenge results file to write")
    p.add_argument("--draw", metavar="DIR", help="also draw frames into DIR")
    p.add_argument(
        "--draw-every",
        type=int,
        default=1,
        metavar="N",
        help="with --draw, draw every N-th frame (default 1: every frame, about "
        "0.4 MB each at 640x480)",
    )
    p.add_argument(
        "--resume",
        action="store_true",
        help="continue an interrupted run: keep the lines of --out (and its "
        ".clusters.csv) and append the rest",
    )
    add_output_arguments(p)
    p.add_argument(
        "--jobs",
        type=int,
        default=os.cpu_count() or 1,
        help="reader threads that decode the next frames while the detector works "
        "(0: decode in the detector's thread; default: the number of CPUs)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_detect)

    p = verbs["evaluate"].add_parser(
        "tunnel", help="score indicator detections against a tour's ground truth"
    )
    p.add_argument("seqdir", help="labelled tour folder (gt/gt.txt)")
    p.add_argument("results", help="results file written by 'detect tunnel'")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.add_argument(
        "--min-height",
        type=float,
        default=14.0,
        help="indicator boxes at least this tall (px) count (default 14)",
    )
    p.set_defaults(func=_cmd_evaluate)


def register_top(sub) -> None:
    """Add the top-level ``demo`` command."""
    p = sub.add_parser(
        "demo",
        help="simulate tunnel tours, train the indicator detector, detect and report",
        description="Simulate a light-traffic training tour and three test tours "
        "(light traffic, heavy traffic, another camera in a curving tunnel), train the "
        "indicator detector on the first, detect on the others and print the paper's "
        "cluster and trajectory figures for each.",
    )
    p.add_argument(
        "--frames",
        type=int,
        default=900,
        help="frames per simulated tour (default 900)",
    )
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--min-height", type=float, default=14.0, help=argparse.SUPPRESS)
    p.set_defaults(func=_cmd_demo)
