import hashlib
import io
import json
import subprocess
import sys
import zipfile

import joblib
import numpy as np
import pytest
from sklearn.linear_model import LogisticRegression
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

from tunnelsense._cli import main
from tunnelsense.io import (
    ModelVersionWarning,
    UntrustedModelError,
    describe_model,
    load_model,
    save_model,
)


class NotTrusted:
    """A type from outside the trusted modules."""

    def __init__(self):
        self.value = 1


@pytest.fixture
def model(global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    X = rng.normal(size=(60, 3))
    y = (X[:, 0] + X[:, 1] > 0).astype(int)
    pipe = Pipeline(
        [("scale", StandardScaler()), ("tree", LogisticRegression())]
    )
    return pipe.fit(X, y), X


def test_safe_round_trip_with_card(model, tmp_path, capsys):
    pipe, X = model
    path = save_model(
        pipe,
        tmp_path / "m.skops",
        summary={"tours": ["a", "b"], "score": np.float64(0.5)},
    )
    back = load_model(path)
    assert np.array_equal(back.predict(X), pipe.predict(X))
    card = describe_model(path)
    assert card["format"] == "skops" and card["summary"] == {
        "tours": ["a", "b"],
        "score": 0.5,
    }
    assert set(card["versions"]) >= {"tunnelsense", "scikit-learn", "numpy"}
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "skops model file" in out and "trained under scikit-learn" in out
    import skops.io  # still a plain skops file for other tools

    assert np.array_equal(
        skops.io.loads(
            path.read_bytes(), trusted=skops.io.get_untrusted_types(file=path)
        ).predict(X),
        pipe.predict(X),
    )


@pytest.mark.parametrize("where", [0, 0.25, 0.5, 0.75, -70, -1])
def test_one_byte_changed_is_refused(model, tmp_path, where):
    path = save_model(model[0], tmp_path / "m.skops")
    data = bytearray(path.read_bytes())
    i = int(where * len(data)) if isinstance(where, float) else where
    data[i] ^= 0x01
    path.write_bytes(bytes(data))
    with pytest.raises(
        UntrustedModelError,
        match="m.skops: (checksum mismatch|not a tunnelsense model file)",
    ):
        load_model(path)


def test_truncated_is_refused(model, tmp_path):
    path = save_model(model[0], tmp_path / "m.skops")
    path.write_bytes(path.read_bytes()[:-200])
    with pytest.raises(
        UntrustedModelError, match="not a tunnelsense model file, or truncated"
    ):
        load_model(path)


def test_pickle_posing_as_safe_format_is_refused(model, tmp_path):
    path = tmp_path / "m.skops"
    joblib.dump(model[0], path)
    with pytest.raises(UntrustedModelError, match="It looks like a pickle"):
        load_model(path)


def _resign(path, edit):
    """Rewrite a model file's metadata and re-sign it (what an attacker with the format could do)."""
    data = path.read_bytes()
    src = zipfile.ZipFile(io.BytesIO(data))
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as dst:
        for item in src.infolist():
            payload = src.read(item.filename)
            if item.filename == "tunnelsense.json":
                payload = json.dumps(edit(json.loads(payload))).encode()
            dst.writestr(item, payload)
        dst.comment = b"tunnelsense-sha256:" + b"0" * 64
    raw = bytearray(out.getvalue())
    raw[-64:] = hashlib.sha256(raw[:-64]).hexdigest().encode()
    path.write_bytes(bytes(raw))


def test_version_mismatch_warns(model, tmp_path):
    path = save_model(model[0], tmp_path / "m.skops")

    def older(meta):
        meta["versions"]["scikit-learn"] = "0.1.0"
        return meta

    _resign(path, older)
    with pytest.warns(ModelVersionWarning, match=r"scikit-learn 0.1.0 \(now"):
        back = load_model(path)
    assert np.array_equal(back.predict(model[1]), model[0].predict(model[1]))


def test_untrusted_types_are_refused(tmp_path):
    path = save_model({"thing": NotTrusted()}, tmp_path / "m.skops")
    with pytest.raises(
        UntrustedModelError, match=r"not trusted .*: .*NotTrusted"
    ):
        load_model(path)


def test_pickles_need_consent_and_load_in_a_fresh_process(model, tmp_path):
    pipe, X = model
    path = save_model(pipe, tmp_path / "m.joblib")
    with pytest.raises(UntrustedModelError, match="allow_pickle=True"):
        load_model(path)
    assert np.array_equal(
        load_model(path, allow_pickle=True).predict(X), pipe.predict(X)
    )
    np.save(tmp_path / "X.npy", X)
    code = (
        "import numpy as np, joblib, sys; m = joblib.load(sys.argv[1]); "
        "print(''.join(map(str, m.predict(np.load(sys.argv[2])))))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, str(path), str(tmp_path / "X.npy")],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    assert out == "".join(map(str, pipe.predict(X)))
    assert describe_model(path)["format"] == "pickle"


def test_unknown_extension(model, tmp_path):
    with pytest.raises(ValueError, match=r"unknown model format '.bin'"):
        save_model(model[0], tmp_path / "m.bin")


def test_model_from_an_older_version_is_refused_clearly(model, tmp_path):
    """A parameter added since the model was saved: say so at load time."""
    pipe, _ = model
    del pipe.named_steps["tree"].__dict__["max_iter"]  # as if saved before it existed
    for name in ("m.skops", "m.joblib"):
        path = save_model(pipe, tmp_path / name)
        with pytest.raises(
            ValueError,
            match=r"LogisticRegression lacks parameter\(s\) max_iter: the model was saved by another version",
        ):
            load_model(path, allow_pickle=True)


@pytest.mark.parametrize("frame_rate", [None, 9.0, 30])
def test_trajectory_stages_frame_rate_round_trips(frame_rate, tmp_path):
    from tunnelsense import FrameRecord
    from tunnelsense.tunnel import PCCVerifier, TrajectoryLinker

    X = [FrameRecord("t", 1, np.zeros((4, 4), np.uint8), {
        "cluster_boxes": np.empty((0, 4)), "appearance": np.empty(0, bool),
        "track_ids": np.empty(0, np.int64)})]
    pipe = Pipeline([("tracks", TrajectoryLinker(frame_rate=frame_rate)),
                     ("motion", PCCVerifier(frame_rate=frame_rate))])
    back = load_model(save_model(pipe.fit(X), tmp_path / "m.skops"))
    assert [s.frame_rate for _, s in back.steps] == [frame_rate] * 2
