"""Detecting many tours or runs at once: locally in processes, or on a Dask cluster.

One task per tour.  Each task writes its results under a temporary folder inside the
output folder and, once the tour is done and its files are on disk (fsync), links
them to their final names (the results file last), so a results file under its final
name is always complete.  A companion file left by a run killed before it linked the
results file (or a results file, written by the same tour's detection in a worker
that died before reporting it) is taken if byte-identical to the new one, never
replaced otherwise.  A
new run skips a tour whose results file exists and is recorded as finished (a hidden
``.finished-NAME`` file beside it holds the results file's SHA-256, written just
before the results file is linked), and starts the others afresh, so a run that was
killed resumes where it stopped.  A results file the fleet did not finish (say, a
stopped single detection's) is reported, never taken as finished; a final name that
exists is never replaced (unless ``overwrite``).
"""

from __future__ import annotations

import filecmp
import hashlib
import os
import shutil
import uuid
from pathlib import Path

__all__ = ["KINDS", "detect_one", "detect_tours", "read_tour_list", "tour_outputs"]

#: The detectors a fleet runs, and the files each tour gets (relative to ``out_dir``).
KINDS = ("tunnel", "street")

_PARTIAL = ".partial-"


def tour_outputs(kind, source, out_dir) -> list[Path]:
    """The files a tour's detection writes in ``out_dir``, the results file first.

    Parameters
    ----------
    kind : {"tunnel", "street"}
    source : str or Path
        The tour (tunnel) or laser run (street).
    out_dir : str or Path

    Returns
    -------
    list of Path
        ``NAME.txt`` and ``NAME.clusters.csv`` for a tour; ``NAME.csv`` for a run,
        ``NAME`` being the source's folder name (whole, dots included) or its file
        name without the suffix.

    Examples
    --------
    >>> from tunnelsense.fleet import tour_outputs
    >>> [p.name for p in tour_outputs("tunnel", "tours/t01", "out")]
    ['t01.txt', 't01.clusters.csv']
    >>> [p.name for p in tour_outputs("street", "runs/r7.bag", "out")]
    ['r7.csv']
    """
    _check_kind(kind)
    path = Path(source).resolve()  # "." and "tours/t01/" name their folder
    name = path.name if path.is_dir() else path.stem  # "2024.03.01/" keeps its dots
    if not name:
        raise ValueError(f"{source}: a tour needs a name (its file or folder name "
                         "names its results); got the root folder")
    out_dir = Path(out_dir)
    if kind == "tunnel":
        return [out_dir / f"{name}.txt", out_dir / f"{name}.clusters.csv"]
    return [out_dir / f"{name}.csv"]


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


def _check_kind(kind) -> None:
    if kind not in KINDS:
        raise ValueError(f"kind: expected one of {', '.join(KINDS)}; got {kind!r}")


def _check_names(kind, sources, out_dir) -> None:
    seen = {}
    for source in sources:
        name = tour_outputs(kind, source, out_dir)[0].name
        if name in seen:
            raise ValueError(f"sources: {seen[name]} and {source} would both write "
                             f"{out_dir / name}; give tours different names")
        seen[name] = source


def _run(model, tasks, n_jobs, dask_scheduler):
    """``(k, facts)`` of each task ``k`` as it finishes (in any order)."""
    if not tasks:
        return
    if dask_scheduler is not None:
        yield from _run_dask(model, tasks, dask_scheduler)
    elif n_jobs == 1 or len(tasks) == 1:
        for k, task in enumerate(tasks):
            yield k, _detect_or_fail(model, *task)
    else:
        yield from _run_processes(model, tasks, min(n_jobs, len(tasks)))


def _run_processes(model, tasks, n_workers):
    """The tasks in ``n_workers`` loky processes, at most one queued per worker.

    A worker killed hard (a segmentation fault, the system's out-of-memory killer, a
    signal) breaks loky's executor, and every task then in flight fails with it.
    Those tasks are run again one at a time in a new executor: a task whose worker
    dies while it runs alone is the one that kills it, and gets an error record; the
    others go on as before.  On any exception here (an interrupt, SIGTERM raised as
    one) the workers are killed, not left running.
    """
    from concurrent.futures import FIRST_COMPLETED, wait

    from joblib.externals.loky import get_reusable_executor
    from joblib.externals.loky.process_executor import BrokenProcessPool

    queue = list(range(len(tasks)))[::-1]  # popped from the end: in order
    suspects = []
    env = _worker_env(n_workers)
    executor = get_reusable_executor(max_workers=n_workers, env=env)
    running = {}  # future -> (task index, whether it runs alone)
    try:
        while queue or suspects or running:
            if suspects and not running:
                k = suspects.pop(0)
                running[executor.submit(_worker_detect_one, model, *tasks[k])] = (k, True)
            while not suspects and queue and len(running) < n_workers:
                k = queue.pop()
                running[executor.submit(_worker_detect_one, model, *tasks[k])] = (k, False)
            done, _ = wait(running, return_when=FIRST_COMPLETED)
            broken = False
            for future in done:
                k, alone = running.pop(future)
                try:
                    yield k, future.result()
                except BrokenProcessPool as exc:
                    broken = True
                    if alone:
                        yield k, _died(tasks[k], exc)
                    else:
                        suspects.append(k)
            if broken:  # the tasks still in flight fail with the executor
                for future, (k, _) in running.items():
                    try:
                        yield k, future.result()
                    except BrokenProcessPool:
                        suspects.append(k)
                running.clear()
                suspects.sort()
                executor = get_reusable_executor(max_workers=n_workers, env=env)  # new
    except BaseException:
        executor.shutdown(wait=False, kill_workers=True)
        raise


#: The thread-pool variables joblib sets for its worker processes.
_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS", "NUMBA_NUM_THREADS",
                "NUMEXPR_NUM_THREADS")


def _worker_env(n_workers):
    """The worker processes' thread pools, as joblib's ``Parallel`` sets them: the
    CPUs shared among the workers, unless the environment says otherwise."""
    from joblib.externals.loky import cpu_count

    share = str(max(cpu_count() // n_workers, 1))
    env = {var: os.environ.get(var, share) for var in _THREAD_VARS}
    env.setdefault("ENABLE_IPC", os.environ.get("ENABLE_IPC", "1"))
    return env


def _died(task, exc):
    """The error record of a task whose worker process died while detecting it."""
    kind, source, out_dir = task[:3]
    reason = " ".join(str(exc).split())
    return {"source": Path(source), "skipped": False, "results":
            tour_outputs(kind, source, out_dir)[0],
            "error": f"the worker process detecting it died ({type(exc).__name__}: "
                     f"{reason}); the other tours went on, and a new run detects "
                     "this one again"}


def _run_dask(model, tasks, address):
    """The tasks on a Dask cluster, one each; a task that ends as ``KilledWorker``
    (its worker died, and the worker the scheduler tried next) may have been beside
    the one that kills them: those run again one at a time once the others are done,
    and one whose worker dies while it runs alone gets an error record."""
    try:
        from distributed import Client
    except ImportError:
        raise ImportError("detecting on a Dask cluster needs distributed: pip install "
                          "'tunnelsense[distributed]'", name="distributed") from None
    from distributed import as_completed

    with Client(address) as client:
        # the model (about 0.1 MB) goes with every task rather than scattered: data
        # scattered to workers that died is lost, and the tasks needing it cancelled
        def submit(k):
            return client.submit(_worker_detect_one, model, *tasks[k], pure=False,
                                 key=f"detect-{Path(tasks[k][1]).name}-{uuid.uuid4()}")

        futures = {submit(k): k for k in range(len(tasks))}
        suspects = []
        for future in as_completed(futures):  # the cluster runs them all meanwhile
            k = futures.pop(future)
            try:
                facts = future.result()
            except Exception as exc:  # noqa: BLE001 -- reported per tour
                if type(exc).__name__ == "KilledWorker":
                    suspects.append(k)
                else:
                    facts = _failed(tasks[k], exc)
            # released: a worker that dies later does not make the cluster detect
            # this tour again
            future.release()
            if k not in suspects:
                yield k, facts
        for k in sorted(suspects):
            future = submit(k)
            try:
                facts = future.result()
            except Exception as exc:  # noqa: BLE001 -- reported per tour
                facts = (_died if type(exc).__name__ == "KilledWorker"
                         else _failed)(tasks[k], exc)
            future.release()
            yield k, facts


def _worker_detect_one(model, kind, source, out_dir, overwrite, options):
    """:func:`detect_one` in a worker process, the detector's modules imported first.

    loky measures a worker's memory after its first task and restarts a worker whose
    memory grew by more than 300 MB since; the modules a detection imports (lazily)
    must all be in by the end of the first task, whatever that task did.
    """
    _import_detector(kind)
    if Path(source).name in (options or {}).get(_KILL_WORKER, ()):
        # test-only: this worker dies as a segmentation fault or the system's
        # out-of-memory killer would end it (no exception, no clean-up)
        import signal

        os.kill(os.getpid(), signal.SIGKILL)
    return _detect_or_fail(model, kind, source, out_dir, overwrite, options)


#: An ``options`` key for tests only: tour names whose worker process is killed.
_KILL_WORKER = "_kill_worker_on"


def _detect_or_fail(model, kind, source, out_dir, overwrite, options):
    """:func:`detect_one`, or the record of its failure (the other tours go on)."""
    try:
        return detect_one(model, kind, source, out_dir, overwrite, options)
    except Exception as exc:  # noqa: BLE001 -- reported per tour by the caller
        return _failed((kind, source, out_dir), exc)


def _failed(task, exc):
    """The error record of a task that raised ``exc``."""
    kind, source, out_dir = task[:3]
    reason = (str(exc) if isinstance(exc, (ValueError, OSError))
              else f"{type(exc).__name__}: {exc}")
    return {"source": Path(source), "skipped": False, "error": reason,
            "results": tour_outputs(kind, source, out_dir)[0]}


def _import_detector(kind) -> None:
    """Import every module a detection of ``kind`` uses."""
    import importlib

    for name in _DETECTOR_MODULES[kind]:
        importlib.import_module(name)


#: The modules a detection imports, by kind (the estimators come with the model).
_DETECTOR_MODULES = {
    "tunnel": ("tunnelsense.tunnel._detect", "tunnelsense.tunnel._pipeline",
               "tunnelsense.io._sources", "tunnelsense.io._results"),
    "street": ("tunnelsense.street._run", "tunnelsense.street._detector",
               "tunnelsense.io._laser", "tunnelsense.io._rosbag"),
}


def detect_one(model, kind, source, out_dir, overwrite=False, options=None):
    """Detect one tour into ``out_dir``: written under a temporary folder, then moved
    to the final names (results file last); see :func:`detect_tours`."""
    source, out_dir = Path(source), Path(out_dir)
    final = tour_outputs(kind, source, out_dir)
    work = out_dir / f"{_PARTIAL}{final[0].name}"
    if work.exists():  # left by a run that was stopped: ours, started afresh
        shutil.rmtree(work)
    work.mkdir()
    try:
        facts = _detect_into(model, kind, source, work / final[0].name, options or {})
        for path in final:  # on disk before any is linked (as atomic_write does)
            _fsync(work / path.name)
        # The results file last, once its companions are on disk: it marks a finished
        # tour.  A companion left by a run killed before its results file was linked
        # is taken when it is byte-identical to the new one (never replaced).
        for path in final[1:]:
            _move(work / path.name, path, overwrite, identical_ok=True)
        mark = _mark(final[0])
        _write_mark(mark, work / final[0].name)
        _fsync(out_dir)
        try:
            # identical: the same tour detected again (Dask recomputes a result
            # lost with a worker that died after the tour was done)
            _move(work / final[0].name, final[0], overwrite, identical_ok=True)
        except BaseException:
            mark.unlink(missing_ok=True)
            raise
        _fsync(out_dir)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return {"source": source, "results": final[0], "skipped": False, "error": None,
            **facts}


def _detect_into(model, kind, source, out, options):
    if kind == "tunnel":
        from tunnelsense.tunnel._detect import detect_to_files

        facts = detect_to_files(model, source, out, n_threads=1,
                                colour=options.get("colour"),
                                stages_in_readers=bool(options.get("stages_in_readers")))
        return {k: facts[k] for k in ("frames", "detections", "trajectories")}
    from tunnelsense.io._laser import open_run_stream
    from tunnelsense.street._run import write_objects

    reading = {k: options[k] for k in ("range_unit", "topic", "mount_height", "speed",
                                       "speed_topic") if options.get(k) is not None}
    scans = open_run_stream(source, ground_truth=False, **reading)
    counts, _ = write_objects(model, scans, out,
                              all_objects=bool(options.get("all_objects")))
    return {"counts": counts}


_MARK = ".finished-"


def _mark(results) -> Path:
    """The file that says a fleet finished ``results``: the SHA-256 of its bytes."""
    return results.parent / f"{_MARK}{results.name}"


def _digest(path) -> str:
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def _write_mark(mark, results) -> None:
    with open(mark, "w", encoding="ascii") as f:
        f.write(_digest(results) + "\n")
        f.flush()
        os.fsync(f.fileno())


def _finished(results) -> bool:
    """Whether a fleet wrote ``results``, complete (not, say, a stopped single run)."""
    try:
        recorded = _mark(results).read_text(encoding="ascii").strip()
    except (OSError, UnicodeDecodeError):
        return False
    return recorded == _digest(results)


def _fsync(path) -> None:
    """Push a file's (or a folder's: its names) contents to the disk.

    A folder that cannot be opened for this (Windows) is left to the system.
    """
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        if Path(path).is_dir():
            return
        raise
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _move(src, dst, overwrite, identical_ok=False) -> None:
    """Rename ``src`` to ``dst``; an existing ``dst`` only replaced if ``overwrite``
    (or, with ``identical_ok``, kept when byte-identical to ``src``)."""
    if overwrite:
        os.replace(src, dst)
        return
    try:
        os.link(src, dst)  # fails, atomically, if dst exists
    except FileExistsError:
        if not (identical_ok and filecmp.cmp(src, dst, shallow=False)):
            raise FileExistsError(f"{dst}: exists (written meanwhile by another "
                                  "run?); not replaced") from None
    except OSError:  # a file system without hard links
        if dst.exists():
            if identical_ok and filecmp.cmp(src, dst, shallow=False):
                os.unlink(src)
                return
            raise FileExistsError(f"{dst}: exists; not replaced") from None
        os.rename(src, dst)
        return
    os.unlink(src)
