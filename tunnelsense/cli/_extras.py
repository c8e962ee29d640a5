"""Optional extras a command needs, checked before it does any work."""

from __future__ import annotations

import importlib.util

__all__ = ["EXTRAS", "require_extra", "require_extras_for_runs"]

#: The optional extras the commands use: extra name -> the module it installs.
EXTRAS = {"plot": "matplotlib", "rosbag": "rosbags", "distributed": "distributed"}


def require_extra(extra, why) -> None:
    """Raise a one-line ImportError with the install hint if ``extra`` is missing.

    The module is looked up, not imported: a check costs no start-up time.
    """
    module = EXTRAS[extra]
    try:
        found = importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):
        found = False
    if not found:
        raise ImportError(f"{why} needs {module}, which is not installed: "
                          f"pip install 'tunnelsense[{extra}]'", name=module)


def require_extras_for_runs(paths, *, draw=False) -> None:
    """The extras of a street command: rosbags for a bag, matplotlib for ``--draw``."""
    from tunnelsense.io._rosbag import is_bag

    for path in paths:
        if is_bag(path):
            require_extra("rosbag", f"reading the ROS bag {path}")
    if draw:
        require_extra("plot", "--draw")
