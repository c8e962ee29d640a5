"""Defer a module's import until its first use, in the command's own process.

scikit-learn imports SciPy's statistics and pandas as it starts (``sklearn.utils.fixes``),
about half of its import time, although detecting with a fitted model touches neither.
:func:`defer` puts a stand-in for such a module in ``sys.modules``: ``import pandas``
then binds the stand-in, and the first attribute looked up on it (``pd.DataFrame``)
imports the real module, which replaces the stand-in in ``sys.modules`` and answers
every later look-up through it.  A command that never uses the module never imports
it; one that does pays the same import, later.

Only the ``tunnelsense`` command calls :func:`defer` (a library import never does): it
changes how modules load in the whole process.
"""

from __future__ import annotations

import importlib
import importlib.machinery
import importlib.util
import sys
import types

__all__ = ["DEFERRED", "defer"]

#: The modules the command defers: imported by scikit-learn at start, seldom needed.
DEFERRED = ("scipy.stats", "pandas")

class _Deferred(types.ModuleType):
    """The stand-in of a module not imported yet (see the module's docstring)."""

    def __getattr__(self, attr):
        return getattr(_load(self), attr)

    def __dir__(self):
        return dir(_load(self))


def _load(stand_in):
    """The real module of ``stand_in``, imported on first use.

    Threads that get here at once import it once: the import system's lock of the
    module makes the later ones wait for the first and take its module.
    """
    name = stand_in.__name__
    if sys.modules.get(name) is stand_in:
        sys.modules.pop(name, None)
    real = importlib.import_module(name)
    stand_in.__dict__.update(
        {k: v for k, v in vars(real).items() if k not in ("__spec__", "__loader__")})
    return real


def defer(names=DEFERRED) -> list[str]:
    """Put stand-ins for the modules ``names`` in ``sys.modules``; return those deferred.

    A module already imported, or not installed, is left alone (its import then fails
    as usual, where it is used).

    Examples
    --------
    >>> import json
    >>> from tunnelsense._deferred import defer
    >>> defer(["json"])  # imported already: left alone
    []
    """
    deferred = []
    for name in names:
        if name in sys.modules:
            continue
        try:  # the top-level package only: a submodule's look-up imports its parent
            if importlib.util.find_spec(name.partition(".")[0]) is None:
                continue
        except (ImportError, ValueError):
            continue
        stand_in = _Deferred(name)
        stand_in.__spec__ = importlib.machinery.ModuleSpec(name, None)
        sys.modules[name] = stand_in
        deferred.append(name)
    return deferred
