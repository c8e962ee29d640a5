"""Writing a detector's model file without importing skops' general writer.

``import skops.io`` lists every scikit-learn estimator (``all_estimators``, which
imports all of scikit-learn): about a second of ``train tunnel`` and ``train
street``.  The detectors' models hold only the kinds of objects the strict reader
(:mod:`tunnelsense.io._model_strict`) builds: a :class:`~sklearn.pipeline.Pipeline`
and tunnelsense estimators (their ``__getstate__`` dicts), dicts with string keys,
lists, tuples, JSON numbers, strings, booleans and null, and NumPy arrays of a
numeric or boolean dtype.  :func:`detector_skops_payload` writes such a model as
``skops.io.dumps(model, compression=ZIP_DEFLATED)`` does, node for node and member
for member (the same schema, the same ``.npy`` members in the same order, named by
the same object ids); any other object makes it return None, and the caller uses
skops.  (Tests compare the two writers' files.)
"""

from __future__ import annotations

import io
import json
import pickle
import zipfile

import numpy as np

__all__ = ["detector_skops_payload"]

#: The skops file protocol these nodes are of, and the skops releases that write it
#: (another release: skops writes the file; the strict reader reads 1 and 2).
PROTOCOL = 2
SKOPS_RELEASES = ("0.15", "0.16")


class _Foreign(Exception):
    """An object outside the vocabulary: the caller writes the model with skops."""


def _skops_version() -> str | None:
    try:
        import skops  # the package alone (its version): light, unlike skops.io
    except ImportError:
        return None
    return getattr(skops, "__version__", None)


def _trusted_classes() -> frozenset:
    from tunnelsense.io._model_strict import _TRUSTED

    return frozenset(_TRUSTED)


class _Writer:
    """The schema of one model, its arrays written to ``zip_file`` on the way."""

    def __init__(self, zip_file, classes):
        self.zip_file, self.classes = zip_file, classes
        self.memo = {}  # holds every object written: no id is reused meanwhile
        self.members = set()

    def state(self, value) -> dict:
        self.memo[id(value)] = value
        kind = type(value)
        if kind is dict:
            res = self.dict_state(value)
        elif kind is list or kind is tuple:
            res = {"__class__": kind.__name__, "__module__": "builtins",
                   "__loader__": "ListNode" if kind is list else "TupleNode",
                   "content": [self.state(v) for v in value]}
        elif kind is np.ndarray:
            res = self.array_state(value)
        elif value is None or kind in (bool, int, float, str):
            res = {"__class__": "str", "__module__": "builtins", "__loader__": "JsonNode",
                   "content": json.dumps(value), "is_json": True}
        elif f"{kind.__module__}.{kind.__qualname__}" in self.classes:
            attrs = value.__getstate__()
            if type(attrs) is not dict:
                raise _Foreign(kind)
            res = {"__class__": kind.__name__,
                   "__module__": pickle.whichmodule(kind, kind.__name__),
                   "__loader__": "ObjectNode", "content": self.state(attrs)}
        else:
            raise _Foreign(kind)
        res["__id__"] = id(value)
        return res

    def dict_state(self, value) -> dict:
        if any(type(k) is not str for k in value):
            raise _Foreign(dict)
        types = [str] * len(value)
        self.memo[id(types)] = types
        self.memo[id(str)] = str
        key_types = {"__class__": "list", "__module__": "builtins",
                     "__loader__": "ListNode",
                     "content": [{"__class__": "str", "__module__": "builtins",
                                  "__loader__": "TypeNode", "__id__": id(str)}
                                 for _ in types],
                     "__id__": id(types)}
        content = {k: self.state(v) for k, v in value.items()}
        return {"__class__": "dict", "__module__": "builtins", "__loader__": "DictNode",
                "content": content, "key_types": key_types}

    def array_state(self, value) -> dict:
        if value.dtype.kind not in "biuf":
            raise _Foreign(value.dtype)
        buffer = io.BytesIO()
        np.save(buffer, value, allow_pickle=False)
        name = f"{id(value)}.npy"
        if name not in self.members:
            self.members.add(name)
            self.zip_file.writestr(name, buffer.getbuffer())
        return {"__class__": "ndarray", "__module__": "numpy", "__loader__": "NdArrayNode",
                "type": "numpy", "file": name}


def detector_skops_payload(model) -> bytes | None:
    """The skops file of ``model`` (as ``skops.io.dumps(model,
    compression=zipfile.ZIP_DEFLATED)``), or None when ``model`` holds an object
    outside the strict reader's vocabulary (see the module's docstring), or skops
    is not installed or another release than :data:`SKOPS_RELEASES`."""
    version = _skops_version()
    if version is None or ".".join(version.split(".")[:2]) not in SKOPS_RELEASES:
        return None
    buffer = io.BytesIO()
    try:
        with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_DEFLATED) as zf:
            state = _Writer(zf, _trusted_classes()).state(model)
            state["protocol"] = PROTOCOL
            state["_skops_version"] = version
            zf.writestr("schema.json", json.dumps(state, indent=2))
    except _Foreign:
        return None
    return buffer.getvalue()
