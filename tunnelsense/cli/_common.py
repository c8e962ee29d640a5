"""Arguments and models shared by the detectors' commands."""

from __future__ import annotations

import os
import time
from pathlib import Path

from tunnelsense._progress import Progress
from tunnelsense.io import save_model
from tunnelsense.io._model import KEY_ENV
from tunnelsense.io._output import check_draw_dir, check_output, input_files
from tunnelsense.io._trust import check_model_path, load_trusted_model, read_signing_key

__all__ = [
    "CPUS",
    "add_model_arguments",
    "add_output_arguments",
    "check_detect_outputs",
    "check_model_output",
    "cli_model",
    "progress",
    "save_cli_model",
]

CPUS = os.cpu_count() or 1

#: The last step of each detector's model, and the command that writes it.
_MODELS = {"tunnel": ("motion", "train tunnel"), "street": ("cluster", "train street")}


def add_model_arguments(parser, *, help_model, group=None) -> None:
    """``--model`` (in ``group`` if given, else required), ``--trust-pickle`` and
    ``--key-file`` of a command that loads a model."""
    (group or parser).add_argument("--model", required=group is None, help=help_model)
    parser.add_argument(
        "--trust-pickle", action="store_true",
        help="allow a .joblib/.pkl model: pickles run code when loaded, so only for "
        "a file from a source you trust",
    )
    _add_key_argument(parser, "refuse a .skops model not signed with the key in FILE")


def _add_key_argument(parser, text) -> None:
    parser.add_argument("--key-file", metavar="FILE", help=f"{text} (default: the "
                        f"environment variable {KEY_ENV}, if set)")


def add_output_arguments(parser, *, writes_model=False, quiet=False) -> None:
    """``--force``; ``--model`` and ``--key-file`` to write a model; ``--quiet``."""
    if writes_model:
        parser.add_argument("--model", required=True, help="where to write the model: "
                            ".skops (safe, no code runs on load) or .joblib (pickle)")
    parser.add_argument(
        "--force", action="store_true",
        help="replace an existing output file (never one of the command's inputs)",
    )
    if writes_model:
        _add_key_argument(parser, "sign the .skops model with the key in FILE")
    if quiet:
        parser.add_argument("--quiet", action="store_true", help="no progress bars")


def progress(args, total, desc, **kwargs):
    """A progress bar on stderr, or None with ``--quiet``."""
    return None if getattr(args, "quiet", False) else Progress(total, desc, **kwargs)


def cli_model(args, kind):
    """The model of ``--model`` for the ``kind`` detector ("tunnel" or "street")."""
    last_step, command = _MODELS[kind]
    return load_trusted_model(args.model, last_step=last_step, command=command,
                              trust_pickle=args.trust_pickle,
                              key=read_signing_key(args.key_file))


def check_model_output(args, sources):
    """Refuse a ``--model`` to write before any work; return the signing key."""
    inputs = [f for d in sources for f in input_files(d)]
    check_model_path(args.model, overwrite=args.force,
                     inputs=[*inputs, *filter(None, [args.key_file])])
    return read_signing_key(args.key_file)


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
