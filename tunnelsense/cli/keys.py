"""``tunnelsense keygen``: a fleet's Ed25519 key pair for signing models."""

from __future__ import annotations

__all__ = ["register_top"]


def _cmd_keygen(args) -> int:
    from tunnelsense.io._keys import generate_key_pair

    private, public = generate_key_pair(args.private, overwrite=args.force)
    print(f"wrote {private} (private key: keep it on the machine that trains, "
          f"sign with 'train ... --sign-key {private}') and {public} (public key: "
          f"give it to the vehicles, verify with '--verify-key {public}')")
    return 0


def register_top(sub) -> None:
    """Add the ``keygen`` command."""
    p = sub.add_parser(
        "keygen", help="write an Ed25519 key pair for signing and verifying models",
        description="Write a new Ed25519 key pair: PRIVATE (readable by its owner "
        "only) signs models ('train ... --sign-key PRIVATE'), PRIVATE.pub verifies "
        "them ('detect ... --verify-key PRIVATE.pub').")
    p.add_argument("private", metavar="PRIVATE", help="the private key file to write; "
                   "the public key is written beside it as PRIVATE.pub")
    p.add_argument("--force", action="store_true", help="replace existing key files")
    p.set_defaults(func=_cmd_keygen)
