"""Defer a module's import until its first use, in the command's own process.

scikit-learn imports SciPy's statistics and pandas as it starts (``sklearn.utils.fixes``),
about half of its import time, although detecting with a fitted model touches neither.
:func:`defer` puts a stand-in for such a module in ``sys.modules``: ``import pandas``
then binds the stand-in, and the first attribute looked up on it (``pd.DataFrame``)
imports the real module, which replaces the stand-in in ``sys.modules`` and answers
every later look-up through it.  A command that never uses the module never imports
it; one that does pays the same import, later.

A package whose names are imported at start (``from package import Name``, which looks
the name up at once) can be deferred too when each such name lives in one light
submodule (:data:`SERVED`): the stand-in answers those names from their submodules and
imports the whole package at the first look-up of any other name.
scikit-learn's pipeline module imports ``FunctionTransformer`` from
``sklearn.preprocessing``, whose package imports SciPy's interpolation and optimization
(a quarter of the pipeline's import), which no detection uses; the tunnel detector
needs SciPy's assignment solver and its Delaunay triangulation and k-d tree, each a
compiled module of a package that imports much more.  A served name that another
release keeps elsewhere imports the whole package instead.  (SciPy's sparse and dense
linear algebra are not deferred: at the lowest SciPy allowed, a stand-in for them
broke the later import of the whole package, e.g. ``scipy.sparse.linalg`` through
``scipy.sparse``.)
scikit-learn's validation imports narwhals' stable API (``import
narwhals.stable.v2 as nw``) to recognise data frames; a stand-in's look-up of a
deferred submodule gives that submodule's stand-in, so the package loads (its
deferred parents with it) only when a data frame is looked at.

Only the ``tunnelsense`` command calls :func:`defer` (a library import never does): it
changes how modules load in the whole process.
"""

from __future__ import annotations

import gc
import importlib
import importlib.machinery
import importlib.util
import sys
import types
from pathlib import Path

__all__ = ["DEFERRED", "NUMPY_PARTS", "SERVED", "defer", "defer_numpy_parts",
           "end_imports", "start_command", "start_imports"]

#: The modules the command defers: imported by scikit-learn at start, seldom needed.
#: (``scipy.special``: scikit-learn's array-API helpers import it for two functions
#: that detection does not call; building its functions' array-API wrappers parses
#: their docstrings, a tenth of scikit-learn's import.  narwhals: see the module's
#: docstring.)
DEFERRED = ("scipy.stats", "pandas", "sklearn.preprocessing", "scipy.optimize",
            "scipy.spatial", "scipy.special",
            "narwhals", "narwhals.stable", "narwhals.stable.v2")

#: NumPy's submodules the command defers once NumPy is imported
#: (:func:`defer_numpy_parts`): SciPy's array-API layer, imported with scikit-learn,
#: copies every name of ``numpy``, which imports each of these lazily loaded
#: submodules (the Fortran wrapper generator, the test helpers, polynomials, the
#: ctypes helpers); detection uses none of them.  (Not ``numpy.ma``: ``np.unique``
#: looks it up on every call.)
NUMPY_PARTS = ("numpy.f2py", "numpy.testing", "numpy.polynomial", "numpy.ctypeslib")

#: Names a deferred package serves from one of its submodules without importing the
#: package (see the module's docstring).
SERVED = {
    "sklearn.preprocessing": {
        "FunctionTransformer": "sklearn.preprocessing._function_transformer",
    },
    # the tunnel detector's trajectory linking and keypoint clustering
    "scipy.optimize": {"linear_sum_assignment": "scipy.optimize._lsap"},
    "scipy.spatial": {"Delaunay": "scipy.spatial._qhull",
                      "QhullError": "scipy.spatial._qhull",
                      "cKDTree": "scipy.spatial._ckdtree"},
}

#: Whether this process is the command's own (:func:`defer_numpy_parts` acts only then).
_IN_COMMAND = []

#: The garbage collector's first threshold while the command imports
#: (:func:`start_imports`): importing makes hundreds of thousands of objects and no
#: garbage to speak of, yet at the interpreter's threshold (700) the collector ran
#: about 140 times, a sixth of the start-up.
IMPORT_GC_THRESHOLD = 200_000

#: The collector's thresholds before :func:`start_imports` raised them.
_SAVED_THRESHOLDS = []

class _Deferred(types.ModuleType):
    """The stand-in of a module not imported yet (see the module's docstring)."""

    def __getattr__(self, attr):
        child = sys.modules.get(f"{self.__name__}.{attr}")
        if isinstance(child, _Deferred):  # ``import a.b.c as x`` of deferred ones
            return child
        served = SERVED.get(self.__name__, {})
        if served and sys.modules.get(self.__name__) is self:
            if attr in served:
                try:
                    return getattr(importlib.import_module(served[attr]), attr)
                except (ImportError, AttributeError):  # another version's layout
                    return getattr(_load(self), attr)
            if _is_submodule(self, attr):  # ``from . import x`` in a submodule
                return importlib.import_module(f"{self.__name__}.{attr}")
        return getattr(_load(self), attr)

    def __dir__(self):
        return dir(_load(self))


def _is_submodule(stand_in, attr):
    """Whether ``attr`` names a module or package in the stand-in's folder."""
    if attr.startswith("__"):
        return False
    for folder in getattr(stand_in, "__path__", ()):
        base = Path(folder)
        if (base / attr / "__init__.py").is_file() or any(
                p.name.partition(".")[0] == attr for p in base.glob(f"{attr}.*")
                if p.suffix in (".py", ".so", ".pyd")):
            return True
    return False


def _load(stand_in):
    """The real module of ``stand_in``, imported on first use.

    Threads that get here at once import it once: the import system's lock of the
    module makes the later ones wait for the first and take its module.
    """
    name = stand_in.__name__
    # deferred parents (stand-ins without a path) are imported with it
    parts = name.split(".")
    parents = [p for p in (".".join(parts[:i]) for i in range(1, len(parts)))
               if isinstance(sys.modules.get(p), _Deferred) and p not in SERVED]
    held = [sys.modules.pop(p) for p in parents]
    if sys.modules.get(name) is stand_in:
        sys.modules.pop(name, None)
    real = importlib.import_module(name)
    for parent in held:
        parent.__dict__.update({k: v for k, v in vars(sys.modules[parent.__name__]).items()
                                if k not in ("__spec__", "__loader__")})
    # submodules imported through the stand-in (SERVED) are the package's too
    for child, module in list(sys.modules.items()):
        if child.rpartition(".")[0] == name and module is not None:
            tail = child.rpartition(".")[2]
            if tail not in vars(real):
                setattr(real, tail, module)
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
    deferred, tops = [], {}
    for name in names:  # the top-level packages' specs, before any stand-in
        tops.setdefault(name.partition(".")[0], _real_spec(name.partition(".")[0]))
    for name in names:
        if name in sys.modules:
            continue
        top = tops[name.partition(".")[0]]
        if top is None:
            continue
        parts = name.split(".")[1:]
        base = Path(top.origin or "").parent
        if parts and not ((base.joinpath(*parts) / "__init__.py").is_file() or any(
                p.suffix in (".py", ".so", ".pyd")
                for p in base.joinpath(*parts[:-1]).glob(f"{parts[-1]}.*"))):
            continue  # no such submodule in this release: its import fails as usual
        path = None
        if name in SERVED:  # its submodules load from its folder, found without
            # importing the parent (``tunnelsense --version`` imports none of it)
            folder = Path(top.origin or "").parent.joinpath(*name.split(".")[1:])
            if top.origin is None or not (folder / "__init__.py").is_file():
                continue
            path = [str(folder)]
        stand_in = _Deferred(name)
        stand_in.__spec__ = importlib.machinery.ModuleSpec(name, None,
                                                           is_package=path is not None)
        if path is not None:
            stand_in.__path__ = path
            stand_in.__spec__.submodule_search_locations = path
        sys.modules[name] = stand_in
        deferred.append(name)
    return deferred


def _real_spec(top):
    """The spec of the top-level package ``top`` (not its stand-in's), or None."""
    try:  # the top-level package only: a submodule's look-up imports its parent
        if isinstance(sys.modules.get(top), _Deferred):
            return importlib.machinery.PathFinder.find_spec(top)
        return importlib.util.find_spec(top)
    except (ImportError, ValueError):
        return None


def start_command() -> list[str]:
    """Defer :data:`DEFERRED` for the command's own process; return those deferred.

    Called once by the ``tunnelsense`` command as it starts (never by a library
    import); :func:`defer_numpy_parts` then acts too.
    """
    _IN_COMMAND.append(True)
    return defer()


def defer_numpy_parts() -> list[str]:
    """In the command's own process, import NumPy and defer :data:`NUMPY_PARTS`.

    NumPy loads these submodules on the first look-up of ``numpy.<name>`` (its own
    ``__getattr__``), so each stand-in is also set as that attribute of ``numpy``;
    the first use of one imports the real submodule, which replaces it there too.
    A command calls it before its heavy imports (scikit-learn).  Outside the
    command (:func:`start_command` not called) it does nothing and returns ``[]``.

    Returns
    -------
    deferred : list of str
    """
    if not _IN_COMMAND:
        return []
    import numpy

    deferred = defer(NUMPY_PARTS)
    for name in deferred:
        setattr(numpy, name.rpartition(".")[2], sys.modules[name])
    return deferred


def start_imports() -> list[str]:
    """In the command's own process, before its heavy imports: defer
    :data:`NUMPY_PARTS` and collect garbage seldom until :func:`end_imports`.

    Outside the command (:func:`start_command` not called) it does nothing.

    Returns
    -------
    deferred : list of str
        As :func:`defer_numpy_parts`.
    """
    if not _IN_COMMAND:
        return []
    if not _SAVED_THRESHOLDS:
        _SAVED_THRESHOLDS.append(gc.get_threshold())
        gc.set_threshold(IMPORT_GC_THRESHOLD, *_SAVED_THRESHOLDS[0][1:])
    return defer_numpy_parts()


def end_imports() -> None:
    """After :func:`start_imports` and the model's load: move every object made so
    far out of the collector's reach (``gc.freeze``: modules, classes and the model
    live as long as the process, and later collections need not walk them again)
    and collect at the usual thresholds.  Nothing to do otherwise.
    """
    if _SAVED_THRESHOLDS:
        gc.freeze()
        gc.set_threshold(*_SAVED_THRESHOLDS.pop())
