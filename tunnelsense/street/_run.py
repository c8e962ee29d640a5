"""Training the detector on runs, and detecting objects in a run as it streams.

What ``tunnelsense train street`` and ``tunnelsense detect street`` do, callable from
Python: :func:`make_parking_pipeline` is the detector as a one-step pipeline,
:func:`train_detector` fits (optionally grid-searches) the detector on
labelled runs and summarizes the training; :func:`stream_objects` runs a fitted
pipeline over scans through :class:`~tunnelsense._streaming.StreamingPipeline` and
yields the object-table rows as they become final; :func:`write_objects` writes them
to a CSV file line by line, flushed, so that an interrupted run keeps them.
"""

from __future__ import annotations

from sklearn.pipeline import Pipeline

from tunnelsense._payload import FINISHED_OBJECTS
from tunnelsense._records import RUN_LABELS, to_xy
from tunnelsense._streaming import StreamingPipeline
from tunnelsense.io._writer import ResultsWriter
from tunnelsense.street._detector import OBJECT_COLUMNS, ScanClusterer

__all__ = [
    "OBJECT_CSV_COLUMNS",
    "SEARCH_GRID",
    "format_object",
    "format_objects_written",
    "format_runs",
    "format_training",
    "make_parking_pipeline",
    "stream_objects",
    "train_detector",
    "write_objects",
]

#: Scans fed into the stream at once by :func:`stream_objects` (the objects are the
#: same at any chunk size; larger chunks save per-call overhead).
SCAN_CHUNK = 64

#: Columns of the object CSV file (the object table without ``run``).
OBJECT_CSV_COLUMNS = OBJECT_COLUMNS[1:]

#: The thresholds :func:`train_detector` searches with ``search=True``.
SEARCH_GRID = {
    "cluster__cut": [0.4, 0.6, 0.8],
    "cluster__link_distance": [0.3, 0.5, 0.7],
}


def make_parking_pipeline(**params):
    """The street-parked vehicle detector as a one-step :class:`~sklearn.pipeline.Pipeline`.

    Parameters
    ----------
    **params
        Parameters of :class:`ScanClusterer` (``cut=0.6``, ``link_distance=0.5``, ...).

    Returns
    -------
    pipeline : Pipeline
        ``Pipeline([("cluster", ScanClusterer(**params))])``; grid-search its
        parameters as ``cluster__cut`` etc.

    Examples
    --------
    >>> from tunnelsense.street import make_parking_pipeline
    >>> make_parking_pipeline(cut=0.5).named_steps["cluster"].cut
    0.5
    """
    return Pipeline([("cluster", ScanClusterer(**params))])


def train_detector(runs, *, search=False, n_jobs=None, progress=None):
    """Fit the street detector on labelled runs; return it and a training summary.

    Parameters
    ----------
    runs : list of Run
        Labelled runs (as :func:`~tunnelsense.io.read_run` reads them, every scan
        carrying the run's ego speed).
    search : bool, default=False
        Grid-search :data:`SEARCH_GRID` for the best parked-vehicle F1, with
        ``GroupKFold`` over the runs (at least two).
    n_jobs : int, default=None
        Parallel fits of the search.
    progress : callable or None, default=None
        ``progress(stage, done, total)`` as the work goes on, ``stage`` naming it:
        the search's fits done (its refit included), or the fit; then the scoring
        of the training runs.

    Returns
    -------
    pipeline : Pipeline
        The fitted :func:`make_parking_pipeline`.
    summary : dict
        Runs, parameters, scores on the training runs and the search.

    Examples
    --------
    >>> from tunnelsense.datasets import make_street_scans
    >>> from tunnelsense.street import train_detector
    >>> model, summary = train_detector([make_street_scans(300, random_state=0)])
    >>> sorted(summary["training_scores"])
    ['parked', 'passing']
    """
    from sklearn.model_selection import GroupKFold

    from tunnelsense._fitting import search_ticks
    from tunnelsense._search import PrefixGridSearch
    from tunnelsense.metrics import (
        make_street_scorer,
        objects_from_targets,
        street_scores,
    )

    X, y, groups = to_xy(runs)
    pipeline = make_parking_pipeline()
    summary = {
        "detector": "street parked vehicles (make_parking_pipeline)",
        "runs": [{"name": run.name, "scans": len(run),
                  **{label: int((run.gt["label"] == label).sum())
                     for label in RUN_LABELS},
                  **{k: run.info[k] for k in ("scenario", "seed") if k in run.info}}
                 for run in runs],
        "scans": len(X),
    }
    if search:
        n_groups = len(set(groups))
        if n_groups < 2:
            raise ValueError("search needs at least two runs (the folds are runs)")
        folds = min(n_groups, 5)
        # GridSearchCV's result, with its fits counted as they end
        grid = PrefixGridSearch(pipeline, SEARCH_GRID, cv=GroupKFold(folds),
                                scoring=make_street_scorer("parked", "f1"),
                                n_jobs=n_jobs,
                                progress=search_ticks(progress, SEARCH_GRID, folds))
        grid.fit(X, y, groups=groups)
        pipeline = grid.best_estimator_
        summary["search"] = {"grid": SEARCH_GRID, "best_params": grid.best_params_,
                             "best_score": float(grid.best_score_),
                             "scoring": "parked F1 (GroupKFold over runs)",
                             "folds": folds}
    else:
        _report(progress, "fitting the detector", 0, 1)
        pipeline.fit(X, y)
        _report(progress, "fitting the detector", 1, 1)
    _report(progress, "scoring the training runs", 0, 1)
    summary["parameters"] = {k: v for k, v in pipeline.get_params(deep=True).items()
                             if "__" in k}
    summary["training_scores"] = street_scores(
        objects_from_targets(X, y), objects_from_targets(X, pipeline.predict(X)),
        zero_division=float("nan"))
    _report(progress, "scoring the training runs", 1, 1)
    return pipeline, summary


def _report(progress, stage, done, total):
    if progress is not None:
        progress(stage, done, total)


def _rate(value):
    return "n/a" if value is None or value != value else f"{100 * value:.1f} %"


def format_runs(runs, *, search=False, n_jobs=1) -> str:
    """What :func:`train_detector` is about to learn from: runs, scans, vehicles.

    Examples
    --------
    >>> from tunnelsense.datasets import make_street_scans
    >>> from tunnelsense.street import format_runs
    >>> format_runs([make_street_scans(300, random_state=0)])  # doctest: +ELLIPSIS
    'training on 1 run(s), 300 scans, ... parked, ... passing vehicles'
    """
    labels = {label: sum(int((run.gt["label"] == label).sum()) for run in runs)
              for label in ("parked", "passing")}
    text = (f"training on {len(runs)} run(s), {sum(map(len, runs))} scans, "
            f"{labels['parked']} parked, {labels['passing']} passing vehicles")
    if search:
        settings = 1
        for values in SEARCH_GRID.values():
            settings *= len(values)
        text += f"; searching {settings} settings on {n_jobs} job(s)"
    return text


def format_objects_written(name, counts, path, resumed=0) -> str:
    """What :func:`write_objects` wrote: objects per label, and lines kept on resume.

    Examples
    --------
    >>> from tunnelsense.street import format_objects_written
    >>> format_objects_written("run", {"passing": 1, "parked": 2}, "objects.csv")
    'run: 3 objects 2 parked, 1 passing -> objects.csv'
    """
    return (f"{name}: {sum(counts.values())} objects "
            + ", ".join(f"{c} {k}" for k, c in sorted(counts.items()))
            + f" -> {path}" + (f" (resumed after {resumed} rows)" if resumed else ""))


def format_training(summary) -> str:
    """The training summary of :func:`train_detector` as text: search and scores.

    Parameters
    ----------
    summary : dict
        The second value :func:`train_detector` returns.

    Returns
    -------
    text : str
        The best parameters of a search, then recall and precision per label on the
        training runs (``n/a`` where undefined).

    Examples
    --------
    >>> from tunnelsense.street import format_training
    >>> scores = {"recall": 0.5, "precision": float("nan"), "tp": 1, "fn": 1}
    >>> print(format_training({"training_scores": {"parked": scores}}))
    training parked: recall 50.0 %, precision n/a (1 of 2 found)
    """
    lines = []
    if "search" in summary:
        s = summary["search"]
        lines.append(f"best parameters: {s['best_params']} (parked F1 "
                     f"{s['best_score']:.3f}, {s['folds']} folds)")
    for label, s in summary["training_scores"].items():
        lines.append(f"training {label}: recall {_rate(s['recall'])}, precision "
                     f"{_rate(s['precision'])} ({s['tp']} of {s['tp'] + s['fn']} found)")
    return "\n".join(lines)


def stream_objects(pipeline, scans, *, all_objects=False):
    """Run a fitted pipeline over scans online; yield the objects as they finish.

    The scans go one at a time through
    :class:`~tunnelsense._streaming.StreamingPipeline`; the object-table rows come
    from the ``"finished_objects"`` payload of the records the detector releases, in
    id order, so memory follows the longest object in view, not the run's length.

    Parameters
    ----------
    pipeline : Pipeline or ScanClusterer
        Fitted; its last step a :class:`~tunnelsense.street.ScanClusterer`.
    scans : iterable of ScanRecord
        In increasing scan order per run.
    all_objects : bool, default=False
        Also yield objects labelled ``"roadside"`` and ``"other"``.

    Yields
    ------
    row : tuple
        The values of :data:`~tunnelsense.street.OBJECT_COLUMNS`.

    Examples
    --------
    >>> from tunnelsense.datasets import make_street_scans
    >>> from tunnelsense.street import make_parking_pipeline, stream_objects
    >>> run = make_street_scans(300, random_state=0)
    >>> model = make_parking_pipeline().fit(run.scans)
    >>> rows = list(stream_objects(model, run.scans))
    >>> rows == list(model[-1].detect(run.scans).itertuples(index=False, name=None))
    True
    """
    for record in StreamingPipeline(pipeline).run(scans, chunk=SCAN_CHUNK):
        for row in record.payload[FINISHED_OBJECTS]:
            if all_objects or row[4] in RUN_LABELS:
                yield row


def format_object(row):
    """One line of the object CSV file (:data:`OBJECT_CSV_COLUMNS`) from a row.

    Examples
    --------
    >>> from tunnelsense.street import format_object
    >>> format_object(("r", 1, 10, 39, "parked", 5.0, 2, 4.4, 1.45, 812, "car"))
    '1,10,39,parked,5.0000,2,4.4000,1.4500,812,car'
    """
    _run, oid, first, last, label, depth, region, length, top, n_points, kind = row
    return (f"{oid},{first},{last},{label},{depth:.4f},{region},{length:.4f},"
            f"{top:.4f},{n_points},{kind}")


def write_objects(pipeline, scans, path, *, all_objects=False, resume=False,
                  overwrite=False, progress=None):
    """Detect the objects of scans and write them to a CSV file as they finish.

    Every line is flushed as soon as its object is final.  An existing file is
    refused unless ``overwrite`` (replaced when complete) or ``resume`` (continued:
    the replayed lines are checked against it; see
    :class:`~tunnelsense.io.ResultsWriter`).

    Parameters
    ----------
    pipeline : Pipeline or ScanClusterer
        Fitted.
    scans : iterable of ScanRecord
    path : str or Path
        The object CSV file (header :data:`OBJECT_CSV_COLUMNS`).
    all_objects : bool, default=False
        Also write ``"roadside"`` and ``"other"`` objects.
    resume, overwrite : bool, default=False
    progress : Progress, default=None
        Updated with the number of scans read, closed at the end.

    Returns
    -------
    counts : dict
        Objects written per label.
    resumed : int
        Lines kept from an interrupted file.
    """
    counts = {}
    if progress is not None:
        scans = (progress.update(i) or scan for i, scan in enumerate(scans, 1))
    with ResultsWriter(path, header=",".join(OBJECT_CSV_COLUMNS), resume=resume,
                       overwrite=overwrite) as writer:
        for row in stream_objects(pipeline, scans, all_objects=all_objects):
            writer.write(format_object(row))
            writer.flush()
            counts[row[4]] = counts.get(row[4], 0) + 1
        resumed = writer.resumed_lines
    if progress is not None:
        progress.close()
    return counts, resumed
