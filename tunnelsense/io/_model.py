"""Shipping fitted models: a safe format (skops) with versions and a checksum.

Pickles (``joblib.dump``) run code when they are loaded, so a pickle from an untrusted
source can do anything.  A ``.skops`` file written by :func:`save_model` cannot: it is
read by `skops <https://skops.readthedocs.io>`_, which rebuilds objects only from an
allow-list of types.  tunnelsense adds to it:

* a metadata member ``tunnelsense.json`` with the versions of tunnelsense,
  scikit-learn, NumPy, SciPy and Python the model was trained under, and a training
  summary (tours, parameters, scores);
* a SHA-256 checksum of every byte of the file, kept in the zip comment, so that a
  tampered or truncated file is refused before anything in it is read.

The file stays a valid skops file: ``skops.io.load`` reads it too.

skops is a runtime dependency because it is the maintained, audited way to persist
scikit-learn objects without pickle; writing our own safe deserializer would be more
code and less trust.
"""

from __future__ import annotations

import hashlib
import io
import json
import platform
import warnings
import zipfile
from datetime import UTC, datetime
from pathlib import Path

from tunnelsense.exceptions import ModelVersionWarning, UntrustedModelError

__all__ = [
    "ModelVersionWarning",
    "UntrustedModelError",
    "describe_model",
    "load_model",
    "save_model",
]

_METADATA = "tunnelsense.json"
_COMMENT_PREFIX = b"tunnelsense-sha256:"
_DIGEST_LEN = 64
#: Modules whose types a safe model file may contain.
TRUSTED_MODULES = (
    "tunnelsense.",
    "sklearn.",
    "numpy.",
    "scipy.",
    "builtins.",
    "collections.",
)


def _versions() -> dict:
    import numpy
    import scipy
    import sklearn

    from tunnelsense._version import __version__

    return {
        "tunnelsense": __version__,
        "scikit-learn": sklearn.__version__,
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "python": platform.python_version(),
    }


def _json_safe(value):
    """Parameters and scores as JSON (estimators and other objects as their repr)."""
    if isinstance(value, dict):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_safe(v) for v in value]
    if isinstance(value, str | int | float | bool) or value is None:
        return value
    if hasattr(value, "item") and getattr(value, "ndim", 1) == 0:
        return value.item()
    return repr(value)


def save_model(model, path, *, summary=None) -> Path:
    """Save a fitted model for shipping.

    The format follows the file's extension: ``.skops`` writes the safe format (no code
    runs on load; versions, summary and checksum inside); ``.joblib`` / ``.pkl`` write
    a plain joblib pickle.

    Parameters
    ----------
    model : estimator
        A fitted estimator or pipeline.
    path : str or Path
        Target file; its extension chooses the format.
    summary : dict, default=None
        Training summary to store (tours, parameters, scores); JSON-able values, other
        objects are stored as their ``repr``.

    Returns
    -------
    path : Path

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from sklearn.tree import DecisionTreeClassifier
    >>> from tunnelsense.io import load_model, save_model
    >>> model = DecisionTreeClassifier(max_depth=1).fit([[0], [1]], [0, 1])
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "model.skops"
    >>> _ = save_model(model, path, summary={"tours": ["tour-01"]})
    >>> load_model(path).predict([[1]]).tolist()
    [1]
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in (".joblib", ".pkl", ".pickle"):
        import joblib

        joblib.dump(model, path)
        return path
    if suffix != ".skops":
        raise ValueError(
            f"{path}: unknown model format {suffix or '(no extension)'!r}; use .skops "
            "(safe) or .joblib (pickle)"
        )
    import skops.io

    payload = skops.io.dumps(model, compression=zipfile.ZIP_DEFLATED)
    metadata = {
        "file_format": "tunnelsense-model",
        "file_format_version": 1,
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "model": type(model).__name__,
        "versions": _versions(),
        "summary": _json_safe(summary or {}),
    }
    buffer = io.BytesIO(payload)
    with zipfile.ZipFile(buffer, "a", compression=zipfile.ZIP_DEFLATED) as zf:
        zf.writestr(_METADATA, json.dumps(metadata, indent=2, sort_keys=True))
        zf.comment = _COMMENT_PREFIX + b"0" * _DIGEST_LEN
    data = bytearray(buffer.getvalue())
    body = len(data) - _DIGEST_LEN
    data[body:] = hashlib.sha256(data[:body]).hexdigest().encode()
    path.write_bytes(bytes(data))
    return path


def _verified_bytes(path: Path) -> bytes:
    if not path.is_file():
        raise FileNotFoundError(f"{path}: model file not found")
    data = path.read_bytes()
    tail = data[-(len(_COMMENT_PREFIX) + _DIGEST_LEN) :]
    if not tail.startswith(_COMMENT_PREFIX):
        hint = ""
        if data[:1] == b"\x80" or data[:2] == b"\x78\x9c" or data[:2] == b"\x1f\x8b":
            hint = (
                " It looks like a pickle: pickles run code when loaded; save it as "
                ".joblib and load it with allow_pickle=True only if you trust its source."
            )
        raise UntrustedModelError(
            f"{path}: not a tunnelsense model file, or truncated (no checksum at the "
            f"end).{hint}"
        )
    body = len(data) - _DIGEST_LEN
    digest = hashlib.sha256(data[:body]).hexdigest().encode()
    if digest != data[body:]:
        raise UntrustedModelError(
            f"{path}: checksum mismatch, the file was changed after it was written "
            "(tampered or corrupted); refusing to load it"
        )
    return data


def _read_metadata(path: Path, data: bytes) -> dict:
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            return json.loads(zf.read(_METADATA))
    except (zipfile.BadZipFile, KeyError, json.JSONDecodeError) as exc:
        raise UntrustedModelError(f"{path}: malformed model file ({exc})") from None


def load_model(path, *, allow_pickle=False):
    """Load a model written by :func:`save_model`.

    A ``.skops`` file is verified before anything in it is read: its checksum must
    match (else it was tampered with or truncated) and it may only hold types from
    scikit-learn, NumPy, SciPy, tunnelsense and Python's builtins.  A model trained
    under other library versions loads with a :class:`ModelVersionWarning`.

    Parameters
    ----------
    path : str or Path
        A ``.skops`` file, or a ``.joblib`` pickle.
    allow_pickle : bool, default=False
        Pickles run code when loaded; load one only with ``allow_pickle=True``, and
        only from a source you trust.

    Returns
    -------
    model : estimator

    Raises
    ------
    UntrustedModelError
        The file is not a tunnelsense model file, its checksum does not match, or it
        holds types outside the trusted modules.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in (".joblib", ".pkl", ".pickle"):
        if not allow_pickle:
            raise UntrustedModelError(
                f"{path}: a pickle runs code when loaded; pass allow_pickle=True only if "
                "you trust its source, or ship models in the safe .skops format"
            )
        import joblib

        model = joblib.load(path)
        _check_parameters(model, path)
        return model
    import skops.io

    data = _verified_bytes(path)
    metadata = _read_metadata(path, data)
    try:
        untrusted = skops.io.get_untrusted_types(data=data)
    except Exception as exc:  # skops raises various errors on malformed schemas
        raise UntrustedModelError(f"{path}: malformed model file ({exc})") from None
    refused = [t for t in untrusted if not t.startswith(TRUSTED_MODULES)]
    if refused:
        raise UntrustedModelError(
            f"{path}: holds types outside the trusted modules: {', '.join(refused)}"
        )
    current = _versions()
    stored = metadata.get("versions", {})
    differ = {
        k: (stored.get(k), v)
        for k, v in current.items()
        if k != "python" and stored.get(k) != v
    }
    if differ:
        warnings.warn(
            f"{path} was saved under other versions than installed: "
            + ", ".join(f"{k} {a} (now {b})" for k, (a, b) in differ.items())
            + "; check its predictions before use",
            ModelVersionWarning,
            stacklevel=2,
        )
    model = skops.io.loads(data, trusted=untrusted)
    _check_parameters(model, path)
    return model


def _check_parameters(model, path: Path) -> None:
    """Refuse a model whose estimators lack parameters the installed code expects.

    A model saved by an older tunnelsense has no attribute for a parameter added
    since; it would fail deep inside ``predict``.  Say so when it is loaded instead.
    """
    from sklearn.base import BaseEstimator

    stack = [model]
    while stack:
        est = stack.pop()
        if not isinstance(est, BaseEstimator):
            continue
        names = est._get_param_names()
        missing = [n for n in names if not hasattr(est, n)]
        if missing:
            raise ValueError(
                f"{path}: its {type(est).__name__} lacks parameter(s) "
                f"{', '.join(missing)}: the model was saved by another version of "
                "tunnelsense; train it again"
            )
        for name in names:
            value = getattr(est, name)
            if isinstance(value, BaseEstimator):
                stack.append(value)
            elif name == "steps" and isinstance(value, list):
                stack.extend(step for _, step in value)


def describe_model(path) -> dict:
    """What a model file holds (versions, training summary, pipeline steps).

    For a ``.skops`` file this reads the metadata only (after the checksum check),
    never the model; a pickle is not opened at all.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in (".joblib", ".pkl", ".pickle"):
        return {
            "kind": "model",
            "format": "pickle",
            "path": str(path),
            "bytes": path.stat().st_size,
            "note": "pickles run code when loaded; not opened",
        }
    data = _verified_bytes(path)
    metadata = _read_metadata(path, data)
    return {
        "kind": "model",
        "format": "skops",
        "path": str(path),
        "bytes": len(data),
        **metadata,
    }
