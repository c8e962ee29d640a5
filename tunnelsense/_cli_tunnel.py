"""Command-line verbs of the FIR indicator detector: train, detect, evaluate, demo.

``tunnelsense._cli`` calls :func:`register` with the ``train`` / ``detect`` /
``evaluate`` sub-parsers and :func:`register_top` with the top-level ones.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd

__all__ = [
    "CLUSTERS_SUFFIX",
    "detect_tour",
    "read_hypotheses",
    "register",
    "register_top",
    "score_results",
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


def _progress(total, desc):
    from tunnelsense._progress import Progress

    return Progress(total, desc)


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


def _results_table(records) -> pd.DataFrame:
    rows = []
    for r in records:
        for det in np.asarray(r.payload["detections"]).reshape(-1, 6):
            rows.append((r.frame, int(det[4]), *det[:4].tolist(), float(det[5])))
    return pd.DataFrame(
        rows,
        columns=["frame", "id", "bb_left", "bb_top", "bb_width", "bb_height", "conf"],
    ).astype({"frame": np.int64, "id": np.int64})


def _clusters_path(results) -> Path:
    results = Path(results)
    return results.with_name(results.stem + CLUSTERS_SUFFIX)


def read_hypotheses(results, tour_name) -> tuple[pd.DataFrame, bool]:
    """The hypotheses behind a results file: every cluster when its companion exists.

    Returns
    -------
    hypotheses : DataFrame (see :data:`tunnelsense.metrics.HYPOTHESIS_COLUMNS`)
    complete : bool
        Whether the companion ``*.clusters.csv`` (every cluster) was found; otherwise
        the rows are the detections of the results file, all labelled indicator.
    """
    from tunnelsense.io import read_mot_results

    companion = _clusters_path(results)
    if companion.is_file():
        h = pd.read_csv(companion)
        missing = {"frame", "track_id", "bb_left", "bb_top", "bb_width", "bb_height",
                   "indicator", "trajectory_positive"} - set(h.columns)
        if missing:
            raise ValueError(f"{companion}: missing columns {sorted(missing)}")
        h.insert(0, "tour", tour_name)
        h["indicator"] = h["indicator"].astype(bool)
        h["trajectory_positive"] = h["trajectory_positive"].astype(bool)
        return h, True
    res = read_mot_results(results)
    h = pd.DataFrame(
        {
            "tour": tour_name,
            "frame": res["frame"].astype(np.int64),
            "track_id": res["id"].astype(np.int64),
            "bb_left": res["bb_left"],
            "bb_top": res["bb_top"],
            "bb_width": res["bb_width"],
            "bb_height": res["bb_height"],
            "indicator": True,
            "trajectory_positive": True,
        }
    )
    return h, False


def score_results(tour, results, *, min_height=14.0) -> dict:
    """Score a results file (and its companion, if any) against a tour's ground truth."""
    from tunnelsense.metrics import tunnel_scores

    hyp, complete = read_hypotheses(results, tour.name)
    gt = tour.gt.assign(tour=tour.name)
    return tunnel_scores(hyp, gt, min_height=min_height, complete=complete)


def _format_report(scores, title=None) -> str:
    c, t = scores["cluster"], scores["trajectory"]
    far = "n/a" if c["false_alarm_rate"] is None else f"{100 * c['false_alarm_rate']:.1f} %"
    lines = [] if title is None else [title]
    lines += [
        "keypoint clusters (Table 1)",
        f"  total number        {c['total']}",
        f"  correctly labelled  {c['correct']}",
        f"  miss detections     {c['misses']}",
        f"  false alarms        {c['false_alarms']}",
        f"  detection rate      {100 * c['detection_rate']:.1f} %",
        f"  false alarm rate    {far}",
        "trajectories",
        f"  indicators          {t['indicators']}",
        f"  detected            {t['detected']}",
        f"  false alarms        {t['false_alarms']}",
        f"  detection rate      {100 * t['detection_rate']:.1f} %",
    ]
    return "\n".join(lines)


# --------------------------------------------------------------------------------------
# commands
# --------------------------------------------------------------------------------------
def _cmd_train(args) -> int:
    import joblib
    from sklearn.model_selection import GridSearchCV, GroupKFold

    from tunnelsense import to_xy
    from tunnelsense.io import read_tour
    from tunnelsense.metrics import make_tunnel_scorer
    from tunnelsense.tunnel import make_indicator_pipeline

    start = time.perf_counter()
    tours = [read_tour(d) for d in args.seqdirs]
    X, y, groups = to_xy(tours)
    n_ind = sum(t.gt.loc[t.gt["class"] == 1, "id"].nunique() for t in tours)
    print(f"training on {len(tours)} tour(s), {len(X)} frames, {n_ind} indicators")
    model = make_indicator_pipeline(random_state=args.seed)
    if args.search:
        if len(tours) < 2:
            raise ValueError("--search needs at least 2 tours (folds are whole tours)")
        search = GridSearchCV(
            model,
            SEARCH_GRID,
            cv=GroupKFold(n_splits=min(len(tours), 3)),
            scoring=make_tunnel_scorer("youden"),
            error_score="raise",
            n_jobs=args.jobs,
        )
        search.fit(X, y, groups=groups)
        model = search.best_estimator_
        print(f"best parameters: {search.best_params_} (score {search.best_score_:.4f})")
    else:
        model.fit(X, y)
    out = Path(args.model)
    out.parent.mkdir(parents=True, exist_ok=True)
    joblib.dump(model, out)
    print(f"wrote {out} ({time.perf_counter() - start:.1f} s)")
    return 0


def _load_model(path):
    import joblib

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: model file not found")
    model = joblib.load(path)
    if not hasattr(model, "steps") or model.steps[-1][0] != "motion":
        raise ValueError(f"{path}: not a model written by 'tunnelsense train tunnel'")
    return model


def _write_outputs(records, out, draw=None):
    from tunnelsense.io import write_mot_results
    from tunnelsense.metrics import hypotheses_from_records

    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    table = _results_table(records)
    write_mot_results(table, out)
    hyp = hypotheses_from_records(records).drop(columns="tour")
    hyp.to_csv(_clusters_path(out), index=False)
    if draw is not None:
        import cv2

        from tunnelsense.tunnel._pipeline import draw_detections

        draw = Path(draw)
        draw.mkdir(parents=True, exist_ok=True)
        bar = _progress(len(records), "drawing frames")
        for k, (r, pic) in enumerate(draw_detections(records), 1):
            cv2.imwrite(str(draw / f"{r.frame:06d}.png"), pic)
            bar.update(k)
    return table


def _cmd_detect(args) -> int:
    from tunnelsense.io import open_tour

    start = time.perf_counter()
    model = _load_model(args.model)
    tour = open_tour(args.source)
    records = detect_tour(model, tour.frames, progress=_progress(len(tour), "detecting"))
    table = _write_outputs(records, args.out, args.draw)
    elapsed = time.perf_counter() - start
    print(
        f"wrote {args.out}: {len(table)} detections on {table['frame'].nunique()} of "
        f"{len(tour)} frames, {table['id'].nunique()} indicator trajectories "
        f"({elapsed:.1f} s)"
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
    train = make_tunnel_tour(n, scenario="light", random_state=args.seed)
    tests = []
    for k, scenario in enumerate(("light", "heavy", "curved"), 1):
        print(f"simulating a test tour ({scenario}, {n} frames, seed {args.seed + k})")
        tests.append(make_tunnel_tour(n, scenario=scenario, random_state=args.seed + k))
    print("training the indicator detector")
    X, y, _ = to_xy([train])
    model = make_indicator_pipeline(random_state=args.seed).fit(X, y)
    all_scores = []
    for tour in tests:
        X, y, _ = to_xy([tour])
        records = detect_tour(model, X, progress=_progress(len(X), f"detecting {tour.name}"))
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
    p.add_argument("--model", required=True, help="where to write the model (joblib)")
    p.add_argument(
        "--search",
        action="store_true",
        help="grid-search the thresholds with GroupKFold over the tours (>= 2 tours)",
    )
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--jobs", type=int, default=1, help="parallel fits for --search")
    p.set_defaults(func=_cmd_train)

    p = verbs["detect"].add_parser("tunnel", help="find indicators in a tour or video")
    p.add_argument("--model", required=True, help="model written by 'train tunnel'")
    p.add_argument("source", help="MOTChallenge folder, image folder or video file")
    p.add_argument("--out", required=True, help="MOTChallenge results file to write")
    p.add_argument("--draw", metavar="DIR", help="also draw every frame into DIR")
    p.set_defaults(func=_cmd_detect)

    p = verbs["evaluate"].add_parser(
        "tunnel", help="score indicator detections against a tour's ground truth"
    )
    p.add_argument("seqdir", help="labelled tour folder (gt/gt.txt)")
    p.add_argument("results", help="results file written by 'detect tunnel'")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.add_argument(
        "--min-height", type=float, default=14.0,
        help="indicator boxes at least this tall (px) count (default 14)",
    )
    p.set_defaults(func=_cmd_evaluate)


def register_top(sub) -> None:
    """Add the top-level ``demo`` command."""
    p = sub.add_parser(
        "demo",
        help="simulate tunnel tours, train the indicator detector, detect and report",
    )
    p.add_argument(
        "--frames", type=int, default=900, help="frames per simulated tour (default 900)"
    )
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--min-height", type=float, default=14.0, help=argparse.SUPPRESS)
    p.set_defaults(func=_cmd_demo)

