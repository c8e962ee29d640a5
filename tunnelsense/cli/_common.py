"""Arguments and models shared by the detectors' commands."""

from __future__ import annotations

import os
import time
from pathlib import Path

from tunnelsense.io._keys import (
    KEY_ENV,
    VERIFY_KEY_ENV,
    read_private_key,
    read_public_key,
    read_secret,
)

# The command line imports only what a command needs: the modules behind the
# functions below (scikit-learn, tqdm, ...) are imported by the function that uses
# them, so that building the parser (and --version, --help) costs no start-up time.

__all__ = [
    "CPUS",
    "add_colour_arguments",
    "add_missing_frames_argument",
    "add_model_arguments",
    "add_output_arguments",
    "add_verify_arguments",
    "check_detect_outputs",
    "check_model_output",
    "colour",
    "key_files",
    "cli_model",
    "progress",
    "save_cli_model",
    "stage_progress",
    "verify_keys",
]

CPUS = os.cpu_count() or 1

#: The last step of each detector's model, and the command that writes it.
_MODELS = {"tunnel": ("motion", "train tunnel"), "street": ("cluster", "train street")}


def add_model_arguments(parser, *, help_model, group=None) -> None:
    """``--model`` (in ``group`` if given, else required), ``--trust-pickle``,
    ``--verify-key`` and ``--key-file`` of a command that loads a model."""
    (group or parser).add_argument("--model", required=group is None, help=help_model)
    parser.add_argument(
        "--trust-pickle", action="store_true",
        help="allow a .joblib/.pkl model: pickles run code when loaded, so only for "
        "a file from a source you trust",
    )
    add_verify_arguments(parser)


def add_verify_arguments(parser) -> None:
    """``--verify-key`` (Ed25519 public key) and ``--key-file`` (HMAC secret)."""
    parser.add_argument(
        "--verify-key", metavar="PUBLIC", help="refuse a .skops model not signed with "
        "the private key of this Ed25519 public key file (tunnelsense keygen; default: "
        f"the file the environment variable {VERIFY_KEY_ENV} names, if set)")
    _add_key_argument(parser, "refuse a .skops model not signed with the shared HMAC "
                      "secret in FILE (the weaker choice: prefer --verify-key)")


def verify_keys(args) -> dict:
    """The keys of ``--verify-key`` / ``--key-file`` (or their environment variables)."""
    return {"key": read_secret(args.key_file),
            "verify_key": read_public_key(args.verify_key)}


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
        parser.add_argument("--sign-key", metavar="PRIVATE", help="sign the .skops "
                            "model with this Ed25519 private key file (tunnelsense "
                            "keygen); vehicles verify it with the public key")
        _add_key_argument(parser, "sign the .skops model with the shared HMAC secret "
                          "in FILE (the weaker choice: prefer --sign-key)")
    if quiet:
        parser.add_argument("--quiet", action="store_true", help="no progress bars")


def add_colour_arguments(parser) -> None:
    """``--channel N`` / ``--palette-to-grey``: how colour frames become grey."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--channel", type=int, choices=(0, 1, 2), metavar="N",
                       help="read colour frames as their channel N (0 blue, 1 green, 2 "
                       "red); without it or --palette-to-grey colour frames are refused, "
                       "since a far-infrared false-colour palette is not luminance")
    group.add_argument("--palette-to-grey", action="store_true",
                       help="read colour frames as their luminance")


def add_missing_frames_argument(parser) -> None:
    """``--missing-frames raise|gap``: frame files missing from a MOTChallenge folder."""
    parser.add_argument("--missing-frames", choices=("raise", "gap"), default="raise",
                        help="frame files missing from a MOTChallenge folder's "
                        "1..seqLength: refused ('raise', the default: a copy may be "
                        "incomplete), or read as gaps in time ('gap': the frames a "
                        "recorder kept, each under its number)")


def colour(args):
    """The conversion of ``--channel`` / ``--palette-to-grey`` (None: refuse colour)."""
    return "luminance" if args.palette_to_grey else args.channel


def progress(args, total, desc, **kwargs):
    """A progress bar on stderr, or None with ``--quiet``."""
    if getattr(args, "quiet", False):
        return None
    from tunnelsense._progress import Progress

    return Progress(total, desc, **kwargs)


class _StageBars:
    """``progress(stage, done, total)``: a bar per stage, named by it; the fitting
    steps of a pipeline ("fitting <step>") share one bar, named by the step."""

    def __init__(self):
        self._stage, self._bar = None, None

    def __call__(self, stage, done, total):
        group = "fitting" if stage.startswith("fitting") or stage == "fitted" else stage
        if group != self._stage:
            self.close()
            self._stage = group
            from tunnelsense._progress import Progress

            self._bar = Progress(total, stage, unit="fit" if "fits" in stage else "it")
        self._bar.describe(stage)
        self._bar.update(done)

    def close(self):
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def stage_progress(args):
    """A ``progress(stage, done, total)`` for library calls with named stages (a
    progress bar per stage on stderr), or None with ``--quiet``."""
    return None if getattr(args, "quiet", False) else _StageBars()


def cli_model(args, kind):
    """The model of ``--model`` for the ``kind`` detector ("tunnel" or "street")."""
    from tunnelsense._deferred import end_imports
    from tunnelsense.io._trust import load_trusted_model

    last_step, command = _MODELS[kind]
    model = load_trusted_model(args.model, last_step=last_step, command=command,
                               trust_pickle=args.trust_pickle, **verify_keys(args))
    end_imports()  # of a detect command, which has imported what it needs by now
    return model


def key_files(args):
    return [f for f in (getattr(args, "key_file", None), getattr(args, "sign_key", None),
                        getattr(args, "verify_key", None)) if f]


def check_model_output(args, sources):
    """Refuse a ``--model`` to write before any work; return the signing keys."""
    from tunnelsense.io._output import check_model_path, input_files

    inputs = [f for d in sources for f in input_files(d)]
    check_model_path(args.model, overwrite=args.force, inputs=[*inputs, *key_files(args)])
    if args.sign_key is not None:
        if args.key_file is not None:
            raise ValueError("--sign-key and --key-file: give one signature, not both")
        return {"sign_key": read_private_key(args.sign_key)}
    return {"key": read_secret(args.key_file)}


def save_cli_model(model, args, *, summary, key, start):
    """Write the trained model of ``--model`` and say so (``key``: the dict of
    :func:`check_model_output`)."""
    from tunnelsense.io._model import save_model

    save_model(model, args.model, summary=summary, overwrite=args.force, **key)
    kind = "safe skops" if Path(args.model).suffix.lower() == ".skops" else "pickle"
    how = (", signed (Ed25519)" if key.get("sign_key") is not None
           else ", signed (HMAC)" if key.get("key") is not None else "")
    print(f"wrote {args.model} ({kind}{how}; {time.perf_counter() - start:.1f} s)")


def check_detect_outputs(args, source, outputs) -> None:
    """Refuse ``--out`` files (and a ``--draw`` folder) before any work."""
    from tunnelsense.io._output import check_draw_dir, check_output, input_files

    inputs = [args.model, *input_files(source), *key_files(args)]
    for path in outputs:
        check_output(path, overwrite=args.force or args.resume, inputs=inputs,
                     what="--out")
    if args.draw is not None:
        check_draw_dir(args.draw, force=args.force, inputs=inputs, outputs=outputs)
