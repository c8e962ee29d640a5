"""A model file must never run code: crafted .skops files, signatures, safe saving."""

import hashlib
import io
import json
import os
import zipfile

import numpy as np
import pytest
from sklearn.linear_model import LogisticRegression

import tunnelsense
from tunnelsense import make_indicator_pipeline, make_parking_pipeline, to_xy
from tunnelsense._cli import main
from tunnelsense.datasets import make_street_scans, make_tunnel_tour
from tunnelsense.exceptions import OutputExistsError, UntrustedModelError
from tunnelsense.io import (
    TRUSTED_TYPES,
    describe_model,
    load_model,
    save_model,
    write_run,
    write_tour,
)

KEY = "fleet-secret-0123456789"


@pytest.fixture(scope="module")
def detectors(tmp_path_factory):
    """Genuine fitted detectors of both kinds, saved as .skops, and their inputs."""
    folder = tmp_path_factory.mktemp("detectors")
    tour = make_tunnel_tour(240, scenario="light", random_state=3, name="tour")
    X, y, _ = to_xy([tour])
    indicator = make_indicator_pipeline(random_state=0).fit(X, y)
    run = make_street_scans(500, random_state=3, name="run")
    Xs, ys, _ = to_xy([run])
    parking = make_parking_pipeline().fit(Xs, ys)
    return {
        "tunnel": save_model(indicator, folder / "tunnel.skops"),
        "street": save_model(parking, folder / "street.skops"),
        "tour": write_tour(tour, folder / "tour"),
        "run": write_run(run, folder / "run"),
    }


def _schema_rewrite(path, out, edit):
    """Edit a model's schema and recompute its checksum, as an attacker could."""
    src = zipfile.ZipFile(io.BytesIO(path.read_bytes()))
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as dst:
        for item in src.infolist():
            payload = src.read(item.filename)
            if item.filename == "schema.json":
                payload = json.dumps(edit(json.loads(payload))).encode()
            dst.writestr(item, payload)
        dst.comment = b"tunnelsense-sha256:" + b"0" * 64
    raw = bytearray(buffer.getvalue())
    raw[-64:] = hashlib.sha256(raw[:-64]).hexdigest().encode()
    out.write_bytes(bytes(raw))
    return out


def _json(value):
    return {"__class__": "str", "__module__": "builtins", "__loader__": "JsonNode",
            "content": json.dumps(value), "is_json": True}


def _call(module, name, *args):
    """A skops node that, if built, calls ``module.name(*args)``."""
    return {
        "__class__": name,
        "__module__": module,
        "__loader__": "ConstructorFromReduceNode",
        "content": {"__class__": "tuple", "__module__": "builtins",
                    "__loader__": "TupleNode", "content": [_json(a) for a in args]},
    }


def _attacks(marker):
    code = f"open({str(marker)!r}, 'w').write('ran')"
    return {
        "builtins.exec": _call("builtins", "exec", code),
        "builtins.eval": _call("builtins", "eval", code),
        f"{os.system.__module__}.system": _call(os.system.__module__, "system", f"touch {marker}"),
        "subprocess.Popen": _call("subprocess", "Popen", ["touch", str(marker)]),
        # a prefix of a trusted name is not trusted
        "tunnelsense._cli.main": _call("tunnelsense._cli", "main",
                                       ["simulate", "street", str(marker)]),
    }


def _inject(node):
    def edit(schema):
        # a new attribute of the pipeline's first step
        steps = schema["content"]["content"]["steps"]["content"]
        steps[0]["content"][1]["content"]["content"]["payload_"] = node
        return schema

    return edit


@pytest.mark.parametrize("attack", list(_attacks("m")))
@pytest.mark.parametrize("kind", ["tunnel", "street"])
def test_crafted_model_is_refused_everywhere_and_runs_nothing(
    detectors, tmp_path, attack, kind, capsys
):
    marker = tmp_path / "marker"
    crafted = _schema_rewrite(detectors[kind], tmp_path / "crafted.skops",
                              _inject(_attacks(marker)[attack]))
    import skops.io  # the file is well-formed: skops itself names the type

    assert attack in skops.io.get_untrusted_types(data=crafted.read_bytes())
    with pytest.raises(UntrustedModelError, match=rf"not trusted.*{attack}"):
        load_model(crafted)
    with pytest.raises(UntrustedModelError, match=attack):
        describe_model(crafted)
    source = detectors["tour" if kind == "tunnel" else "run"]
    out = tmp_path / "out.txt"
    for argv in (
        ["detect", kind, "--model", str(crafted), str(source), "--out", str(out),
         "--quiet"],
        ["info", str(crafted)],
    ):
        assert main(argv) == 1
        assert attack in capsys.readouterr().err
    assert not marker.exists()
    assert not out.exists()


def test_genuine_detectors_load(detectors):
    for kind in ("tunnel", "street"):
        model = load_model(detectors[kind])
        assert model.steps[-1][0] == ("motion" if kind == "tunnel" else "cluster")


def test_trusted_types_are_exact_names_of_the_estimators():
    classes = [getattr(tunnelsense, n) for n in tunnelsense.__all__]
    estimators = {
        f"{c.__module__}.{c.__qualname__}"
        for c in classes
        if isinstance(c, type) and hasattr(c, "get_params")
    }
    assert estimators == TRUSTED_TYPES
    # nothing in the list is a module prefix or a callable other than a class
    for name in TRUSTED_TYPES:
        module, _, attr = name.rpartition(".")
        assert isinstance(getattr(__import__(module, fromlist=[attr]), attr), type)


def test_signed_model_needs_the_key(tmp_path):
    model = LogisticRegression().fit([[0], [1]], [0, 1])
    signed = save_model(model, tmp_path / "signed.skops", key=KEY)
    plain = save_model(model, tmp_path / "plain.skops")
    assert load_model(signed, key=KEY).predict([[1]]).tolist() == [1]
    assert load_model(signed).predict([[1]]).tolist() == [1]  # checksum still checked
    assert describe_model(signed)["signature"] == "hmac-sha256, not verified"
    assert describe_model(signed, key=KEY)["signature"] == "hmac-sha256, verified"
    assert describe_model(plain)["signature"] == "none"
    with pytest.raises(UntrustedModelError, match="signature mismatch"):
        load_model(signed, key="another-secret-0123456789")
    with pytest.raises(UntrustedModelError, match="not signed"):
        load_model(plain, key=KEY)
    # an attacker re-signing the checksum cannot forge the signature
    data = bytearray(signed.read_bytes())
    i = data.index(b"tunnelsense.json")
    data[i - 40] ^= 1
    data[-64:] = hashlib.sha256(bytes(data[:-64])).hexdigest().encode()
    forged = tmp_path / "forged.skops"
    forged.write_bytes(bytes(data))
    with pytest.raises(UntrustedModelError, match="signature mismatch"):
        load_model(forged, key=KEY)
    with pytest.raises(ValueError, match="at least 16 bytes"):
        save_model(model, tmp_path / "short.skops", key="short")


def test_cli_signs_and_checks_with_the_environment_key(detectors, tmp_path, capsys,
                                                       monkeypatch):
    monkeypatch.setenv("TUNNELSENSE_MODEL_KEY", KEY)
    out = tmp_path / "r.txt"
    # the genuine model is not signed: a vehicle holding a key refuses it
    assert main(["detect", "tunnel", "--model", str(detectors["tunnel"]),
                 str(detectors["tour"]), "--out", str(out), "--quiet"]) == 1
    assert "not signed" in capsys.readouterr().err
    assert not out.exists()
    signed = save_model(load_model(detectors["tunnel"]), tmp_path / "s.skops", key=KEY)
    assert main(["detect", "tunnel", "--model", str(signed), str(detectors["tour"]),
                 "--out", str(out), "--quiet"]) == 0


def test_save_never_destroys_an_existing_file(tmp_path):
    model = LogisticRegression().fit([[0], [1]], [0, 1])
    path = tmp_path / "m.skops"
    path.write_bytes(b"precious")
    with pytest.raises(OutputExistsError, match="m.skops: exists"):
        save_model(model, path)
    assert path.read_bytes() == b"precious"
    save_model(model, path, overwrite=True)
    assert load_model(path).predict([[0]]).tolist() == [0]
    assert [p.name for p in tmp_path.iterdir()] == ["m.skops"]  # no temporary left


def test_failed_save_leaves_the_old_model(tmp_path):
    model = LogisticRegression().fit([[0], [1]], [0, 1])
    path = save_model(model, tmp_path / "m.joblib")
    before = path.read_bytes()

    class Unpicklable:
        def __reduce__(self):
            raise RuntimeError("cannot pickle")

    with pytest.raises(RuntimeError, match="cannot pickle"):
        save_model({"x": Unpicklable()}, path, overwrite=True)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["m.joblib"]


@pytest.mark.parametrize("where", ["/dev/tunnelsense-m.skops", "/dev/shm/tunnelsense-m.skops"])
def test_never_writes_into_device_folders(where):
    model = LogisticRegression().fit([[0], [1]], [0, 1])
    with pytest.raises(ValueError, match="device folder"):
        save_model(model, where, overwrite=True)
    assert not os.path.exists(where)


def test_random_bytes_and_edits_are_refused(tmp_path, global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    model = LogisticRegression().fit([[0], [1]], [0, 1])
    good = save_model(model, tmp_path / "m.skops").read_bytes()
    path = tmp_path / "x.skops"
    for _ in range(20):
        data = bytearray(good)
        data[int(rng.integers(len(data)))] ^= int(rng.integers(1, 256))
        path.write_bytes(bytes(data))
        with pytest.raises(UntrustedModelError):
            load_model(path)


class _Evil:
    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


def test_a_pickled_array_member_is_refused(tmp_path):
    """An .npy member holding a pickled object array: never unpickled."""
    model = LogisticRegression().fit([[0], [1]], [0, 1])
    path = save_model(model, tmp_path / "m.skops")
    marker = tmp_path / "marker"
    evil = io.BytesIO()
    np.save(evil, np.array([_Evil(marker)], dtype=object), allow_pickle=True)
    src = zipfile.ZipFile(io.BytesIO(path.read_bytes()))
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename.endswith(".npy"):
                data = evil.getvalue()
            dst.writestr(item, data)
        dst.comment = b"tunnelsense-sha256:" + b"0" * 64
    raw = bytearray(out.getvalue())
    raw[-64:] = hashlib.sha256(bytes(raw[:-64])).hexdigest().encode()
    crafted = tmp_path / "crafted.skops"
    crafted.write_bytes(bytes(raw))
    with pytest.raises(UntrustedModelError, match="Object arrays cannot be loaded"):
        load_model(crafted)
    assert not marker.exists()


def test_a_decision_tree_is_not_trusted(tmp_path):
    """scikit-learn's Tree does not check its child indices: a forged one crashes
    predict, so model files may not hold one (as skops itself does not trust it)."""
    from sklearn.tree import DecisionTreeClassifier

    path = save_model(DecisionTreeClassifier(max_depth=1).fit([[0], [1]], [0, 1]),
                      tmp_path / "tree.skops")
    with pytest.raises(UntrustedModelError, match=r"not trusted .*sklearn\.tree\._tree\.Tree"):
        load_model(path)
