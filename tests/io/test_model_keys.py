"""Signed models: Ed25519 key pairs, the shared HMAC secret, keys that cannot be had."""

import os
import subprocess
import sys
import textwrap

import pytest
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

from tunnelsense._cli import main
from tunnelsense.exceptions import InputFormatError, UntrustedModelError
from tunnelsense.io import (
    describe_model,
    generate_key_pair,
    load_model,
    read_private_key,
    read_public_key,
    read_secret,
    save_model,
)

SECRET = "fleet-secret-0123456789"


def _model():
    return Pipeline([("scale", StandardScaler())]).fit([[0.0], [1.0]])


@pytest.fixture
def pair(tmp_path):
    return generate_key_pair(tmp_path / "keys" / "fleet.key")


def test_keygen_writes_a_private_key_only_its_owner_reads(pair):
    private, public = pair
    assert private.stat().st_mode & 0o777 == 0o600
    assert public.read_bytes().startswith(b"-----BEGIN PUBLIC KEY-----")
    with pytest.raises(FileExistsError):
        generate_key_pair(private)
    read_private_key(private)  # both parse
    read_public_key(public)


def test_a_signed_model_verifies_with_the_public_key_in_a_fresh_process(pair, tmp_path):
    """The vehicle: a fresh process, a folder that never held the private key."""
    private, public = pair
    signed = save_model(_model(), tmp_path / "signed.skops",
                        sign_key=read_private_key(private))
    vehicle = tmp_path / "vehicle"
    vehicle.mkdir()
    (vehicle / "fleet.pub").write_bytes(public.read_bytes())
    (vehicle / "m.skops").write_bytes(signed.read_bytes())
    private.unlink()  # gone from the machine, too
    code = textwrap.dedent("""
        import sys
        from tunnelsense.io import describe_model, load_model, read_public_key
        key = read_public_key("fleet.pub")
        print(describe_model("m.skops")["signature"])
        print(describe_model("m.skops", verify_key=key)["signature"])
        print(load_model("m.skops", verify_key=key).steps[0][0])
    """)
    env = {k: v for k, v in os.environ.items() if not k.startswith("TUNNELSENSE_")}
    done = subprocess.run([sys.executable, "-c", code], cwd=vehicle, env=env,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split("\n")[:3] == ["ed25519, not verified", "ed25519, verified",
                                           "scale"]


def test_another_key_or_an_edit_is_refused(pair, tmp_path):
    private, public = pair
    other_private, other_public = generate_key_pair(tmp_path / "other.key")
    signed = save_model(_model(), tmp_path / "s.skops", sign_key=read_private_key(private))
    with pytest.raises(UntrustedModelError, match="signature mismatch"):
        load_model(signed, verify_key=read_public_key(other_public))
    with pytest.raises(UntrustedModelError, match="signature mismatch"):
        describe_model(signed, verify_key=read_public_key(other_public))
    # an attacker who edits the file and recomputes the checksum
    import hashlib

    data = bytearray(signed.read_bytes())
    i = data.index(b"tunnelsense.json")
    data[i - 40] ^= 1
    data[-64:] = hashlib.sha256(bytes(data[:-64])).hexdigest().encode()
    forged = tmp_path / "forged.skops"
    forged.write_bytes(bytes(data))
    with pytest.raises(UntrustedModelError, match="signature mismatch"):
        load_model(forged, verify_key=read_public_key(public))
    # an HMAC-signed or unsigned model is refused when a public key is given
    plain = save_model(_model(), tmp_path / "p.skops")
    hmac_signed = save_model(_model(), tmp_path / "h.skops", key=SECRET)
    for path in (plain, hmac_signed):
        with pytest.raises(UntrustedModelError, match="not signed"):
            load_model(path, verify_key=read_public_key(public))
    with pytest.raises(UntrustedModelError, match="not signed"):
        load_model(signed, key=SECRET)


@pytest.mark.parametrize("bad", ["empty-name", "empty-file", "dev-zero", "missing",
                                 "not-a-key", "private-for-public"])
def test_a_key_that_cannot_be_had_is_an_error(pair, tmp_path, bad):
    private, public = pair
    (tmp_path / "empty").write_bytes(b"\n")
    (tmp_path / "junk").write_bytes(b"not a key")
    path = {"empty-name": "", "empty-file": tmp_path / "empty", "dev-zero": "/dev/zero",
            "missing": tmp_path / "none", "not-a-key": tmp_path / "junk",
            "private-for-public": private}[bad]
    with pytest.raises(InputFormatError):
        read_public_key(path)
    if bad != "private-for-public":
        with pytest.raises(InputFormatError):
            read_private_key(path if bad != "not-a-key" else public)
    if bad in ("empty-name", "empty-file", "dev-zero", "missing"):
        with pytest.raises(InputFormatError):
            read_secret(path)


def test_an_empty_environment_key_is_an_error(monkeypatch):
    monkeypatch.setenv("TUNNELSENSE_MODEL_KEY", "")
    with pytest.raises(InputFormatError, match="TUNNELSENSE_MODEL_KEY is set but empty"):
        read_secret()
    monkeypatch.setenv("TUNNELSENSE_VERIFY_KEY", "")
    with pytest.raises(InputFormatError, match="TUNNELSENSE_VERIFY_KEY"):
        read_public_key()
    monkeypatch.delenv("TUNNELSENSE_MODEL_KEY")
    monkeypatch.delenv("TUNNELSENSE_VERIFY_KEY")
    assert read_secret() is None and read_public_key() is None


@pytest.fixture(scope="module")
def street(tmp_path_factory):
    from tunnelsense.datasets import make_street_scans
    from tunnelsense.io import write_run

    folder = tmp_path_factory.mktemp("street")
    return write_run(make_street_scans(300, random_state=4, name="run"), folder / "run")


def test_cli_signs_verifies_and_refuses_empty_keys(street, tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("TUNNELSENSE_MODEL_KEY", raising=False)
    monkeypatch.delenv("TUNNELSENSE_VERIFY_KEY", raising=False)
    private = tmp_path / "fleet.key"
    assert main(["keygen", str(private)]) == 0
    public = tmp_path / "fleet.key.pub"
    model = tmp_path / "m.skops"
    assert main(["train", "street", str(street), "--model", str(model),
                 "--sign-key", str(private)]) == 0
    assert "signed (Ed25519)" in capsys.readouterr().out
    out = tmp_path / "o.csv"
    assert main(["info", str(model)]) == 0
    assert "signature: ed25519, not verified" in capsys.readouterr().out
    assert main(["info", str(model), "--verify-key", str(public)]) == 0
    assert "signature: ed25519, verified" in capsys.readouterr().out
    other = tmp_path / "other.key"
    assert main(["keygen", str(other)]) == 0
    capsys.readouterr()
    assert main(["info", str(model), "--verify-key", f"{other}.pub"]) == 1
    assert "signature mismatch" in capsys.readouterr().err
    assert main(["detect", "street", "--model", str(model), str(street), "--out",
                 str(out), "--verify-key", f"{other}.pub", "--quiet"]) == 1
    assert not out.exists()
    monkeypatch.setenv("TUNNELSENSE_VERIFY_KEY", str(public))
    assert main(["detect", "street", "--model", str(model), str(street), "--out",
                 str(out), "--quiet"]) == 0
    monkeypatch.delenv("TUNNELSENSE_VERIFY_KEY")
    capsys.readouterr()
    # a key asked for and not had: never "no key"
    unsigned = tmp_path / "u.skops"
    assert main(["train", "street", str(street), "--model", str(unsigned)]) == 0
    for argv, env in (
        (["--key-file", ""], None),
        (["--key-file", "/dev/zero"], None),
        (["--verify-key", ""], None),
        ([], ("TUNNELSENSE_MODEL_KEY", "")),
        ([], ("TUNNELSENSE_VERIFY_KEY", "")),
    ):
        if env:
            monkeypatch.setenv(*env)
        out.unlink(missing_ok=True)
        assert main(["detect", "street", "--model", str(unsigned), str(street), "--out",
                     str(out), "--quiet", *argv]) == 1, (argv, env)
        err = capsys.readouterr().err
        assert "error:" in err and "internal" not in err
        assert not out.exists()
        if env:
            monkeypatch.delenv(env[0])
