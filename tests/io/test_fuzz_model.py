"""Fuzz the model reader and the results companion: only the project's errors escape."""

import hashlib
import io
import json
import warnings
import zipfile

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sklearn.linear_model import LogisticRegression
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

from tunnelsense.exceptions import (
    InputFormatError,
    ModelVersionWarning,
    UntrustedModelError,
)
from tunnelsense.io import (
    CLUSTERS_HEADER,
    describe_model,
    load_model,
    read_hypotheses,
    save_model,
)

FUZZ = settings()  # examples from the Hypothesis profile (tests/conftest.py)


@pytest.fixture(scope="module")
def genuine(tmp_path_factory):
    X = np.arange(20.0).reshape(10, 2)
    model = Pipeline([("scale", StandardScaler()),
                      ("tree", LogisticRegression())]).fit(X, X[:, 0] > 9)
    path = save_model(model, tmp_path_factory.mktemp("m") / "m.skops")
    return path.read_bytes()


def _reads_or_refuses(path):
    """Load and describe; only a refusal naming the file may escape."""
    for read in (describe_model, load_model):
        try:
            with warnings.catch_warnings():  # edited versions: a warning, by design
                warnings.simplefilter("ignore", ModelVersionWarning)
                read(path)
        except InputFormatError as exc:  # UntrustedModelError is one
            assert str(path) in str(exc)


def _resign(data: bytes) -> bytes:
    """Recompute the checksum, as anyone editing the file can."""
    raw = bytearray(data)
    if raw[-83:-64] == b"tunnelsense-sha256:":
        raw[-64:] = hashlib.sha256(bytes(raw[:-64])).hexdigest().encode()
    return bytes(raw)


@FUZZ
@given(data=st.binary(max_size=2048))
def test_random_bytes(tmp_path, data):
    path = tmp_path / "m.skops"
    path.write_bytes(data)
    with pytest.raises(UntrustedModelError, match="m.skops"):
        load_model(path)


@FUZZ
@given(flips=st.lists(st.tuples(st.floats(0, 1, exclude_max=True),
                                st.integers(1, 255)), min_size=1, max_size=4),
       cut=st.none() | st.floats(0, 1), resign=st.booleans())
def test_edited_bytes(tmp_path, genuine, flips, cut, resign):
    data = bytearray(genuine)
    for where, value in flips:
        data[int(where * len(data))] ^= value
    if cut is not None:
        data = data[: int(cut * len(data))]
    path = tmp_path / "m.skops"
    path.write_bytes(_resign(bytes(data)) if resign else bytes(data))
    _reads_or_refuses(path)


_JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False)
    | st.text(max_size=12),
    lambda inner: st.lists(inner, max_size=3)
    | st.dictionaries(st.sampled_from(["__class__", "__module__", "__loader__",
                                       "content", "is_json", "type", "file",
                                       "__id__"]), inner, max_size=4),
    max_leaves=12,
)


@FUZZ
@given(node=_JSON, where=st.sampled_from(["tunnelsense.json", "schema.json"]))
def test_edited_members_with_a_correct_checksum(tmp_path, genuine, node, where):
    """An attacker rewrites a member and the checksum: refused or harmless."""
    src = zipfile.ZipFile(io.BytesIO(genuine))
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as dst:
        for item in src.infolist():
            payload = src.read(item.filename)
            if item.filename == where:
                doc = json.loads(payload)
                if isinstance(doc, dict) and where == "schema.json":
                    doc["content"]["content"]["injected"] = node
                else:
                    doc = node
                payload = json.dumps(doc).encode()
            dst.writestr(item, payload)
        dst.comment = b"tunnelsense-sha256:" + b"0" * 64
    path = tmp_path / "m.skops"
    path.write_bytes(_resign(buffer.getvalue()))
    _reads_or_refuses(path)


@FUZZ
@given(text=st.text(max_size=400) | st.binary(max_size=400),
       with_header=st.booleans())
def test_results_companion(tmp_path, text, with_header):
    results = tmp_path / "r.txt"
    results.write_text("3,1,1.0,2.0,3.0,4.0,0.9,-1,-1,-1\n")
    companion = tmp_path / "r.clusters.csv"
    if isinstance(text, bytes):
        companion.write_bytes((CLUSTERS_HEADER + "\n").encode() * with_header + text)
    else:
        companion.write_text(CLUSTERS_HEADER + "\n" * with_header + text)
    try:
        hyp, complete = read_hypotheses(results, "t")
    except InputFormatError as exc:
        assert "r.clusters.csv" in str(exc) or "r.txt" in str(exc)
        return
    assert complete
    positive = hyp[hyp["trajectory_positive"]]
    assert positive[["frame", "track_id"]].to_numpy().tolist() == [[3, 1]]
