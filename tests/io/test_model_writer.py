"""A detector's model file, written without skops' writer, is the file skops writes."""

import io
import json
import subprocess
import sys
import zipfile

import numpy as np
import pytest
import skops.io
from sklearn.linear_model import LogisticRegression

from tunnelsense import make_indicator_pipeline, make_parking_pipeline, to_xy
from tunnelsense.datasets import make_street_scans, make_tunnel_tour
from tunnelsense.io import _model_writer, save_model
from tunnelsense.io._model_writer import detector_skops_payload


@pytest.fixture(scope="module")
def detectors():
    tour = make_tunnel_tour(120, scenario="light", random_state=5, name="tour")
    X, y, _ = to_xy([tour])
    run = make_street_scans(300, random_state=5, name="run")
    Xs, ys, _ = to_xy([run])
    return {"tunnel": make_indicator_pipeline(random_state=0).fit(X, y),
            "street": make_parking_pipeline().fit(Xs, ys)}


def _normalised(payload):
    """The zip's schema, member names, member flags and member bytes, every object id
    (``__id__``, the ``.npy`` names) replaced by its order of first appearance."""
    zf = zipfile.ZipFile(io.BytesIO(payload))
    ids = {}

    def rename(value):
        return ids.setdefault(value, len(ids))

    def walk(node):
        if isinstance(node, dict):
            out = {k: walk(v) for k, v in node.items()}
            if "__id__" in node:
                out["__id__"] = rename(node["__id__"])
            if node.get("__loader__") == "NdArrayNode":
                out["file"] = rename(int(node["file"].removesuffix(".npy")))
            return list(out.items())  # the keys' order counts
        if isinstance(node, list):
            return [walk(v) for v in node]
        return node

    schema = walk(json.loads(zf.read("schema.json")))
    members = [(rename(int(i.filename.removesuffix(".npy"))) if i.filename != "schema.json"
                else i.filename, i.compress_type, i.external_attr, zf.read(i.filename))
               for i in zf.infolist() if i.filename != "schema.json"]
    names = [i.filename for i in zf.infolist()]
    return schema, members, names[-1], len(names)


@pytest.mark.parametrize("kind", ["tunnel", "street"])
def test_a_detector_is_written_as_skops_writes_it(detectors, kind):
    model = detectors[kind]
    ours = detector_skops_payload(model)
    theirs = skops.io.dumps(model, compression=zipfile.ZIP_DEFLATED)
    assert ours is not None
    assert _normalised(ours) == _normalised(theirs)
    assert _normalised(ours)[1]  # the fitted arrays are members
    # skops reads it as its own
    loaded = skops.io.loads(ours, trusted=skops.io.get_untrusted_types(data=ours))
    assert loaded.get_params().keys() == model.get_params().keys()


def test_other_objects_are_left_to_skops(detectors, monkeypatch):
    X = np.array([[0.0], [1.0], [2.0], [3.0]])
    assert detector_skops_payload(LogisticRegression().fit(X, [0, 0, 1, 1])) is None
    model = detectors["street"]
    step = model.steps[-1][1]
    for odd in (np.float64(1.5), np.array(["a"], dtype=object), {1: "int key"}):
        monkeypatch.setattr(step, "odd_", odd, raising=False)
        assert detector_skops_payload(model) is None, odd
    monkeypatch.delattr(step, "odd_")
    assert detector_skops_payload(model) is not None
    # a skops release whose file it does not know: skops writes it
    monkeypatch.setattr(_model_writer, "_skops_version", lambda: "0.99.0")
    assert detector_skops_payload(model) is None


_SAVE = """
import sys
import numpy as np
from tunnelsense.io import save_model
from tunnelsense.io._trust import load_trusted_model
kind, path, out = sys.argv[1:]
last = {"tunnel": "motion", "street": "cluster"}[kind]
model = load_trusted_model(path, last_step=last, command="train " + kind)
save_model(model, out)
assert "skops.io" not in sys.modules, "the skops writer was imported"
again = load_trusted_model(out, last_step=last, command="train " + kind)
for (name, a), (_, b) in zip(model.steps, again.steps, strict=True):
    for key, value in vars(a).items():
        if isinstance(value, np.ndarray):
            np.testing.assert_array_equal(value, vars(b)[key], err_msg=f"{name}.{key}")
            assert value.dtype == vars(b)[key].dtype
print("ok")
"""


@pytest.mark.parametrize("kind", ["tunnel", "street"])
def test_saving_a_detector_imports_no_skops_writer(detectors, kind, tmp_path):
    path = save_model(detectors[kind], tmp_path / f"{kind}.skops")
    done = subprocess.run([sys.executable, "-c", _SAVE, kind, str(path),
                           str(tmp_path / "again.skops")],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ok"
