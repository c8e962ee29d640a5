"""Pieces shared by the detectors' command-line modules: models in, outputs out."""

from __future__ import annotations

import os
import sys
from pathlib import Path

__all__ = [
    "add_model_arguments",
    "add_output_arguments",
    "check_draw_dir",
    "input_files",
    "load_cli_model",
    "signing_key",
]

_PICKLE_SUFFIXES = (".joblib", ".pkl", ".pickle")


def add_model_arguments(parser, *, help_model) -> None:
    """``--model``, ``--trust-pickle`` and ``--key-file`` of a command that loads one."""
    parser.add_argument("--model", required=True, help=help_model)
    parser.add_argument(
        "--trust-pickle",
        action="store_true",
        help="allow a .joblib/.pkl model: pickles run code when loaded, so only for "
        "a file from a source you trust",
    )
    _add_key_argument(parser, "refuse a .skops model not signed with the key in FILE")


def _add_key_argument(parser, text) -> None:
    parser.add_argument(
        "--key-file",
        metavar="FILE",
        help=f"{text} (default: the environment variable TUNNELSENSE_MODEL_KEY, if "
        "set)",
    )


def add_output_arguments(parser, *, signs=False) -> None:
    """``--force`` (and ``--key-file`` for a command that writes a model)."""
    parser.add_argument(
        "--force",
        action="store_true",
        help="replace an existing output file (never one of the command's inputs)",
    )
    if signs:
        _add_key_argument(parser, "sign the .skops model with the key in FILE")


def signing_key(args):
    """The fleet's signing key: ``--key-file``, else ``TUNNELSENSE_MODEL_KEY``."""
    from tunnelsense.io._model import KEY_ENV

    path = getattr(args, "key_file", None)
    if path:
        try:
            key = Path(path).read_bytes().strip()
        except OSError as exc:
            raise OSError(exc.errno, f"--key-file {path}: {exc.strerror}") from None
        if not key:
            raise ValueError(f"--key-file {path}: the file is empty")
        return key
    return os.environ.get(KEY_ENV) or None


def load_cli_model(path, *, last_step, command, trust_pickle=False, key=None):
    """Load a model named on the command line and check which detector it is.

    A ``.skops`` file is verified by :func:`tunnelsense.io.load_model` (checksum,
    trusted types, and the signature when a key is given).  A ``.joblib`` pickle runs
    code when loaded, so it is refused unless ``trust_pickle``.

    Parameters
    ----------
    path : str or Path
        The model file.
    last_step : str
        Name of the last pipeline step the detector's models have.
    command : str
        The training command, for the error message (e.g. ``"train tunnel"``).
    trust_pickle : bool, default=False
        Load a pickle (``--trust-pickle``).
    key : bytes or None, default=None
        The signing key the model must be signed with.
    """
    from tunnelsense.exceptions import UntrustedModelError
    from tunnelsense.io import load_model

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: model file not found")
    if path.suffix.lower() in _PICKLE_SUFFIXES:
        if not trust_pickle:
            raise UntrustedModelError(
                f"--model {path}: a pickle runs code when loaded; pass --trust-pickle "
                "only if you trust its source, or ship .skops models"
            )
        print(
            f"note: loading the pickle {path} (--trust-pickle): it can run any code",
            file=sys.stderr,
        )
        model = load_model(path, allow_pickle=True, key=key)
    else:
        model = load_model(path, key=key)
    steps = getattr(model, "steps", None)
    if not steps or steps[-1][0] != last_step:
        raise ValueError(f"{path}: not a model written by 'tunnelsense {command}'")
    return model


def input_files(source) -> list[Path]:
    """The files (and folders) a command reads from a tour, video or laser run.

    An output is never written over any of them, even with ``--force``.
    """
    from tunnelsense.io._rosbag import is_bag

    source = Path(source)
    if not source.is_dir() or is_bag(source):
        return [source]  # a file, or a ROS 2 bag folder: every file in it
    names = ["seqinfo.ini", "gt", "img1", "scans.npz", "gt.csv", "metadata.yaml"]
    names.append(_image_dir(source / "seqinfo.ini"))
    present = [source / n for n in names if n and (source / n).exists()]
    return present or [source]  # a plain image folder: every file in it


def _image_dir(seqinfo) -> str | None:
    """The ``imDir`` a ``seqinfo.ini`` names (its frames), if it can be read."""
    import configparser

    parser = configparser.ConfigParser(interpolation=None)
    try:
        parser.read(seqinfo, encoding="utf-8")
        return parser.get("Sequence", "imDir", fallback=None)
    except (configparser.Error, UnicodeDecodeError, OSError):
        return None


def check_draw_dir(path, *, force, inputs=()) -> Path:
    """A folder for pictures: new or empty, or ``--force`` to draw over its files.

    Never a device folder, and never one of the command's inputs (or inside one),
    even with ``--force``.
    """
    from tunnelsense.exceptions import OutputExistsError
    from tunnelsense.io._output import _is_device_path

    path = Path(path)
    if _is_device_path(path):
        raise ValueError(f"--draw {path}: refusing to write into a device folder")
    if path.exists() and not path.is_dir():
        raise ValueError(f"--draw {path}: exists and is not a folder")
    target = path.resolve()
    for item in inputs:
        item = Path(item).resolve()
        if target.is_relative_to(item):
            raise OutputExistsError(
                f"--draw {path}: is (or is inside) an input of this command ({item}); "
                "refusing to draw into it"
            )
    if path.is_dir() and any(path.iterdir()) and not force:
        raise OutputExistsError(
            f"--draw {path}: the folder is not empty; refusing to draw over its files "
            "(pass --force)"
        )
    return path
