"""Lazy package namespaces: a public name's module is imported on first use.

A command such as ``tunnelsense --version`` needs none of scikit-learn, pandas or
SciPy; importing them all because ``tunnelsense/__init__.py`` names every estimator
cost seconds a process.  :func:`attach` gives a package the PEP 562 module
``__getattr__`` and ``__dir__`` that import the defining module of a name when it is
first looked up (as scikit-image's ``lazy_loader`` does), so that ``import tunnelsense``
is cheap and ``from tunnelsense import MSTClusterer`` imports what that class needs.
"""

from __future__ import annotations

import importlib
import sys

__all__ = ["attach"]


def attach(package: str, names: dict[str, str], public=None):
    """``(__getattr__, __dir__, __all__)`` of a package whose public names are lazy.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    names : dict of str to str
        Name -> the submodule (relative to ``package``) that defines it.
    public : list of str, optional
        The package's ``__all__`` (default: every name of ``names``).

    Returns
    -------
    getattr, dir, all : callable, callable, list of str
        To assign to the package's ``__getattr__``, ``__dir__`` and ``__all__``.

    Examples
    --------
    >>> import tunnelsense
    >>> "MSTClusterer" in dir(tunnelsense)
    True
    >>> tunnelsense.MSTClusterer.__name__
    'MSTClusterer'
    """
    public = list(names if public is None else public)

    def __getattr__(name):
        where = names.get(name)
        if where is None and name.startswith("__"):
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        if where is not None:
            value = getattr(importlib.import_module(f"{package}.{where}"), name)
        else:  # a submodule not imported yet (tunnelsense.io._model, ...)
            try:
                value = importlib.import_module(f"{package}.{name}")
            except ModuleNotFoundError as exc:
                if exc.name != f"{package}.{name}":
                    raise
                raise AttributeError(
                    f"module {package!r} has no attribute {name!r}") from None
        setattr(sys.modules[package], name, value)  # later look-ups skip this
        return value

    def __dir__():
        return sorted({*public, *vars(sys.modules[package])})

    return __getattr__, __dir__, public
