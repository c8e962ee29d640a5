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

__all__ = [
    "PICKLE_SUFFIXES",
    "atomic_write",
    "check_draw_dir",
    "check_model_path",
    "check_output",
    "input_files",
    "output_error",
]

#: Extensions of the pickle model files (``.skops`` is the safe format).
PICKLE_SUFFIXES = (".joblib", ".pkl", ".pickle")

#: Folders of the operating system's devices and kernel tables: never written.
_DEVICE_ROOTS = (Path("/dev"), Path("/proc"), Path("/sys"))


def _is_device_path(path: Path) -> bool:
    resolved = path.resolve()
    return any(resolved.is_relative_to(root) for root in _DEVICE_ROOTS)


def _refuse_inputs(path, inputs, what, *, folder=False) -> None:
    """Raise when ``path`` is one of ``inputs`` or inside an input folder.

    A picture folder (``folder=True``) may not be inside an input folder, nor hold an
    input file anywhere below it.
    """
    target = path.resolve()
    for item in map(Path, filter(None, inputs)):
        item = item.resolve()
        if target == item or ((folder or item.is_dir()) and target.is_relative_to(item)):
            raise OutputExistsError(
                f"{what} {path}: is (or is inside) an input of this command ({item}); "
                "refusing to write over it"
            )
        if folder and item.is_relative_to(target):
            raise OutputExistsError(
                f"{what} {path}: the folder holds an input of this command ({item}); "
                "refusing to draw into it"
            )


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
    _refuse_inputs(path, inputs, what)
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


def input_files(source) -> list[Path]:
    """The files (and folders) a command reads from a tour, video or laser run.

    An output is never written over any of them, even with ``--force``.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from tunnelsense.io._output import input_files
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> (folder / "gt").mkdir()
    >>> [p.name for p in input_files(folder)]
    ['gt']
    """
    source = Path(source)
    from tunnelsense.io._rosbag import is_bag  # numpy: only when a run is read

    if not source.is_dir() or is_bag(source):
        return [source]  # a file, or a ROS 2 bag folder: every file in it
    names = ["seqinfo.ini", "gt", "img1", "scans.npz", "gt.csv", "metadata.yaml"]
    names.append(_image_dir(source / "seqinfo.ini"))
    present = [source / n for n in names if n and (source / n).exists()]
    return present or [source]  # a plain image folder: every file in it


def _image_dir(seqinfo) -> str | None:
    """The ``imDir`` a ``seqinfo.ini`` names (its frames), if it can be read."""
    import configparser  # only here: every command that writes imports this module

    parser = configparser.ConfigParser(interpolation=None)
    try:
        parser.read(seqinfo, encoding="utf-8")
        return parser.get("Sequence", "imDir", fallback=None)
    except (configparser.Error, UnicodeDecodeError, OSError):
        return None


def check_draw_dir(path, *, force, inputs=(), outputs=()) -> Path:
    """A folder for pictures: new or empty, or ``force`` to draw over its files.

    Never a device folder, never one of the command's inputs, inside one or holding
    one, even with ``force``; and none of the command's other ``outputs`` (its
    results files) may be inside it, where a picture could take its name.

    Raises
    ------
    ValueError
        A device folder, or a path that is not a folder.
    OutputExistsError
        A folder that holds files (without ``force``), or one of ``inputs``.
    """
    path = Path(path)
    if _is_device_path(path):
        raise ValueError(f"--draw {path}: refusing to write into a device folder")
    if path.exists() and not path.is_dir():
        raise ValueError(f"--draw {path}: exists and is not a folder")
    _refuse_inputs(path, inputs, "--draw", folder=True)
    for output in map(Path, outputs):
        if output.resolve().is_relative_to(path.resolve()):
            raise OutputExistsError(
                f"--draw {path}: the output {output} would be inside the picture "
                "folder, where a picture may take its name; write it elsewhere"
            )
    if path.is_dir() and any(path.iterdir()) and not force:
        raise OutputExistsError(
            f"--draw {path}: the folder is not empty; refusing to draw over its files "
            "(pass --force)"
        )
    return path


def check_model_path(path, *, overwrite=False, inputs=()) -> Path:
    """Refuse a model file to write before any work: its extension, and no overwrite.

    Parameters
    ----------
    path : str or Path
        ``.skops`` (the safe format) or a pickle (``.joblib``, ``.pkl``, ``.pickle``).
    overwrite : bool, default=False
        Allow replacing an existing file.
    inputs : sequence of path, default=()
        Files the model must not be (the training data, the key file).

    Returns
    -------
    path : Path

    Examples
    --------
    >>> check_model_path("model.txt")
    Traceback (most recent call last):
    ...
    ValueError: --model model.txt: the extension chooses the format: .skops (safe, no code runs on load) or .joblib (pickle)
    """
    if Path(path).suffix.lower() not in (*PICKLE_SUFFIXES, ".skops"):
        raise ValueError(f"--model {path}: the extension chooses the format: "
                         ".skops (safe, no code runs on load) or .joblib (pickle)")
    return check_output(path, overwrite=overwrite, what="--model", inputs=inputs)
