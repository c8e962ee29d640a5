"""Arguments and models shared by the detectors' commands."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

from tunnelsense._progress import Progress
from tunnelsense.exceptions import UntrustedModelError
from tunnelsense.io import load_model, save_model
from tunnelsense.io._model import KEY_ENV
from tunnelsense.io._output import check_draw_dir, check_output, input_files

__all__ = [
    "add_model_arguments",
    "add_output_arguments",
    "add_quiet",
    "check_detect_outputs",
    "check_model_output",
    "load_cli_model",
    "progress",
    "save_cli_model",
    "signing_key",
]

_PICKLE_SUFFIXES = (".joblib", ".pkl", ".pickle")


def add_model_arguments(parser, *, help_model) -> None:
    """``--model``, ``--trust-pickle`` and ``--key-file`` of a command that loads one."""
    parser.add_argument("--model", required=True, help=help_model)
    parser.add_argument(
        "--trust-pickle", action="store_true",
        help="allow a .joblib/.pkl model: pickles run code when loaded, so only for "
        "a file from a source you trust",
    )
    _add_key_argument(parser, "refuse a .skops model not signed with the key in FILE")


def _add_key_argument(parser, text) -> None:
    parser.add_argument("--key-file", metavar="FILE", help=f"{text} (default: the "
                        f"environment variable {KEY_ENV}, if set)")


def add_output_arguments(parser, *, signs=False) -> None:
    """``--force`` (and ``--key-file`` for a command that writes a model)."""
    parser.add_argument(
        "--force", action="store_true",
        help="replace an existing output file (never one of the command's inputs)",
    )
    if signs:
        _add_key_argument(parser, "sign the .skops model with the key in FILE")


def add_quiet(parser) -> None:
    """``--quiet``: no progress bars."""
    parser.add_argument("--quiet", action="store_true", help="no progress bars")


def progress(args, total, desc, **kwargs):
    """A progress bar on stderr, or None with ``--quiet``."""
    return None if getattr(args, "quiet", False) else Progress(total, desc, **kwargs)


def signing_key(args):
    """The fleet's signing key: ``--key-file``, else ``TUNNELSENSE_MODEL_KEY``."""
    path = getattr(args, "key_file", None)
    if not path:
        return os.environ.get(KEY_ENV) or None
    try:
        key = Path(path).read_bytes().strip()
    except OSError as exc:
        raise OSError(exc.errno, f"--key-file {path}: {exc.strerror}") from None
    if not key:
        raise ValueError(f"--key-file {path}: the file is empty")
    return key


def load_cli_model(path, *, last_step, command, trust_pickle=False, key=None):
    """The model of ``--model`` (:func:`tunnelsense.io.load_model`), a pickle only
    with ``--trust-pickle``; refused unless its last step is ``last_step``, as the
    models of ``tunnelsense {command}`` are."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: model file not found")
    pickle = path.suffix.lower() in _PICKLE_SUFFIXES
    if pickle and not trust_pickle:
        raise UntrustedModelError(
            f"--model {path}: a pickle runs code when loaded; pass --trust-pickle "
            "only if you trust its source, or ship .skops models"
        )
    if pickle:
        print(f"note: loading the pickle {path} (--trust-pickle): it can run any code",
              file=sys.stderr)
    model = load_model(path, allow_pickle=pickle, key=key)
    steps = getattr(model, "steps", None)
    if not steps or steps[-1][0] != last_step:
        raise ValueError(f"{path}: not a model written by 'tunnelsense {command}'")
    return model


def check_model_output(args, sources):
    """Refuse a ``--model`` to write before any work; return the signing key."""
    if Path(args.model).suffix.lower() not in (*_PICKLE_SUFFIXES, ".skops"):
        raise ValueError(f"--model {args.model}: the extension chooses the format: "
                         ".skops (safe, no code runs on load) or .joblib (pickle)")
    inputs = [f for d in sources for f in input_files(d)]
    check_output(args.model, overwrite=args.force, what="--model",
                 inputs=[*inputs, *filter(None, [args.key_file])])
    return signing_key(args)


def save_cli_model(model, args, *, summary, key, start):
    """Write the trained model of ``--model`` and say so."""
    save_model(model, args.model, summary=summary, key=key, overwrite=args.force)
    kind = "safe skops" if Path(args.model).suffix.lower() == ".skops" else "pickle"
    print(f"wrote {args.model} ({kind}{', signed' if key is not None else ''}; "
          f"{time.perf_counter() - start:.1f} s)")


def check_detect_outputs(args, source, outputs) -> None:
    """Refuse ``--out`` files (and a ``--draw`` folder) before any work."""
    inputs = [args.model, *input_files(source), *filter(None, [args.key_file])]
    for path in outputs:
        check_output(path, overwrite=args.force or args.resume, inputs=inputs,
                     what="--out")
    if args.draw is not None:
        check_draw_dir(args.draw, force=args.force, inputs=inputs)
