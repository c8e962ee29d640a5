"""Opening the model file a user names: a pickle only when trusted, of the right kind.

What the commands' ``--model``, ``--trust-pickle``, ``--verify-key`` and
``--key-file`` do, callable from Python: :func:`load_trusted_model` refuses a pickle
unless told to trust it, and reads a detector's ``.skops`` file strictly (an exact
vocabulary of types, then exactly the detector's pipeline).
"""

from __future__ import annotations

import sys
from pathlib import Path

from tunnelsense.exceptions import UntrustedModelError
from tunnelsense.io._keys import read_secret
from tunnelsense.io._model import (
    MAX_MODEL_BYTES,
    _check_key_type,
    _warn_versions,
    load_model,
)
from tunnelsense.io._model_checks import check_detector
from tunnelsense.io._model_file import _as_key, read_metadata, verified_bytes
from tunnelsense.io._model_strict import read_strict

# the model path's check lives beside the other output checks, which import no
# scikit-learn: a training command makes it before its frames are decoded
from tunnelsense.io._output import PICKLE_SUFFIXES, check_model_path

__all__ = ["PICKLE_SUFFIXES", "check_model_path", "load_trusted_model", "read_signing_key"]


def read_signing_key(path=None):
    """A fleet's shared HMAC secret (:func:`~tunnelsense.io.read_secret`).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "key"
    >>> _ = f.write_bytes(b"fleet-secret\\n")
    >>> read_signing_key(f)
    b'fleet-secret'
    """
    return read_secret(path)


#: The last step of each detector's pipeline, and the detector.
_DETECTORS = {"motion": "tunnel", "cluster": "street"}


def load_trusted_model(path, *, last_step, command, trust_pickle=False, key=None,
                       verify_key=None, max_bytes=MAX_MODEL_BYTES):
    """Load a model file (:func:`~tunnelsense.io.load_model`) that a command may use.

    Parameters
    ----------
    path : str or Path
        A ``.skops`` file, or a pickle (``.joblib``, ``.pkl``, ``.pickle``).
    last_step : str
        Name the pipeline's last step must have (``"motion"``, ``"cluster"``).
    command : str
        The command that writes such models, for the message (``"train street"``).
    trust_pickle : bool, default=False
        Load a pickle (it can run any code); a note says so on stderr.
    key : bytes or str, default=None
        Refuse a ``.skops`` file not signed with this shared HMAC secret.
    verify_key : Ed25519PublicKey, default=None
        Refuse a ``.skops`` file not signed with the private key of this public key.
    max_bytes : int, default=MAX_MODEL_BYTES
        Limit of the file and of its members' inflated sizes.

    Returns
    -------
    model : Pipeline

    Raises
    ------
    UntrustedModelError
        A pickle without ``trust_pickle``; for a detector's ``.skops`` file (last step
        ``"motion"`` or ``"cluster"``), anything but exactly that detector's fitted
        pipeline (see :mod:`tunnelsense.io._model_strict`).
    ValueError
        A model whose last step is not ``last_step``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from tunnelsense.io import save_model
    >>> from tunnelsense.street import make_parking_pipeline
    >>> from tunnelsense import to_xy
    >>> from tunnelsense.datasets import make_street_scans
    >>> X, y, _ = to_xy([make_street_scans(100, random_state=0)])
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "street.skops"
    >>> _ = save_model(make_parking_pipeline().fit(X, y), path)
    >>> load_trusted_model(path, last_step="cluster", command="train street").steps[-1][0]
    'cluster'
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: model file not found")
    pickle = path.suffix.lower() in PICKLE_SUFFIXES
    if pickle and not trust_pickle:
        raise UntrustedModelError(
            f"--model {path}: a pickle runs code when loaded; pass --trust-pickle "
            "only if you trust its source, or ship .skops models"
        )
    if pickle:
        print(f"note: loading the pickle {path} (--trust-pickle): it can run any code",
              file=sys.stderr)
    kind = _DETECTORS.get(last_step)
    _check_key_type(verify_key, "verify_key", "Ed25519PublicKey")
    if kind is not None and not pickle:
        data, _ = verified_bytes(path, _as_key(key), verify_key, max_bytes=max_bytes)
        _warn_versions(path, read_metadata(path, data, max_bytes))
        try:
            return check_detector(read_strict(path, data, max_bytes=max_bytes), kind,
                                  path)
        except UntrustedModelError as exc:
            raise UntrustedModelError(
                f"{exc} (not a model written by 'tunnelsense {command}')") from None
    model = load_model(path, allow_pickle=pickle, key=key, verify_key=verify_key,
                       max_bytes=max_bytes)
    steps = getattr(model, "steps", None)
    if not steps or steps[-1][0] != last_step:
        raise ValueError(f"{path}: not a model written by 'tunnelsense {command}'")
    return model
