"""Signing keys of model files: Ed25519 key pairs, and the older shared HMAC secret.

A fleet signs its models with an Ed25519 **private** key that only the training
machine holds, and every vehicle verifies them with the matching **public** key: a
vehicle cannot sign a model, so one stolen vehicle key forges nothing.  The keys are
PEM files (PKCS #8 private key, SubjectPublicKeyInfo public key) written by
:func:`generate_key_pair` (``tunnelsense keygen``), through the ``cryptography``
package.

The shared-secret HMAC-SHA256 signature is kept for fleets that already use it; it
is the weaker choice, since every verifier holds the secret that signs.

A key that was asked for and cannot be had is an error, never "no key": an empty
environment variable, an empty file name, an empty or unreadable file, a file of
another kind.  Key files are read with a bound (:data:`MAX_KEY_BYTES`), so a path
such as ``/dev/zero`` is refused rather than read without end.
"""

from __future__ import annotations

import os
from pathlib import Path

from tunnelsense.exceptions import InputFormatError

__all__ = [
    "KEY_ENV",
    "MAX_KEY_BYTES",
    "VERIFY_KEY_ENV",
    "generate_key_pair",
    "read_private_key",
    "read_public_key",
    "read_secret",
]

#: Environment variable holding the fleet's shared HMAC secret (the weaker choice).
KEY_ENV = "TUNNELSENSE_MODEL_KEY"

#: Environment variable naming the fleet's Ed25519 public key file.
VERIFY_KEY_ENV = "TUNNELSENSE_VERIFY_KEY"

#: The most bytes read from a key file (a PEM key is a few hundred bytes).
MAX_KEY_BYTES = 16384


def _read_key_file(path, what) -> bytes:
    """At most :data:`MAX_KEY_BYTES` of ``path``; an error for anything unusable."""
    if path is None or str(path).strip() == "":
        raise InputFormatError(f"{what}: an empty file name; name the key file")
    path = Path(path)
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_KEY_BYTES + 1)
    except OSError as exc:
        raise InputFormatError(f"{what} {path}: cannot read the key "
                               f"({exc.strerror or exc})") from None
    if len(data) > MAX_KEY_BYTES:
        raise InputFormatError(f"{what} {path}: more than {MAX_KEY_BYTES} bytes; not "
                               "a key file")
    data = data.strip()
    if not data:
        raise InputFormatError(f"{what} {path}: the file is empty")
    return data


def read_secret(path=None, *, what="--key-file"):
    """A fleet's shared HMAC secret: the stripped bytes of ``path``, else ``$TUNNELSENSE_MODEL_KEY``.

    Parameters
    ----------
    path : str or Path, default=None
        File holding the secret; None reads the environment variable instead.

    Returns
    -------
    key : bytes or None
        None only when no file is named and the variable is not set.

    Raises
    ------
    InputFormatError
        An empty file name, an empty or unreadable file, or the variable set but empty.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "key"
    >>> _ = f.write_bytes(b"fleet-secret\\n")
    >>> read_secret(f)
    b'fleet-secret'
    """
    if path is None:
        value = os.environ.get(KEY_ENV)
        if value is None:
            return None
        if not value.strip():
            raise InputFormatError(f"{KEY_ENV} is set but empty; unset it, or set it "
                                   "to the fleet's secret")
        return value.strip().encode("utf-8")
    return _read_key_file(path, what)


def _crypto():
    from cryptography.hazmat.primitives import serialization
    from cryptography.hazmat.primitives.asymmetric import ed25519

    return serialization, ed25519


def read_private_key(path, *, what="--sign-key"):
    """The Ed25519 private key in the PEM file ``path`` (unencrypted PKCS #8).

    Raises
    ------
    InputFormatError
        An empty file name, or a file that is not an Ed25519 private key.
    """
    data = _read_key_file(path, what)
    serialization, ed25519 = _crypto()
    try:
        key = serialization.load_pem_private_key(data, password=None)
    except (ValueError, TypeError) as exc:
        raise InputFormatError(f"{what} {path}: not an unencrypted PEM private key "
                               f"({exc})") from None
    if not isinstance(key, ed25519.Ed25519PrivateKey):
        raise InputFormatError(f"{what} {path}: a {type(key).__name__}, expected an "
                               "Ed25519 private key (tunnelsense keygen)")
    return key


def read_public_key(path=None, *, what="--verify-key"):
    """The Ed25519 public key in the PEM file ``path``, else in ``$TUNNELSENSE_VERIFY_KEY``.

    Returns
    -------
    key : Ed25519PublicKey or None
        None only when no file is named and the variable is not set.

    Raises
    ------
    InputFormatError
        An empty file name (or variable), or a file that is not an Ed25519 public key.
    """
    if path is None:
        path = os.environ.get(VERIFY_KEY_ENV)
        if path is None:
            return None
        what = VERIFY_KEY_ENV
    data = _read_key_file(path, what)
    serialization, ed25519 = _crypto()
    try:
        key = serialization.load_pem_public_key(data)
    except (ValueError, TypeError) as exc:
        raise InputFormatError(f"{what} {path}: not a PEM public key ({exc})") from None
    if not isinstance(key, ed25519.Ed25519PublicKey):
        raise InputFormatError(f"{what} {path}: a {type(key).__name__}, expected an "
                               "Ed25519 public key (tunnelsense keygen)")
    return key


def generate_key_pair(private_path, *, overwrite=False):
    """Write a new Ed25519 key pair: ``private_path`` and ``private_path + ".pub"``.

    The private key file is created readable by its owner only (mode 0600); it stays
    on the machine that trains and signs models.  The public key is what vehicles
    hold to verify them.

    Parameters
    ----------
    private_path : str or Path
        The private key file to write; the public key goes beside it with ``.pub``
        appended.
    overwrite : bool, default=False
        Replace existing key files.

    Returns
    -------
    private_path, public_path : Path

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> private, public = generate_key_pair(folder / "fleet.key")
    >>> public.name, oct(private.stat().st_mode & 0o777)
    ('fleet.key.pub', '0o600')
    >>> type(read_public_key(public)).__name__.endswith("Ed25519PublicKey")
    True
    """
    from tunnelsense.io._output import atomic_write, check_output

    private_path = Path(private_path)
    public_path = private_path.with_name(private_path.name + ".pub")
    check_output(private_path, overwrite=overwrite, what="private key")
    check_output(public_path, overwrite=overwrite, what="public key")
    serialization, ed25519 = _crypto()
    key = ed25519.Ed25519PrivateKey.generate()
    private_pem = key.private_bytes(serialization.Encoding.PEM,
                                    serialization.PrivateFormat.PKCS8,
                                    serialization.NoEncryption())
    public_pem = key.public_key().public_bytes(
        serialization.Encoding.PEM, serialization.PublicFormat.SubjectPublicKeyInfo)
    with atomic_write(private_path) as f:
        os.chmod(f.fileno(), 0o600)
        f.write(private_pem)
    os.chmod(private_path, 0o600)
    with atomic_write(public_path) as f:
        f.write(public_pem)
    return private_path, public_path
