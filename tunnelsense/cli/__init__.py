"""The ``tunnelsense`` command: a thin layer over the library.

Each command module parses its arguments and calls library functions.  It adds its
commands through ``register_top(sub)`` (top-level) and ``register(verbs)`` (a kind of
the ``train`` / ``detect`` / ``evaluate`` verbs).
"""

from __future__ import annotations

import argparse
import gc
import importlib
import os
import signal
import sys

from tunnelsense._version import __version__

__all__ = ["build_parser", "main"]

#: The command modules, in the order of the help text.
_MODULES = ("info", "simulate", "tunnel", "street", "survey", "position", "keys")

#: The verbs, each with kinds registered by the command modules.
_VERBS = ("train", "detect", "evaluate")

#: The module that registers each top-level command and each kind of a verb, for
#: :func:`build_parser` given the command line (tests check it against the modules).
_OWNERS = {"info": "info", "simulate": "simulate", "demo": "tunnel", "survey": "survey",
           "position": "position", "keygen": "keys",
           "tunnel": "tunnel", "street": "street"}


def _owner(argv) -> str | None:
    """The one command module that registers the command ``argv`` names, or None
    (no command, an option first, an unknown name: every module is needed)."""
    if not argv:
        return None
    if argv[0] in _VERBS:
        return _OWNERS.get(argv[1]) if len(argv) > 1 else None
    return _OWNERS.get(argv[0])


def build_parser(argv=None) -> argparse.ArgumentParser:
    """The command's argument parser, every command registered.

    Given the command line ``argv``, the parser has only the command module that
    registers the command it names (when one does): the same parser for that
    command, without importing and building every other (about 20 ms of a
    command's start-up).  Help, an option first or a name no module owns get
    every command, and so does a name at another level than its own (``train info``,
    ``tunnel``), so that its error lists every choice.
    """
    owner = _owner(argv)
    parser, commands, verbs = _parser(owner)
    if owner is not None:
        named, choices = (argv[1], verbs[argv[0]].choices) if argv[0] in verbs else (
            argv[0], commands.choices)
        if named not in choices:
            parser, _, _ = _parser(None)
    return parser


def _parser(owner):
    """The parser with the commands module ``owner`` registers (None: every module),
    its subparsers' action and each verb's."""
    parser = argparse.ArgumentParser(
        prog="tunnelsense",
        description="Find roadside landmarks in vehicle sensor data: emergency-telephone "
        "indicators in far-infrared tunnel video, street-parked vehicles in laser scans.",
    )
    parser.add_argument("--version", action="version", version=f"tunnelsense {__version__}",
                        help="print the version and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    modules = [importlib.import_module(f"tunnelsense.cli.{m}") for m in _MODULES
               if owner in (None, m)]
    for module in modules:
        if hasattr(module, "register_top"):
            module.register_top(sub)
    verbs = {}
    for verb, text in zip(_VERBS, ("fit a detector on labelled tours or runs",
                                   "run a fitted detector",
                                   "score detections against ground truth"), strict=True):
        kinds = sub.add_parser(verb, help=text, description=text.capitalize() + ".")
        verbs[verb] = kinds.add_subparsers(dest="kind", metavar="KIND", required=True)
    for module in modules:
        if hasattr(module, "register"):
            module.register(verbs)
    return parser, sub, verbs


class _Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the command is, to unwind it as Ctrl-C does."""


def _terminate(signum, frame):
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # a second one ends it at once
    raise _Terminated


def main(argv=None) -> int:
    """Run the command; return its exit status (0 done, 1 bad input or a missing
    optional extra, 3 a defect, 130 interrupted, 143 terminated)."""
    if argv is None:  # the command: its own process (see tunnelsense._deferred)
        from tunnelsense._deferred import start_command

        start_command()
        # SIGTERM unwinds like Ctrl-C, so that what the command started is ended on
        # the way out (a fleet's worker processes: joblib stops them); its default,
        # dying on the spot, left them blocked forever.
        signal.signal(signal.SIGTERM, _terminate)
    try:
        return _run(argv)
    except KeyboardInterrupt as exc:  # Ctrl-C at any moment, start-up imports included
        _close_bars()
        if isinstance(exc, _Terminated):
            print("tunnelsense: terminated", file=sys.stderr)
            return 128 + signal.SIGTERM
        print("tunnelsense: interrupted", file=sys.stderr)
        return 130
    finally:
        if argv is None:  # the command, not a call from Python: the process ends
            _skip_exit_collection()


def _skip_exit_collection() -> None:
    """Spare the ending process a last garbage collection of everything it imported.

    The interpreter collects garbage as it shuts down; with scikit-learn, SciPy and
    pandas loaded that walks millions of objects for nothing (0.3-0.8 s).  Frozen
    objects are left out of every collection; memory is returned by the OS anyway.
    """
    gc.disable()
    gc.freeze()


def _close_bars() -> None:
    """End the progress bars left open by a command that stopped early."""
    if "tunnelsense._progress" in sys.modules:  # else none was drawn
        sys.modules["tunnelsense._progress"].close_all()


def _run(argv) -> int:
    parser = build_parser(sys.argv[1:] if argv is None else list(argv))
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    try:
        return int(args.func(args) or 0)
    except BrokenPipeError:  # e.g. `tunnelsense info ... | head -1`: not an error
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # no second error when Python flushes
        return 0
    except (FileNotFoundError, ValueError, OSError) as exc:
        _close_bars()
        print(f"tunnelsense: error: {exc}", file=sys.stderr)
        return 1
    except ImportError as exc:
        hint = _extra_hint(exc)
        if hint is None:
            return _internal_error(exc)
        _close_bars()
        print(f"tunnelsense: error: {hint}", file=sys.stderr)
        return 1
    except Exception as exc:  # a defect, not bad input: one line, traceback on request
        return _internal_error(exc)


def _extra_hint(exc) -> str | None:
    """The install hint for an optional extra that is missing, or None."""
    from tunnelsense.cli._extras import EXTRAS

    if "pip install" in str(exc):  # the library's own message names the extra
        return str(exc)
    top = (exc.name or "").partition(".")[0]
    for extra, module in EXTRAS.items():
        if top == module:
            return f"this needs {module}: pip install 'tunnelsense[{extra}]'"
    return None


def _internal_error(exc) -> int:
    if os.environ.get("TUNNELSENSE_DEBUG"):
        raise exc
    _close_bars()
    print(f"tunnelsense: internal error: {type(exc).__name__}: {exc} "
          "(set TUNNELSENSE_DEBUG=1 to see the traceback, and please report it)",
          file=sys.stderr)
    return 3
