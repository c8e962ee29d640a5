"""The model file format: a skops file with tunnelsense's metadata, checksum and
signature (see :mod:`tunnelsense.io._model`).

skops is imported only when a model is written or read: it takes about a second, and
``tunnelsense --help`` need not wait for it.
"""

from __future__ import annotations

import hashlib
import hmac
import io
import json
import platform
import zipfile
import zlib
from datetime import UTC, datetime
from pathlib import Path

import numpy
import scipy
import sklearn

from tunnelsense._version import __version__
from tunnelsense.exceptions import UntrustedModelError

__all__ = ["read_metadata", "skops_bytes", "verified_bytes"]

_METADATA = "tunnelsense.json"
_COMMENT_PREFIX = b"tunnelsense-sha256:"
_SIGNATURE_PREFIX = b"tunnelsense-hmac-sha256:"
_DIGEST_LEN = 64


def _versions() -> dict:
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


def _as_key(key):
    """A signing key as bytes (a str is taken as UTF-8); None stays None."""
    if key is None:
        return None
    if isinstance(key, str):
        key = key.encode("utf-8")
    if not isinstance(key, bytes | bytearray) or len(key) < 16:
        raise ValueError(
            "key must be a secret of at least 16 bytes (str or bytes); got "
            + (f"{len(key)} bytes" if isinstance(key, bytes | bytearray) else
               type(key).__name__)
        )
    return bytes(key)



def _hmac(key: bytes, data) -> str:
    return hmac.new(key, data, hashlib.sha256).hexdigest()


def skops_bytes(model, summary, *, signed) -> bytearray:
    """The skops file with metadata and a zip comment of zeros to fill in."""
    import skops.io  # slow to import: see the module's docstring

    payload = skops.io.dumps(model, compression=zipfile.ZIP_DEFLATED)
    metadata = {
        "file_format": "tunnelsense-model",
        "file_format_version": 1,
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "model": type(model).__name__,
        "signed": signed,
        "versions": _versions(),
        "summary": _json_safe(summary or {}),
    }
    buffer = io.BytesIO(payload)
    with zipfile.ZipFile(buffer, "a", compression=zipfile.ZIP_DEFLATED) as zf:
        zf.writestr(_METADATA, json.dumps(metadata, indent=2, sort_keys=True))
        comment = _COMMENT_PREFIX + b"0" * _DIGEST_LEN
        if signed:
            comment = _SIGNATURE_PREFIX + b"0" * _DIGEST_LEN + comment
        zf.comment = comment
    return bytearray(buffer.getvalue())


def verified_bytes(path: Path, key=None) -> tuple[bytes, bool]:
    """The file's bytes after the checksum (and, with a key, signature) check.

    Returns the bytes and whether the file carries a signature.
    """
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
    if not hmac.compare_digest(digest, data[body:]):
        raise UntrustedModelError(
            f"{path}: checksum mismatch, the file was changed after it was written "
            "(tampered or corrupted); refusing to load it"
        )
    end = len(data) - len(tail)
    start = end - _DIGEST_LEN
    signed = data[start - len(_SIGNATURE_PREFIX) : start] == _SIGNATURE_PREFIX
    if key is not None:
        if not signed:
            raise UntrustedModelError(
                f"{path}: the model is not signed, and a signing key was given; "
                "refusing a model this key did not sign"
            )
        expected = _hmac(key, data[:start]).encode()
        if not hmac.compare_digest(expected, data[start:end]):
            raise UntrustedModelError(
                f"{path}: signature mismatch: the model was not signed with this key, "
                "or was changed after it was signed; refusing to load it"
            )
    return data, signed


def read_metadata(path: Path, data: bytes) -> dict:
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            metadata = json.loads(zf.read(_METADATA))
    except (zipfile.BadZipFile, zlib.error, KeyError, ValueError, OSError, EOFError,
            NotImplementedError, RuntimeError) as exc:  # what a broken zip raises
        raise UntrustedModelError(f"{path}: malformed model file ({exc})") from None
    versions = metadata.get("versions") if isinstance(metadata, dict) else None
    if (
        not isinstance(metadata, dict)
        or metadata.get("file_format") != "tunnelsense-model"
        or not isinstance(versions, dict)
        or not all(isinstance(v, str) for v in versions.values())
    ):
        raise UntrustedModelError(
            f"{path}: malformed model file ({_METADATA} is not the JSON object "
            "tunnelsense writes: file_format 'tunnelsense-model' and a 'versions' "
            "object of strings)"
        )
    return metadata
