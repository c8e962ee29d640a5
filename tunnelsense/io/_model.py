"""Shipping fitted models: a safe format (skops) with versions, checksum and signature.

Pickles (``joblib.dump``) run code when they are loaded, so a pickle from an untrusted
source can do anything.  A ``.skops`` file written by :func:`save_model` cannot: it is
read by `skops <https://skops.readthedocs.io>`_, which rebuilds objects only from
types it is told to trust.  :func:`load_model` trusts skops' own reviewed defaults
(built-in containers, NumPy arrays and dtypes, scikit-learn's estimators) and, beyond
them, only the exact names in :data:`TRUSTED_TYPES`: tunnelsense's estimator
classes.  Any other type named in the file (``builtins.exec``, ``os.system``,
``subprocess.Popen``, a function, a class of another package) refuses the whole file
before anything in it is built.  tunnelsense adds to the skops file:

* a metadata member ``tunnelsense.json`` with the versions of tunnelsense,
  scikit-learn, NumPy, SciPy and Python the model was trained under, and a training
  summary (tours, parameters, scores);
* a SHA-256 checksum of every byte of the file, kept in the zip comment, so that a
  corrupted or truncated file is refused before anything in it is read;
* optionally a signature, so that a vehicle can refuse a model its fleet did not
  sign (the checksum alone is no proof of origin, since anyone who edits a file can
  compute it again): an Ed25519 signature with the fleet's private key
  (``sign_key=``), verified with the public key (``verify_key=``); or, the weaker
  choice, an HMAC-SHA256 with a secret shared by signer and verifiers (``key=``).

Reading is bounded: the file, each zip member's declared size and their total must
stay under ``max_bytes`` before anything is decompressed, so a "zip bomb" is refused
without inflating it.

The file stays a valid skops file: ``skops.io.load`` reads it too.

skops is a runtime dependency because it is the maintained, audited way to persist
scikit-learn objects without pickle; writing our own safe deserializer would be more
code and less trust.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import joblib
from sklearn.base import BaseEstimator

from tunnelsense.exceptions import (
    InputFormatError,
    ModelVersionWarning,
    UntrustedModelError,
)
from tunnelsense.io._keys import KEY_ENV
from tunnelsense.io._model_file import (
    MAX_MODEL_BYTES,
    _as_key,
    _versions,
    read_metadata,
    sign,
    skops_bytes,
    verified_bytes,
)
from tunnelsense.io._output import atomic_write, check_output

__all__ = [
    "KEY_ENV",
    "MAX_MODEL_BYTES",
    "TRUSTED_TYPES",
    "ModelVersionWarning",
    "UntrustedModelError",
    "describe_model",
    "load_model",
    "save_model",
]

_PICKLE_SUFFIXES = (".joblib", ".pkl", ".pickle")

#: The exact type names, beyond skops' own trusted defaults, that a model file may
#: hold: tunnelsense's estimators, nothing else.  (scikit-learn's ``Tree`` is left out
#: on purpose, as skops leaves it: its ``__setstate__`` does not check child indices,
#: and a forged tree crashes ``predict`` or reads memory out of bounds.)
TRUSTED_TYPES = frozenset(
    [
        "tunnelsense.tunnel._keypoints.IntensityKeypointSampler",
        "tunnelsense.tunnel._verification.KMeansHistogramVerifier",
        "tunnelsense.tunnel._clustering.MSTClusterer",
        "tunnelsense.tunnel._appearance.WeightedAdaBoost",
        "tunnelsense.tunnel._tracking.TrajectoryLinker",
        "tunnelsense.tunnel._motion.PCCVerifier",
        "tunnelsense.street._detector.ScanClusterer",
        "tunnelsense.positioning._positioner.TunnelPositioner",
    ]
)



def _model_format(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix not in (*_PICKLE_SUFFIXES, ".skops"):
        raise ValueError(
            f"{path}: unknown model format {suffix or '(no extension)'!r}; use .skops "
            "(safe) or .joblib (pickle)"
        )
    return suffix


def _check_key_type(value, name, cls_name):
    if value is not None and type(value).__name__ != cls_name:
        raise TypeError(f"{name} must be an {cls_name} (tunnelsense.io.read_"
                        f"{'private' if 'Private' in cls_name else 'public'}_key), "
                        f"got {type(value).__name__}")


def save_model(model, path, *, summary=None, key=None, sign_key=None,
               overwrite=False) -> Path:
    """Save a fitted model for shipping.

    The format follows the file's extension: ``.skops`` writes the safe format (no code
    runs on load; versions, summary and checksum inside); ``.joblib`` / ``.pkl`` write
    a plain joblib pickle.  The file is written under a temporary name and renamed
    when complete, so an interrupted save never leaves half a model.

    Parameters
    ----------
    model : estimator
        A fitted estimator or pipeline.
    path : str or Path
        Target file; its extension chooses the format.
    summary : dict, default=None
        Training summary to store (tours, parameters, scores); JSON-able values, other
        objects are stored as their ``repr``.
    key : str or bytes, default=None
        A secret of at least 16 bytes: sign the ``.skops`` file with HMAC-SHA256, so
        that :func:`load_model` with the same key can tell it was written by a holder
        of the key.  The weaker choice: every verifier can sign too; prefer
        ``sign_key``.
    sign_key : Ed25519PrivateKey, default=None
        Sign the ``.skops`` file with this private key
        (:func:`~tunnelsense.io.read_private_key`); :func:`load_model` verifies it
        with the public key alone.
    overwrite : bool, default=False
        Whether to replace an existing file.

    Returns
    -------
    path : Path

    Raises
    ------
    OutputExistsError
        ``path`` exists and ``overwrite`` is false.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from sklearn.linear_model import LogisticRegression
    >>> from tunnelsense.io import load_model, save_model
    >>> model = LogisticRegression().fit([[0], [1]], [0, 1])
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "model.skops"
    >>> _ = save_model(model, path, summary={"tours": ["tour-01"]})
    >>> load_model(path).predict([[1]]).tolist()
    [1]
    """
    path = Path(path)
    suffix = _model_format(path)
    key = _as_key(key)
    _check_key_type(sign_key, "sign_key", "Ed25519PrivateKey")
    if key is not None and sign_key is not None:
        raise ValueError("pass one of key (HMAC) and sign_key (Ed25519), not both")
    check_output(path, overwrite=overwrite, what="model file")
    if suffix in _PICKLE_SUFFIXES:
        if key is not None or sign_key is not None:
            raise ValueError(f"{path}: only .skops files can be signed")
        with atomic_write(path) as f:
            joblib.dump(model, f)
        return path
    kind = "ed25519" if sign_key is not None else "hmac-sha256" if key else None
    data = sign(skops_bytes(model, summary, signed=kind), key=key, sign_key=sign_key)
    with atomic_write(path) as f:
        f.write(bytes(data))
    return path



def load_model(path, *, allow_pickle=False, key=None, verify_key=None,
               max_bytes=MAX_MODEL_BYTES):
    """Load a model written by :func:`save_model`.

    A ``.skops`` file is verified before anything in it is built: its checksum must
    match (else it was corrupted, truncated or edited), with ``key`` its signature
    must match (else someone without the key wrote or changed it), and every type it
    names must be one of skops' trusted defaults or in :data:`TRUSTED_TYPES` (else it
    could run code).  A model trained under other library versions loads with a
    :class:`~tunnelsense.exceptions.ModelVersionWarning`.

    Parameters
    ----------
    path : str or Path
        A ``.skops`` file, or a ``.joblib`` pickle.
    allow_pickle : bool, default=False
        Pickles run code when loaded; load one only with ``allow_pickle=True``, and
        only from a source you trust.
    key : str or bytes, default=None
        The shared HMAC secret: refuse a ``.skops`` file not signed with it.
    verify_key : Ed25519PublicKey, default=None
        The fleet's public key (:func:`~tunnelsense.io.read_public_key`): refuse a
        ``.skops`` file not signed with the matching private key.
    max_bytes : int, default=MAX_MODEL_BYTES
        Limit of the file's size, of each zip member's inflated size and of their
        total: a file past it is refused before anything is decompressed.

    Returns
    -------
    model : estimator

    Raises
    ------
    UntrustedModelError
        The file is not a tunnelsense model file, its checksum or signature does not
        match, or it names a type outside the trusted ones.
    """
    path = Path(path)
    suffix = _model_format(path)
    key = _as_key(key)
    _check_key_type(verify_key, "verify_key", "Ed25519PublicKey")
    if suffix in _PICKLE_SUFFIXES:
        if not allow_pickle:
            raise UntrustedModelError(
                f"{path}: a pickle runs code when loaded; pass allow_pickle=True only if "
                "you trust its source, or ship models in the safe .skops format"
            )
        if key is not None or verify_key is not None:
            raise UntrustedModelError(
                f"{path}: a pickle cannot be signed; a signing key was given, so only "
                "signed .skops models are accepted"
            )
        model = joblib.load(path)
        _check_parameters(model, path)
        return model
    import skops.io  # slow to import: only when a model is read

    data, _ = verified_bytes(path, key, verify_key, max_bytes=max_bytes)
    metadata = read_metadata(path, data, max_bytes)
    untrusted = _trusted_types_of(path, data)
    _warn_versions(path, metadata)
    try:
        model = skops.io.loads(data, trusted=untrusted)
    except Exception as exc:  # a schema skops cannot build: refuse the file
        raise UntrustedModelError(
            f"{path}: malformed model file ({type(exc).__name__}: {exc})"
        ) from None
    _check_parameters(model, path)
    return model


def _trusted_types_of(path: Path, data: bytes) -> list[str]:
    """The types beyond skops' defaults the file names; refuse any not trusted.

    Nothing is built: skops reads the schema only.
    """
    import skops.io  # slow to import: only when a model is read

    try:
        untrusted = skops.io.get_untrusted_types(data=data)
    except Exception as exc:  # skops raises various errors on malformed schemas
        raise UntrustedModelError(f"{path}: malformed model file ({exc})") from None
    refused = sorted(t for t in untrusted if t not in TRUSTED_TYPES)
    if refused:
        raise UntrustedModelError(
            f"{path}: names types that are not trusted (they could run code when "
            f"loaded): {', '.join(refused)}; refusing to load it"
        )
    return sorted(untrusted)


def _warn_versions(path: Path, metadata: dict) -> None:
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
            stacklevel=3,
        )


def _check_parameters(model, path: Path) -> None:
    """Refuse a model whose estimators lack parameters the installed code expects.

    A model saved by an older tunnelsense has no attribute for a parameter added
    since; it would fail deep inside ``predict``.  Say so when it is loaded instead.
    """
    stack = [model]
    while stack:
        est = stack.pop()
        if not isinstance(est, BaseEstimator):
            continue
        names = est._get_param_names()
        missing = [n for n in names if not hasattr(est, n)]
        if missing:
            raise InputFormatError(
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


def describe_model(path, *, key=None, verify_key=None,
                   max_bytes=MAX_MODEL_BYTES) -> dict:
    """What a model file holds (versions, training summary, pipeline steps).

    For a ``.skops`` file this reads the metadata only (after the checksum check, the
    size check of its members and the check of the types it names), never builds the
    model; a pickle is not opened at all.  ``signature`` says what is known of the
    file's origin: ``"none"``, ``"<kind>, not verified"`` (no key given), or
    ``"<kind>, verified"`` when ``verify_key`` (Ed25519) or ``key`` (HMAC) matches;
    a key that does not match raises :class:`UntrustedModelError`.
    """
    path = Path(path)
    suffix = _model_format(path)
    key = _as_key(key)
    _check_key_type(verify_key, "verify_key", "Ed25519PublicKey")
    if suffix in _PICKLE_SUFFIXES:
        if not path.is_file():
            raise FileNotFoundError(f"{path}: model file not found")
        if key is not None or verify_key is not None:
            raise UntrustedModelError(f"{path}: a pickle cannot be signed; a key was "
                                      "given, so it is refused")
        return {
            "kind": "model",
            "format": "pickle",
            "path": str(path),
            "bytes": path.stat().st_size,
            "note": "pickles run code when loaded; not opened",
        }
    data, kind = verified_bytes(path, key, verify_key, max_bytes=max_bytes)
    metadata = read_metadata(path, data, max_bytes)
    _trusted_types_of(path, data)
    checked = key is not None or verify_key is not None
    metadata.pop("signed", None)  # what the writer said; the comment is what counts
    return {
        "kind": "model",
        "format": "skops",
        "path": str(path),
        "bytes": len(data),
        **metadata,
        "signature": "none" if kind is None
        else f"{kind}, {'verified' if checked else 'not verified'}",
    }
