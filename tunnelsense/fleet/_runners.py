"""Where a fleet's tasks run: here one after another, in loky worker processes, or on a
Dask cluster; a task that fails (or whose worker dies) gets an error record and the
others go on."""

from __future__ import annotations

import os
import uuid
from pathlib import Path

from tunnelsense.fleet._one import detect_one, tour_outputs


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

    The executor is the fleet's own, shut down when the fleet ends: loky's reusable
    executor is the one joblib's ``Parallel`` reuses too, and joblib expects its own
    kind there (a search run later in the same process would fail on ours).
    """
    from concurrent.futures import FIRST_COMPLETED, wait

    from joblib.externals.loky import ProcessPoolExecutor
    from joblib.externals.loky.process_executor import BrokenProcessPool

    queue = list(range(len(tasks)))[::-1]  # popped from the end: in order
    suspects = []
    env = _worker_env(n_workers)
    executor = ProcessPoolExecutor(max_workers=n_workers, env=env)
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
                executor.shutdown(wait=True, kill_workers=True)  # broken: none left
                executor = ProcessPoolExecutor(max_workers=n_workers, env=env)  # new
    except BaseException:
        executor.shutdown(wait=False, kill_workers=True)
        raise
    executor.shutdown(wait=True)


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
