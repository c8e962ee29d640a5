"""Reading a detector's model file strictly: an exact vocabulary, then the structure.

The commands load only the two pipelines ``train tunnel`` and ``train street`` write,
so they need not trust anything else.  :func:`load_detector` reads such a file
without skops' general loader (and without its discovery of every scikit-learn
estimator, which costs more than half a second): the schema may hold only the node
kinds those pipelines are written with, each of an exact type,

* ``ObjectNode`` of :class:`~sklearn.pipeline.Pipeline` or of a tunnelsense
  estimator (:data:`~tunnelsense.io.TRUSTED_TYPES`), built with ``__new__`` and its
  attribute dict (no ``__init__``, no ``__setstate__`` of ours runs);
* ``DictNode`` (string keys), ``ListNode``, ``TupleNode`` of the builtins;
* ``JsonNode`` holding a JSON string, boolean, null or a finite number within
  2**53 (no parameter or count of a model is larger; NaN and infinities never);
* ``NdArrayNode`` of a NumPy ``.npy`` member of a numeric or boolean dtype, read
  with ``allow_pickle=False``,

and anything else (a method, a function, a type other than ``str`` for a key, a
random generator, a cached reference, an object array) refuses the file.  Then the
model must be what the command expects: the pipeline's steps exactly the expected
classes in the expected order (by type and name), every step's parameters valid by
its own ``_parameter_constraints``, its attributes exactly its parameters and the
fitted attributes its class documents, with their documented shapes and dtypes
(:func:`~tunnelsense.io._model_checks.check_detector`).  Any deviation is an
:class:`~tunnelsense.exceptions.UntrustedModelError` naming it, before a frame is
read.
"""

from __future__ import annotations

import importlib
import io
import json
import zipfile
from pathlib import Path

import numpy as np

from tunnelsense.exceptions import UntrustedModelError
from tunnelsense.io._model_file import check_sizes

__all__ = ["EXPECTED_STEPS", "read_strict"]

#: The steps of each detector's pipeline: (name, class name), ``None`` for a step
#: that may be ``"passthrough"`` (the tunnel detector's optional verifier).
EXPECTED_STEPS = {
    "tunnel": [
        ("keypoints", "IntensityKeypointSampler"),
        ("verifier", "KMeansHistogramVerifier", None),
        ("clusters", "MSTClusterer"),
        ("appearance", "WeightedAdaBoost"),
        ("tracks", "TrajectoryLinker"),
        ("motion", "PCCVerifier"),
    ],
    "street": [("cluster", "ScanClusterer")],
}

_MAX_DEPTH = 24


#: The types a detector's file may build, by ``module.qualname``, and the module
#: that defines each (the packages' faces import the command-line helpers).  A
#: class's module is imported when a node of its type is built, so that reading a
#: tunnel model does not import the street detector, nor the reverse.
_TRUSTED = {
    "sklearn.pipeline.Pipeline": "sklearn.pipeline",
    "tunnelsense.street._detector.ScanClusterer": "tunnelsense.street._detector",
    "tunnelsense.tunnel._keypoints.IntensityKeypointSampler":
        "tunnelsense.tunnel._keypoints",
    "tunnelsense.tunnel._verification.KMeansHistogramVerifier":
        "tunnelsense.tunnel._verification",
    "tunnelsense.tunnel._clustering.MSTClusterer": "tunnelsense.tunnel._clustering",
    "tunnelsense.tunnel._motion.PCCVerifier": "tunnelsense.tunnel._motion",
    "tunnelsense.tunnel._tracking.TrajectoryLinker": "tunnelsense.tunnel._tracking",
    "tunnelsense.tunnel._appearance.WeightedAdaBoost": "tunnelsense.tunnel._appearance",
}


def _class(name):
    """The trusted class named ``name`` (a key of :data:`_TRUSTED`)."""
    cls = getattr(importlib.import_module(_TRUSTED[name]), name.rpartition(".")[2])
    if f"{cls.__module__}.{cls.__qualname__}" != name:  # moved: the table is stale
        raise RuntimeError(f"{name} is now {cls.__module__}.{cls.__qualname__}; "
                           "update tunnelsense.io._model_strict._TRUSTED")
    return cls


def _classes() -> dict:
    """Exact type name -> class, for the types a detector's file may build."""
    return {name: _class(name) for name in _TRUSTED}


def _is_trusted(cls) -> bool:
    """Whether ``cls`` is one of the trusted classes (importing only its own)."""
    name = f"{cls.__module__}.{cls.__qualname__}"
    return name in _TRUSTED and _class(name) is cls


class _Reader:
    def __init__(self, path, zf):
        self.path, self.zf, self.classes = path, zf, _TRUSTED

    def refuse(self, where, what):
        raise UntrustedModelError(f"{self.path}: {where}: {what}; tunnelsense models "
                                  "never hold that, refusing to load it")

    def build(self, node, where, depth=0):
        if depth > _MAX_DEPTH:
            self.refuse(where, f"nested deeper than {_MAX_DEPTH} levels")
        if not isinstance(node, dict):
            self.refuse(where, f"a {type(node).__name__} where a node was expected")
        loader, module, name = (node.get("__loader__"), node.get("__module__"),
                                node.get("__class__"))
        kind = (loader, module, name)
        if kind == ("JsonNode", "builtins", "str"):
            return self.json_value(node, where)
        if kind in (("ListNode", "builtins", "list"), ("TupleNode", "builtins", "tuple")):
            items = node.get("content")
            if not isinstance(items, list):
                self.refuse(where, f"a {loader} without a list of items")
            built = [self.build(v, f"{where}[{i}]", depth + 1) for i, v in enumerate(items)]
            return built if name == "list" else tuple(built)
        if kind == ("DictNode", "builtins", "dict"):
            return self.dict_value(node, where, depth)
        if kind == ("NdArrayNode", "numpy", "ndarray"):
            return self.array(node, where)
        if loader == "ObjectNode" and f"{module}.{name}" in self.classes:
            cls = _class(f"{module}.{name}")
            attrs = self.build(node.get("content"), f"{where}.{name}", depth + 1)
            if not isinstance(attrs, dict):
                self.refuse(where, f"{name} without a dict of attributes")
            attrs.pop("_sklearn_version", None)  # versions: the metadata member
            obj = cls.__new__(cls)
            obj.__dict__.update(attrs)
            return obj
        self.refuse(where, f"a {loader} of {module}.{name}")

    def json_value(self, node, where):
        content = node.get("content")
        if not isinstance(content, str) or len(content) > 4096:
            self.refuse(where, "a JSON node without a short JSON text")
        try:
            value = json.loads(content)
        except (ValueError, RecursionError):
            self.refuse(where, "a JSON node that is not JSON")
        if value is not None and not isinstance(value, bool | int | float | str):
            self.refuse(where, f"a JSON {type(value).__name__} (only numbers, strings, "
                        "booleans and null)")
        if isinstance(value, int | float) and not abs(value) <= 2**53:
            self.refuse(where, f"the number {value!r} (non-finite, or beyond 2**53)")
        return value

    def dict_value(self, node, where, depth):
        content, key_types = node.get("content"), node.get("key_types")
        if not isinstance(content, dict) or not isinstance(key_types, dict):
            self.refuse(where, "a DictNode without content and key types")
        types = key_types.get("content")
        if (key_types.get("__loader__") != "ListNode" or not isinstance(types, list)
                or len(types) != len(content)):
            self.refuse(where, "a DictNode whose key types are not one list entry a key")
        for t in types:
            if not isinstance(t, dict) or (t.get("__loader__"), t.get("__module__"),
                                           t.get("__class__")) != ("TypeNode", "builtins",
                                                                   "str"):
                self.refuse(where, "a dict key of another type than str")
        return {k: self.build(v, f"{where}.{k}", depth + 1) for k, v in content.items()}

    def array(self, node, where):
        member = node.get("file")
        if node.get("type") != "numpy" or not isinstance(member, str):
            self.refuse(where, "an array not stored as a .npy member (an object array)")
        try:
            raw = self.zf.read(member)
            array = np.load(io.BytesIO(raw), allow_pickle=False)
        except KeyError:
            self.refuse(where, f"an array member {member!r} that is not in the file")
        except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
            self.refuse(where, f"an array member {member!r} that NumPy cannot read "
                        f"({exc})")
        if not isinstance(array, np.ndarray) or array.dtype.kind not in "biuf":
            self.refuse(where, f"an array of dtype {getattr(array, 'dtype', '?')}")
        return array


_PLAIN = {("JsonNode", "builtins", "str"), ("ListNode", "builtins", "list"),
          ("TupleNode", "builtins", "tuple"), ("DictNode", "builtins", "dict"),
          ("NdArrayNode", "numpy", "ndarray"), ("TypeNode", "builtins", "str")}


def _refuse_foreign_nodes(path, schema, classes) -> None:
    """Name every node of the schema outside the vocabulary, before building any."""
    foreign, stack = set(), [schema]
    while stack:
        item = stack.pop()
        if isinstance(item, dict):
            if "__loader__" in item:
                kind = (item.get("__loader__"), item.get("__module__"),
                        item.get("__class__"))
                if kind not in _PLAIN and not (
                        kind[0] == "ObjectNode" and f"{kind[1]}.{kind[2]}" in classes):
                    foreign.add(f"{kind[1]}.{kind[2]} ({kind[0]})")
            stack.extend(item.values())
        elif isinstance(item, list):
            stack.extend(item)
    if foreign:
        raise UntrustedModelError(
            f"{path}: names types that are not trusted (they could run code when "
            f"loaded; tunnelsense models never hold them): {', '.join(sorted(foreign))}"
            "; refusing to load it")


def read_strict(path, data: bytes, *, max_bytes=None):
    """Build the model in ``data`` (the verified bytes of ``path``) from the exact
    vocabulary of the module's docstring."""
    path = Path(path)
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            check_sizes(path, zf, max_bytes)
            schema = json.loads(zf.read("schema.json"))
            if not isinstance(schema, dict) or schema.get("protocol") not in (1, 2):
                raise UntrustedModelError(f"{path}: schema.json is not a skops schema "
                                          "of protocol 1 or 2")
            reader = _Reader(path, zf)
            _refuse_foreign_nodes(path, schema, reader.classes)
            return reader.build(schema, "model")
    except UntrustedModelError:
        raise
    except (zipfile.BadZipFile, KeyError, ValueError, RecursionError, OSError,
            EOFError, NotImplementedError) as exc:
        raise UntrustedModelError(f"{path}: malformed model file "
                                  f"({type(exc).__name__}: {exc})") from None


# ---------------------------------------------------------------------------

