"""Opening a model file a user names: io/_trust.py."""

import pytest
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

from tunnelsense.exceptions import UntrustedModelError
from tunnelsense.io import save_model
from tunnelsense.io._trust import check_model_path, load_trusted_model, read_signing_key


def test_a_pickle_needs_trust_and_a_model_the_right_kind(tmp_path):
    model = Pipeline([("scale", StandardScaler())]).fit([[0.0], [1.0]])
    save_model(model, tmp_path / "m.joblib")
    with pytest.raises(UntrustedModelError, match="--trust-pickle"):
        load_trusted_model(tmp_path / "m.joblib", last_step="scale", command="x")
    with pytest.raises(ValueError, match="'tunnelsense train street'"):
        load_trusted_model(tmp_path / "m.joblib", last_step="cluster",
                           command="train street", trust_pickle=True)
    with pytest.raises(FileNotFoundError, match="model file not found"):
        load_trusted_model(tmp_path / "none.skops", last_step="scale", command="x")


def test_a_signed_model_needs_its_key(tmp_path):
    model = Pipeline([("scale", StandardScaler())]).fit([[0.0], [1.0]])
    (tmp_path / "key").write_bytes(b"fleet-secret-0123456789\n")
    key = read_signing_key(tmp_path / "key")
    assert key == b"fleet-secret-0123456789"
    save_model(model, tmp_path / "m.skops", key=key)
    loaded = load_trusted_model(tmp_path / "m.skops", last_step="scale", command="x",
                                key=key)
    assert loaded.steps[-1][0] == "scale"
    with pytest.raises(Exception, match="sign"):
        load_trusted_model(tmp_path / "m.skops", last_step="scale", command="x",
                           key=b"another-fleet-secret-key")


def test_an_empty_key_file_and_a_model_path_are_refused(tmp_path):
    (tmp_path / "key").write_bytes(b"\n")
    with pytest.raises(ValueError, match="the file is empty"):
        read_signing_key(tmp_path / "key")
    (tmp_path / "m.skops").write_bytes(b"old")
    with pytest.raises(FileExistsError):
        check_model_path(tmp_path / "m.skops")
    assert check_model_path(tmp_path / "m.skops", overwrite=True).name == "m.skops"
    with pytest.raises(FileExistsError, match="an input of this command"):
        check_model_path(tmp_path / "m.skops", overwrite=True,
                         inputs=[tmp_path / "m.skops"])
