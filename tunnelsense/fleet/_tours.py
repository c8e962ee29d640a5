"""Detecting many tours or runs at once: locally in processes, or on a Dask cluster.

One task per tour (:mod:`tunnelsense.fleet._runners`), each written into the output
folder so that a results file under its final name is always complete
(:mod:`tunnelsense.fleet._one`).  A new run skips the tours a fleet finished and starts
the others afresh, so a run that was killed resumes where it stopped.
"""

from __future__ import annotations

from pathlib import Path

from tunnelsense.fleet._one import (
    KINDS,
    _check_kind,
    _finished,
    detect_one,
    tour_outputs,
)
from tunnelsense.fleet._runners import _run

__all__ = ["KINDS", "detect_one", "detect_tours", "read_tour_list", "tour_outputs"]


def read_tour_list(path) -> list[str]:
    """The tours named in a list file: one path a line; blank lines and ``#`` comments
    are skipped.  The paths are returned as written (a relative one is relative to
    the current folder, not to the list file's).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from tunnelsense.fleet import read_tour_list
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "tours.txt"
    >>> _ = f.write_text("# the March tours\\ntours/t01\\n\\ntours/t02\\n")
    >>> read_tour_list(f)
    ['tours/t01', 'tours/t02']
    """
    try:
        text = Path(path).read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise ValueError(f"{path}: expected a text file of tour paths, one a "
                         "line") from None
    tours = [s for s in (line.strip() for line in text.splitlines())
             if s and not s.startswith("#")]
    if not tours:
        raise ValueError(f"{path}: names no tour (expected one path a line)")
    return tours


def detect_tours(model, sources, out_dir, *, kind="tunnel", n_jobs=1,
                 dask_scheduler=None, overwrite=False, progress=None, options=None):
    """Detect every tour (or laser run) of ``sources``, writing results per tour.

    Parameters
    ----------
    model : Pipeline
        A fitted indicator pipeline (``kind="tunnel"``) or parking pipeline
        (``kind="street"``).
    sources : list of str or Path
        Tour folders, image folders or videos (tunnel); run folders or ROS bags
        (street).  Their names (without suffix) must differ: they name the results.
    out_dir : str or Path
        The folder of the results (created if missing): see :func:`tour_outputs`.
    kind : {"tunnel", "street"}, default="tunnel"
    n_jobs : int, default=1
        Tours detected at once, in worker processes (1: one after another, here).
    dask_scheduler : str or None, default=None
        Run one task per tour on the Dask cluster at this address instead (needs the
        ``distributed`` extra); its workers must see the tours and ``out_dir`` at the
        same paths.
    overwrite : bool, default=False
        Detect every tour again, replacing its results; by default a tour whose
        results file exists is skipped when a fleet finished it (an earlier run),
        else reported as failed, its file untouched.
    progress : callable or None, default=None
        ``progress(done, total)`` after each tour.
    options : dict or None, default=None
        Keyword arguments of each tour's detection: ``colour``, ``stages_in_readers``
        (tunnel); ``all_objects``, ``range_unit``, ``topic``, ``mount_height``,
        ``speed``, ``speed_topic`` (street).

    Returns
    -------
    list of dict
        Per source, in order: ``source``, ``results`` (path), ``skipped`` (bool),
        ``error`` (None, or why this tour failed: a tour that fails does not stop
        the others, and leaves no results file, so a new run detects it again) and
        the facts of its detection (tunnel: ``frames``, ``detections``,
        ``trajectories``; street: ``counts``).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from tunnelsense import make_parking_pipeline, to_xy
    >>> from tunnelsense.datasets import make_street_scans
    >>> from tunnelsense.fleet import detect_tours
    >>> from tunnelsense.io import write_run
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> X, y, _ = to_xy(make_street_scans(600, random_state=0))
    >>> model = make_parking_pipeline().fit(X, y)
    >>> runs = [write_run(make_street_scans(300, random_state=s), folder / f"run{s}")
    ...         for s in (1, 2)]
    >>> done = detect_tours(model, runs, folder / "out", kind="street")
    >>> [(d["results"].name, d["skipped"]) for d in done]
    [('run1.csv', False), ('run2.csv', False)]
    >>> [d["skipped"] for d in detect_tours(model, runs, folder / "out", kind="street")]
    [True, True]
    """
    _check_kind(kind)
    sources = [Path(s) for s in sources]
    if not sources:
        raise ValueError("sources: expected at least one tour; got none")
    if int(n_jobs) != n_jobs or n_jobs < 1:
        raise ValueError(f"n_jobs: expected a whole number >= 1; got {n_jobs!r}")
    out_dir = Path(out_dir)
    _check_names(kind, sources, out_dir)
    for source in sources:
        if not source.exists():
            raise FileNotFoundError(f"{source}: no such tour (file or folder)")
    if out_dir.exists() and not out_dir.is_dir():
        raise ValueError(f"out_dir {out_dir}: exists and is not a folder")
    out_dir.mkdir(parents=True, exist_ok=True)
    options = dict(options or {})
    results = [None] * len(sources)
    todo = []
    for i, source in enumerate(sources):
        final = tour_outputs(kind, source, out_dir)
        if not final[0].exists() or overwrite:
            todo.append(i)
            continue
        results[i] = {"source": source, "results": final[0], "skipped": True,
                      "error": None}
        if not _finished(final[0]):
            results[i].update(skipped=False, error=(
                f"{final[0]}: exists, but no fleet finished it (a single detection's, "
                "stopped midway?); not replaced: move it away, or detect again "
                "replacing it (--force)"))
    done = len(sources) - len(todo)
    if progress is not None:
        progress(done, len(sources))
    tasks = [(kind, sources[i], out_dir, overwrite, options) for i in todo]
    for k, facts in _run(model, tasks, n_jobs, dask_scheduler):
        results[todo[k]] = facts
        done += 1
        if progress is not None:
            progress(done, len(sources))
    return results


def _check_names(kind, sources, out_dir) -> None:
    seen = {}
    for source in sources:
        name = tour_outputs(kind, source, out_dir)[0].name
        if name in seen:
            raise ValueError(f"sources: {seen[name]} and {source} would both write "
                             f"{out_dir / name}; give tours different names")
        seen[name] = source
