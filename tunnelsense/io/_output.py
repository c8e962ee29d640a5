"""Writing outputs without destroying anything: the checks every writer makes.

* An existing file is never replaced unless the caller says so (``overwrite=True``,
  ``--force`` on the command line), and never when it is one of the command's own
  inputs (the model, the tour, the run).
* Nothing is written into a device folder (``/dev``, ``/proc``, ``/sys``) or onto
  something that is not a regular file.
* A file that replaces another is written beside it under a temporary name and
  renamed over it only when complete, so a failure leaves the old file as it was.
* An error from the operating system (disk full, permission denied) names the file.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

from tunnelsense.exceptions import OutputExistsError

__all__ = ["atomic_write", "check_output", "output_error"]

#: Folders of the operating system's devices and kernel tables: never written.
_DEVICE_ROOTS = (Path("/dev"), Path("/proc"), Path("/sys"))


def _is_device_path(path: Path) -> bool:
    resolved = path.resolve()
    return any(resolved.is_relative_to(root) for root in _DEVICE_ROOTS)


def check_output(path, *, overwrite=False, inputs=(), what="output") -> Path:
    """Check that ``path`` may be written; raise before anything is touched.

    Parameters
    ----------
    path : str or Path
        The file to write.
    overwrite : bool, default=False
        Whether an existing regular file may be replaced.
    inputs : iterable of str or Path, default=()
        Files (or folders, meaning every file in them) the command reads: never
        replaced, even with ``overwrite``.
    what : str, default="output"
        What the file is, for the message (e.g. ``"--out"``).

    Returns
    -------
    path : Path

    Raises
    ------
    OutputExistsError
        The file exists and ``overwrite`` is false, or it is one of ``inputs``.
    ValueError
        The path is in a device folder, or names a folder or another non-regular
        file.
    """
    path = Path(path)
    if _is_device_path(path):
        raise ValueError(f"{what} {path}: refusing to write into a device folder")
    if path.exists() and not path.is_file():
        raise ValueError(f"{what} {path}: exists and is not a regular file")
    target = path.resolve()
    for item in inputs:
        item = Path(item).resolve()
        if target == item or (item.is_dir() and target.is_relative_to(item)):
            raise OutputExistsError(
                f"{what} {path}: is an input of this command ({item}); refusing to "
                "write over it"
            )
    if path.exists() and not overwrite:
        raise OutputExistsError(
            f"{what} {path}: exists; refusing to overwrite it (pass --force, or "
            "overwrite=True, to replace it)"
        )
    return path


def output_error(path, exc: OSError) -> OSError:
    """The same operating-system error with the file named in its message."""
    reason = exc.strerror or str(exc)
    new = type(exc)(exc.errno, f"{path}: cannot write ({reason})")
    return new


def _file_mode(path: Path) -> int:
    """The mode of the file replaced, or what a new file gets under the umask."""
    try:
        return path.stat().st_mode & 0o777
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


@contextlib.contextmanager
def atomic_write(path, mode="wb"):
    """Open a temporary file beside ``path``; rename it to ``path`` when complete.

    On an exception inside the block the temporary file is removed and ``path`` is
    left as it was.  Errors of the operating system name ``path``.

    Parameters
    ----------
    path : str or Path
        The file to write.
    mode : {"wb", "w"}, default="wb"
        Binary or text (UTF-8, ``\\n`` line ends).

    Yields
    ------
    file : file object

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from tunnelsense.io._output import atomic_write
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.txt"
    >>> with atomic_write(path, "w") as f:
    ...     _ = f.write("complete\\n")
    >>> path.read_text()
    'complete\\n'
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp",
                                   dir=path.parent)
    except OSError as exc:
        raise output_error(path, exc) from None
    try:
        os.chmod(tmp, _file_mode(path))
        kwargs = {} if "b" in mode else {"encoding": "utf-8", "newline": "\n"}
        with os.fdopen(fd, mode, **kwargs) as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise output_error(path, exc) from None
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
