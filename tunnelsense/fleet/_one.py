"""One tour's detection into its files, never leaving a partial file under a final name.

A tour's results are written under a temporary folder inside the output folder and,
once the tour is done and its files are on disk (fsync), linked to their final names
(the results file last), so a results file under its final name is always complete.
A companion file left by a run killed before it linked the results file (or a results
file, written by the same tour's detection in a worker that died before reporting it)
is taken if byte-identical to the new one, never replaced otherwise.  A hidden
``.finished-NAME`` file beside a results file holds its SHA-256, written just before
the results file is linked: a new fleet run skips such a tour.  A results file the
fleet did not finish (say, a stopped single detection's) is never taken as finished;
a final name that exists is never replaced (unless ``overwrite``).
"""

from __future__ import annotations

import filecmp
import hashlib
import os
import shutil
from pathlib import Path

__all__ = ["KINDS", "detect_one", "tour_outputs"]

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


def _check_kind(kind) -> None:
    if kind not in KINDS:
        raise ValueError(f"kind: expected one of {', '.join(KINDS)}; got {kind!r}")


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
                                missing_frames=options.get("missing_frames", "raise"),
                                stages_in_readers=options.get("stages_in_readers", False))
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
