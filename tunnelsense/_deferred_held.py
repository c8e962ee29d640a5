"""Hold a package's own code until a name it defines is first looked up.

scikit-learn imports SciPy's sparse linear algebra as it starts
(``sklearn.utils.fixes`` looks up its conjugate-gradient solver, and SciPy's sparse
graph package its linear operator), and with it SciPy's dense linear algebra, whose
functions' wrappers parse their docstrings as they load: a sixth of the command's
imports, for names that detection never calls (and joblib's asyncio, see :data:`HELD`).  :func:`hold` puts the package's real
module object in ``sys.modules`` and binds it as its parent's attribute, as an import
does, but does not run its ``__init__`` yet:

* a name in :data:`HELD` is served from the light submodule that defines it (the
  submodule imports as usual: its package is in ``sys.modules``, with its path);
* while one of the package's submodules is importing in this thread, a name the
  package does not have yet is missing (``AttributeError``; ``from package import
  _optional`` raises ``ImportError``), as in a package whose ``__init__`` is still
  running: the submodules a held package serves are those its ``__init__`` imports
  first, before it defines any name of its own;
* any other name runs the package's ``__init__`` in that same module object (the
  module keeps its identity: what was bound to it stays bound to the whole package,
  and the submodules imported so far are reused, as when an import comes round to a
  submodule already loaded) and answers from it.  A thread that looks a name up
  while another runs the ``__init__`` waits for it.

A served name that another release keeps elsewhere (its submodule missing, or
without it) runs the ``__init__`` instead.  Unlike the stand-ins of
:mod:`tunnelsense._deferred`, nothing is copied or replaced, so no later import can
see two modules of one name.  Only the ``tunnelsense`` command holds packages
(:func:`tunnelsense._deferred.start_imports`).
"""

from __future__ import annotations

import importlib
import importlib.machinery
import importlib.util
import sys
import threading
import types

__all__ = ["HELD", "hold"]

#: The packages the command holds, each with the names it serves and their
#: submodules (ordered: a package before its subpackages; a top-level package has no
#: parent to bind it to).  ``scipy.sparse.linalg._isolve``
#: is held with nothing to serve: its ``__init__`` imports every iterative solver, one
#: of which looks up a dozen names of ``scipy.linalg``; only the conjugate gradient of
#: its ``iterative`` module is served.
HELD = {
    "scipy.linalg": {"get_lapack_funcs": "scipy.linalg.lapack"},
    "scipy.sparse.linalg": {"LinearOperator": "scipy.sparse.linalg._interface",
                            "cg": "scipy.sparse.linalg._isolve.iterative"},
    "scipy.sparse.linalg._isolve": {},
    # joblib's memory imports asyncio for its coroutines, which detection has none of
    # (not psutil: joblib's process pool imports a name of it at once)
    "asyncio": {},
}

#: Per held package: its lock, the thread running its ``__init__`` and what it serves.
_STATE = {}

#: Per thread: the held packages one of whose submodules it is importing.
_LOCAL = threading.local()


class _Held(types.ModuleType):
    """A held package's module object, until its ``__init__`` has run."""

    def __getattr__(self, attr):
        return _look_up(self, attr)

    def __dir__(self):
        _run_init(self)
        return dir(self)


def _serving():
    if not hasattr(_LOCAL, "names"):
        _LOCAL.names = []
    return _LOCAL.names


def _look_up(module, attr):
    name = module.__name__
    state = _STATE[name]
    # whether the package is partial here, then whose __init__ runs (read after:
    # a thread that had not started the __init__ then imported none of it before)
    partial = name in _serving() or _submodule_importing(name)
    owner = state["owner"]
    if owner is not None and owner != threading.get_ident():
        with state["lock"]:  # another thread runs the __init__: wait for it
            pass
        return getattr(module, attr)
    if owner is not None or partial:
        raise AttributeError(
            f"partially initialized module {name!r} has no attribute {attr!r}")
    source = state["served"].get(attr)
    if source is not None:
        _serving().append(name)
        try:
            return getattr(importlib.import_module(source), attr)
        except (ImportError, AttributeError):  # another release's layout
            pass
        finally:
            _serving().pop()
    _run_init(module)
    return getattr(module, attr)


def _submodule_importing(name):
    """Whether a submodule of ``name`` is importing (its code not run to the end).

    The import system does not say by which thread: a look-up from one thread while
    another imports a submodule of a held package directly (not through a served
    name) finds the package partial too.  The command imports in its main thread
    before its threads start.
    """
    prefix = f"{name}."
    return any(key.startswith(prefix) and getattr(
        getattr(mod, "__spec__", None), "_initializing", False)
        for key, mod in list(sys.modules.items()))


def _run_init(module):
    """Run the held package's ``__init__`` in its module object, once."""
    state = _STATE[module.__name__]
    with state["lock"]:
        if type(module) is not _Held:
            return
        spec = module.__spec__
        state["owner"] = threading.get_ident()
        spec._initializing = True
        try:
            spec.loader.exec_module(module)
        except BaseException:
            if sys.modules.get(module.__name__) is module:  # as a failed import
                del sys.modules[module.__name__]
            raise
        finally:
            spec._initializing = False
            state["owner"] = None
            module.__class__ = types.ModuleType


def _spec(name):
    """The spec of module ``name``, found without importing its parents."""
    top, *parts = name.split(".")
    spec = importlib.util.find_spec(top) if top not in sys.modules else (
        sys.modules[top].__spec__)
    for k in range(len(parts)):
        if spec is None or not spec.submodule_search_locations:
            return None
        spec = importlib.machinery.PathFinder.find_spec(
            ".".join([top, *parts[:k + 1]]), list(spec.submodule_search_locations))
    return spec


def hold(held=None) -> list[str]:
    """Hold the packages ``held`` (default :data:`HELD`); return those held.

    A package already imported, or not installed, is left alone; so is a subpackage
    whose parent was left alone.  Each held package is bound as its parent's
    attribute when the parent is imported already (the command imports SciPy's
    sparse package after holding, then binds it: see
    :func:`tunnelsense._deferred.start_imports`).
    """
    done = []
    for name, served in (HELD if held is None else held).items():
        parent = name.rpartition(".")[0]
        if name in sys.modules or (parent in HELD and parent not in done
                                   and parent not in sys.modules):
            continue
        spec = _spec(name)
        if spec is None or spec.loader is None or not spec.submodule_search_locations:
            continue
        module = importlib.util.module_from_spec(spec)
        module.__class__ = _Held
        _STATE[name] = {"lock": threading.RLock(), "owner": None, "served": served}
        sys.modules[name] = module
        done.append(name)
    bind(done)
    return done


def bind(names) -> None:
    """Set each held package of ``names`` as its parent's attribute, where the
    parent is imported and has none of that name in its namespace."""
    for name in names:
        parent, _, child = name.rpartition(".")
        module = sys.modules.get(parent)
        if module is not None and child not in vars(module):
            setattr(module, child, sys.modules[name])
