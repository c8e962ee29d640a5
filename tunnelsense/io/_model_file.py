"""The model file format: a skops file with tunnelsense's metadata, checksum and
signature (see :mod:`tunnelsense.io._model`).

skops is imported only when a model is written or read: it takes about a second, and
``tunnelsense --help`` need not wait for it.  A detector's model is written without
it (:mod:`tunnelsense.io._model_writer`: the same file).
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

__all__ = [
    "MAX_MODEL_BYTES",
    "check_sizes",
    "read_metadata",
    "sign",
    "skops_bytes",
    "verified_bytes",
]

_METADATA = "tunnelsense.json"
_COMMENT_PREFIX = b"tunnelsense-sha256:"
_SIGNATURE_PREFIX = b"tunnelsense-hmac-sha256:"
_ED25519_PREFIX = b"tunnelsense-ed25519:"
_DIGEST_LEN = 64
#: The signatures a zip comment may carry: kind, prefix, hex digits.
_SIGNATURES = (("ed25519", _ED25519_PREFIX, 128),
               ("hmac-sha256", _SIGNATURE_PREFIX, _DIGEST_LEN))

#: Default limit of a model file's size, of each zip member's inflated size and of
#: their total (bytes).  A tunnelsense model holds well under a megabyte of arrays
#: (the largest, the verifier's cluster centres, is a few thousand rows of 32
#: floats); the limit leaves a hundredfold margin and still keeps a bomb far from
#: the memory of a vehicle's computer.
MAX_MODEL_BYTES = 64 * 2**20

#: Limit of the inflated size of ``schema.json`` and the metadata member.
MAX_SCHEMA_BYTES = 8 * 2**20

_MAX_MEMBERS = 10000


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


def skops_bytes(model, summary, *, signed=None) -> bytearray:
    """The skops file with metadata and a zip comment of zeros to fill in."""
    from tunnelsense.io._model_writer import detector_skops_payload

    payload = detector_skops_payload(model)  # a detector's model: skops' file, not skops
    if payload is None:
        import skops.io  # slow to import: see the module's docstring

        payload = skops.io.dumps(model, compression=zipfile.ZIP_DEFLATED)
    metadata = {
        "file_format": "tunnelsense-model",
        "file_format_version": 1,
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "model": type(model).__name__,
        "signed": signed is not None,
        "versions": _versions(),
        "summary": _json_safe(summary or {}),
    }
    buffer = io.BytesIO(payload)
    with zipfile.ZipFile(buffer, "a", compression=zipfile.ZIP_DEFLATED) as zf:
        zf.writestr(_METADATA, json.dumps(metadata, indent=2, sort_keys=True))
        comment = _COMMENT_PREFIX + b"0" * _DIGEST_LEN
        for kind, prefix, length in _SIGNATURES:
            if signed == kind:
                comment = prefix + b"0" * length + comment
        zf.comment = comment
    return bytearray(buffer.getvalue())


def _signature_block(data: bytes) -> tuple[str | None, int, int]:
    """The signature kind in the zip comment and where its hex digits lie.

    Returns ``(kind, start, end)``: ``kind`` is None, ``"hmac-sha256"`` or
    ``"ed25519"``; the signature covers ``data[:start]``.
    """
    end = len(data) - len(_COMMENT_PREFIX) - _DIGEST_LEN
    for kind, prefix, length in _SIGNATURES:
        start = end - length
        if start > len(prefix) and data[start - len(prefix) : start] == prefix:
            return kind, start, end
    return None, end, end


def verified_bytes(path: Path, key=None, verify_key=None, *,
                   max_bytes=None) -> tuple[bytes, str | None]:
    """The file's bytes after the checksum and signature checks.

    ``key`` (a shared HMAC secret) or ``verify_key`` (an Ed25519 public key)
    requires a signature of that kind that matches.  The file itself is read only up
    to ``max_bytes`` (default :data:`MAX_MODEL_BYTES`).  Returns the bytes and the
    kind of signature the file carries (None, ``"hmac-sha256"``, ``"ed25519"``).
    """
    if not path.is_file():
        raise FileNotFoundError(f"{path}: model file not found")
    limit = MAX_MODEL_BYTES if max_bytes is None else int(max_bytes)
    with open(path, "rb") as f:
        data = f.read(limit + 1)
    if len(data) > limit:
        raise UntrustedModelError(
            f"{path}: larger than {limit} bytes (max_bytes), more than a tunnelsense "
            "model holds; refusing to read it"
        )
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
    kind, start, end = _signature_block(data)
    if key is not None or verify_key is not None:
        wanted = "ed25519" if verify_key is not None else "hmac-sha256"
        if kind != wanted:
            raise UntrustedModelError(
                f"{path}: the model is not signed"
                + (f" (it carries a {kind} signature)" if kind else "")
                + f", and a {'public key' if verify_key is not None else 'signing key'}"
                " was given; refusing a model this key did not sign"
            )
        if verify_key is not None:
            ok = _ed25519_verify(verify_key, data[start:end], data[:start])
        else:
            ok = hmac.compare_digest(_hmac(key, data[:start]).encode(), data[start:end])
        if not ok:
            raise UntrustedModelError(
                f"{path}: signature mismatch: the model was not signed with this key, "
                "or was changed after it was signed; refusing to load it"
            )
    return data, kind


def _ed25519_verify(public_key, signature_hex: bytes, data: bytes) -> bool:
    from cryptography.exceptions import InvalidSignature

    try:
        public_key.verify(bytes.fromhex(signature_hex.decode("ascii")), data)
    except (InvalidSignature, ValueError, UnicodeDecodeError):
        return False
    return True


def sign(data: bytearray, *, key=None, sign_key=None) -> bytearray:
    """Fill in the signature and checksum of the bytes from :func:`skops_bytes`."""
    kind, start, end = _signature_block(data)
    if sign_key is not None:
        data[start:end] = sign_key.sign(bytes(data[:start])).hex().encode()
    elif key is not None:
        data[start:end] = _hmac(key, data[:start]).encode()
    body = len(data) - _DIGEST_LEN
    data[body:] = hashlib.sha256(data[:body]).hexdigest().encode()
    return data


def check_sizes(path: Path, zf: zipfile.ZipFile, max_bytes=None) -> None:
    """Refuse a zip whose members would inflate past the limits, before any is read.

    Each member's declared size, and their total, must stay under ``max_bytes``
    (default :data:`MAX_MODEL_BYTES`); the metadata member and ``schema.json`` under
    :data:`MAX_SCHEMA_BYTES`.  ``zipfile`` never inflates a member past its declared
    size (and checks its CRC), so these bounds hold for what is read.
    """
    limit = MAX_MODEL_BYTES if max_bytes is None else int(max_bytes)
    infos = zf.infolist()
    if len(infos) > _MAX_MEMBERS:
        raise UntrustedModelError(f"{path}: {len(infos)} zip members, more than a "
                                  f"tunnelsense model holds ({_MAX_MEMBERS})")
    total = 0
    for info in infos:
        small = info.filename in (_METADATA, "schema.json")
        cap = min(limit, MAX_SCHEMA_BYTES) if small else limit
        if info.file_size > cap:
            raise UntrustedModelError(
                f"{path}: member {info.filename!r} would inflate to {info.file_size} "
                f"bytes, more than the limit of {cap} (max_bytes); refusing to "
                "decompress it"
            )
        total += info.file_size
    if total > limit:
        raise UntrustedModelError(
            f"{path}: its members would inflate to {total} bytes in all, more than "
            f"the limit of {limit} (max_bytes); refusing to decompress them"
        )


def read_metadata(path: Path, data: bytes, max_bytes=None) -> dict:
    """The metadata member, after the size check of every member (:func:`check_sizes`)."""
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            check_sizes(path, zf, max_bytes)
            metadata = json.loads(zf.read(_METADATA))
    except UntrustedModelError:
        raise
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
