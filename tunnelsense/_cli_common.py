"""Pieces shared by the detectors' command-line modules."""

from __future__ import annotations

import sys
from pathlib import Path

__all__ = ["load_cli_model"]

_PICKLE_SUFFIXES = (".joblib", ".pkl", ".pickle")


def load_cli_model(path, *, last_step, command):
    """Load a model named on the command line and check which detector it is.

    The user names the file, so a ``.joblib`` pickle is loaded, with a note that
    pickles run code; ``.skops`` files are verified by :func:`tunnelsense.io.load_model`.

    Parameters
    ----------
    path : str or Path
        The model file.
    last_step : str
        Name of the last pipeline step the detector's models have.
    command : str
        The training command, for the error message (e.g. ``"train tunnel"``).
    """
    from tunnelsense.io import load_model

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: model file not found")
    if path.suffix.lower() in _PICKLE_SUFFIXES:
        print(
            f"note: {path} is a pickle, which runs code when loaded; load pickles only "
            "from sources you trust (ship .skops files)",
            file=sys.stderr,
        )
        model = load_model(path, allow_pickle=True)
    else:
        model = load_model(path)
    steps = getattr(model, "steps", None)
    if not steps or steps[-1][0] != last_step:
        raise ValueError(f"{path}: not a model written by 'tunnelsense {command}'")
    return model
