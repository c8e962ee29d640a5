"""What a detector's model file may hold: bounded sizes, exact contents, no smuggled calls."""

import copy
import io
import json
import subprocess
import sys
import zlib

import numpy as np
import pytest
from _model_files import LAST, _detections, _members, _zip, make_genuine

from tunnelsense import make_indicator_pipeline, to_xy
from tunnelsense._cli import main
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.exceptions import UntrustedModelError
from tunnelsense.io import load_model, save_model
from tunnelsense.io._trust import load_trusted_model


@pytest.fixture(scope="module")
def genuine(tmp_path_factory):
    return make_genuine(tmp_path_factory.mktemp("genuine"))


def _bomb(size=2 * 2**30):
    """A raw deflate stream of ``size`` zero bytes (about 2 MB for 2 GB), and its CRC."""
    chunk = bytes(2**20)
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    first = c.compress(chunk) + c.flush(zlib.Z_FULL_FLUSH)
    repeat = c.compress(chunk) + c.flush(zlib.Z_FULL_FLUSH)
    n = size // len(chunk)
    crc = 0
    for _ in range(n):
        crc = zlib.crc32(chunk, crc)
    return first + repeat * (n - 1) + c.flush(), crc, n * len(chunk)


@pytest.fixture(scope="module")
def bomb():
    return _bomb()


_PEAK = """
import resource, sys
from tunnelsense.cli import main
try:
    if sys.argv[1] == "load_model":
        from tunnelsense.io import load_model
        load_model(sys.argv[2])
        rc = 0
    else:
        rc = main(sys.argv[1:])
except Exception as exc:
    print(type(exc).__name__, exc, file=sys.stderr)
    rc = 2
try:  # the peak of this program (getrusage may count the forked parent before exec)
    with open("/proc/self/status") as f:
        peak = next(int(l.split()[1]) for l in f if l.startswith("VmHWM:"))
except OSError:
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(peak, rc)
"""


@pytest.mark.slow
@pytest.mark.parametrize("member,how", [("npy", "detect"), ("npy", "load_model"),
                                        ("schema.json", "info"),
                                        ("tunnelsense.json", "info")])
def test_a_zip_bomb_is_refused_before_it_inflates(genuine, bomb, tmp_path, member, how):
    members = _members(genuine["street"])
    name = next(n for n in members if n.endswith(".npy")) if member == "npy" else member
    del members[name]
    path = tmp_path / "bomb.skops"
    path.write_bytes(_zip(members, {name: bomb}))
    assert path.stat().st_size < 3e6
    out = tmp_path / "o.csv"
    argv = {"detect": ["detect", "street", "--model", str(path), str(genuine["run"]),
                       "--out", str(out), "--quiet"],
            "info": ["info", str(path)], "load_model": ["load_model", str(path)]}[how]
    done = subprocess.run([sys.executable, "-c", _PEAK, *argv], capture_output=True,
                          text=True, timeout=300)
    peak_kb, rc = map(int, done.stdout.split()[-2:])
    assert peak_kb < 300 * 1024, f"peak {peak_kb / 1024:.0f} MB"
    assert rc in (1, 2)
    assert "UntrustedModelError" in done.stderr or "error:" in done.stderr
    assert "inflate" in done.stderr and name in done.stderr
    assert not out.exists()


def _rewrite(path, out, edit):
    members = _members(path)
    members["schema.json"] = json.dumps(edit(json.loads(members["schema.json"]))).encode()
    out.write_bytes(_zip(members))
    return out


def _steps(schema):
    return schema["content"]["content"]["steps"]["content"]


def _attrs(schema, index):
    return _steps(schema)[index]["content"][1]["content"]["content"]


def _json(value):
    return {"__class__": "str", "__module__": "builtins", "__loader__": "JsonNode",
            "content": json.dumps(value), "is_json": True}


def _function_transformer(schema):
    step = _steps(schema)[0]["content"][1]
    step.update({"__class__": "FunctionTransformer",
                 "__module__": "sklearn.preprocessing._function_transformer"})
    return schema


def _extra_step(schema):
    _steps(schema).append(copy.deepcopy(_steps(schema)[0]))
    return schema


def _steps_int(schema):
    schema["content"]["content"]["steps"]["content"] = [_json(1)]
    return schema


def _param(index, name, value):
    def edit(schema):
        attrs = _attrs(schema, index)
        if name not in attrs:  # a new attribute: its key type too, as skops writes
            dict_node = _steps(schema)[index]["content"][1]["content"]
            dict_node["key_types"]["content"].append(
                {"__class__": "str", "__module__": "builtins", "__loader__": "TypeNode"})
        attrs[name] = _json(value)
        return schema

    return edit


def _array_member(schema, members, name, array):
    buffer = io.BytesIO()
    np.save(buffer, array)
    members[name] = buffer.getvalue()


CASES = {
    # kind, edit of the schema, what the refusal names
    "function-transformer": ("street", _function_transformer, "FunctionTransformer"),
    "extra-step": ("street", _extra_step, "steps"),
    "steps=[1]": ("street", _steps_int, "steps"),
    "max_distance=NaN": ("tunnel", _param(1, "max_distance", float("nan")),
                         "max_distance"),
    "row_stride=-1": ("tunnel", _param(0, "row_stride", -1), "row_stride"),
    "cut=-1": ("street", _param(0, "cut", -1.0), "cut"),
    "extra-attribute": ("street", _param(0, "payload_", 1), "payload_"),
    "stump index": ("tunnel", _param(3, "n_features_in_", 10**6), "n_features_in_"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_model_that_is_not_exactly_the_detector_is_refused(genuine, tmp_path, case,
                                                             capsys):
    kind, edit, named = CASES[case]
    crafted = _rewrite(genuine[kind], tmp_path / "crafted.skops", edit)
    with pytest.raises(UntrustedModelError, match=named):
        load_trusted_model(crafted, last_step=LAST[kind], command="x")
    out = tmp_path / "out.txt"
    source = genuine["tour" if kind == "tunnel" else "run"]
    assert main(["detect", kind, "--model", str(crafted), str(source), "--out",
                 str(out), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert named in err and "internal error" not in err
    assert not out.exists()


def test_forged_fitted_arrays_are_refused(genuine, tmp_path):
    members = _members(genuine["tunnel"])
    schema = json.loads(members["schema.json"])
    attrs = _attrs(schema, 1)  # the verifier
    for name, array in (("centers_", np.zeros((3, 5))),
                        ("center_scores_", np.zeros(7, dtype=np.int64)),
                        ("negative_centers_", np.full((3, 1), np.inf))):
        forged = dict(members)
        _array_member(schema, forged, attrs[name]["file"], array)
        path = tmp_path / f"{name}.skops"
        path.write_bytes(_zip(forged))
        with pytest.raises(UntrustedModelError, match=name):
            load_trusted_model(path, last_step="motion", command="x")


# --- crafted files that call code under skops 0.11-0.14 (the floor is 0.15) ---

@pytest.fixture
def probe(monkeypatch):
    """A numpy.random attribute that records being called."""
    calls = []
    monkeypatch.setattr(np.random, "_tunnelsense_probe", lambda *a, **k: calls.append(a),
                        raising=False)
    return calls


def test_a_random_generator_node_calling_numpy_random_is_refused(genuine, tmp_path,
                                                                 probe):
    """skops 0.11-0.14 call the bit generator name a file gives, with any name."""
    import skops.io

    from tunnelsense.tunnel import KMeansHistogramVerifier

    base = save_model(KMeansHistogramVerifier(random_state=np.random.default_rng(0)),
                      tmp_path / "rng.skops")

    def smuggle(schema):
        rng = schema["content"]["content"]["random_state"]
        rng["content"]["bit_generator"]["content"]["bit_generator"]["content"] = (
            json.dumps("_tunnelsense_probe"))
        return schema

    crafted = _rewrite(base, tmp_path / "crafted.skops", smuggle)
    # the installed skops names it (0.14 reported nothing and called it)
    assert "numpy.random._tunnelsense_probe" in skops.io.get_untrusted_types(
        data=crafted.read_bytes())
    with pytest.raises(UntrustedModelError, match="numpy.random._tunnelsense_probe"):
        load_model(crafted)
    # the same node in a detector's pipeline: refused by the strict reader as well
    node = json.loads(_members(crafted)["schema.json"])["content"]["content"][
        "random_state"]

    def inject(schema):
        _attrs(schema, 1)["random_state"] = node
        return schema

    tunnel = _rewrite(genuine["tunnel"], tmp_path / "tunnel.skops", inject)
    with pytest.raises(UntrustedModelError, match="Generator"):
        load_trusted_model(tunnel, last_step="motion", command="x")
    assert probe == []


def test_a_method_node_is_refused(genuine, tmp_path, probe):
    """A bound method of a trusted estimator, placed where skops calls it (a dict's
    key type)."""
    def inject(schema):
        est = _steps(schema)[0]["content"][1]
        method = {"__class__": est["__class__"], "__module__": est["__module__"],
                  "__loader__": "MethodNode",
                  "content": {"obj": copy.deepcopy(est), "func": "set_params"}}
        est["content"]["key_types"]["content"][0] = method
        return schema

    crafted = _rewrite(genuine["street"], tmp_path / "crafted.skops", inject)
    with pytest.raises(UntrustedModelError, match="not trusted"):
        load_model(crafted)
    with pytest.raises(UntrustedModelError, match="MethodNode"):
        load_trusted_model(crafted, last_step="cluster", command="x")


def test_the_declared_skops_floor_refuses_the_crafted_files():
    """skops 0.11-0.14 call a crafted random generator's name on load (checked by
    installing them): the lowest skops allowed must be 0.15."""
    import pathlib
    import re
    import tomllib

    pyproject = pathlib.Path(__file__).parents[2] / "pyproject.toml"
    deps = tomllib.loads(pyproject.read_text())["project"]["dependencies"]
    (floor,) = [re.fullmatch(r"skops>=([\d.]+)", d).group(1) for d in deps
                if d.startswith("skops")]
    assert tuple(int(p) for p in floor.split(".")) >= (0, 15)


def test_a_detector_is_read_without_importing_skops(genuine):
    """The strict reader needs neither skops' loader nor its discovery of every
    scikit-learn estimator."""
    code = ("import sys, warnings; warnings.simplefilter('ignore');"
            "from tunnelsense.io._trust import load_trusted_model;"
            f"load_trusted_model({str(genuine['tunnel'])!r}, last_step='motion', "
            "command='x'); print('skops' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert done.stdout.strip() == "False", done.stderr


def test_verifier_centres_off_their_grid_are_refused(genuine, tmp_path):
    """Centres that do not lie on quantum_ would not give exact distances."""
    members = _members(genuine["tunnel"])
    schema = json.loads(members["schema.json"])
    attrs = _attrs(schema, 1)  # the verifier
    model = load_trusted_model(genuine["tunnel"], last_step="motion", command="x")
    centers = model.named_steps["verifier"].centers_ + 1e-9
    forged = dict(members)
    _array_member(schema, forged, attrs["centers_"]["file"], centers)
    path = tmp_path / "off-grid.skops"
    path.write_bytes(_zip(forged))
    with pytest.raises(UntrustedModelError, match="grid"):
        load_trusted_model(path, last_step="motion", command="x")


def test_a_scikit_learn_step_that_skops_trusts_is_refused(genuine, tmp_path, capsys):
    """A genuine, well-formed pipeline whose 'cluster' step is a scikit-learn
    estimator (trusted by skops): not the street detector."""
    from sklearn.pipeline import Pipeline
    from sklearn.preprocessing import FunctionTransformer

    path = save_model(Pipeline([("cluster", FunctionTransformer())]).fit([[0.0]]),
                      tmp_path / "foreign.skops")
    with pytest.raises(UntrustedModelError, match="FunctionTransformer"):
        load_trusted_model(path, last_step="cluster", command="x")
    out = tmp_path / "o.csv"
    assert main(["detect", "street", "--model", str(path), str(genuine["run"]),
                 "--out", str(out), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "FunctionTransformer" in err and "internal error" not in err
    assert not out.exists()


def test_the_trusted_types_are_the_detectors_classes():
    """The strict reader's table of types (imported when a node names one) holds
    exactly the classes of the two detectors' pipelines."""
    from sklearn.pipeline import Pipeline

    from tunnelsense import (
        IntensityKeypointSampler,
        KMeansHistogramVerifier,
        MSTClusterer,
        PCCVerifier,
        ScanClusterer,
        TrajectoryLinker,
        WeightedAdaBoost,
    )
    from tunnelsense.io._model_strict import EXPECTED_STEPS, _classes, _is_trusted

    classes = [Pipeline, IntensityKeypointSampler, KMeansHistogramVerifier,
               MSTClusterer, PCCVerifier, ScanClusterer, TrajectoryLinker,
               WeightedAdaBoost]
    assert _classes() == {f"{c.__module__}.{c.__qualname__}": c for c in classes}
    names = {spec[1] for steps in EXPECTED_STEPS.values() for spec in steps}
    assert names | {"Pipeline"} == {c.__name__ for c in classes}
    assert all(_is_trusted(c) for c in classes)
    impostor = type("MSTClusterer", (MSTClusterer,), {"__module__": MSTClusterer.__module__})
    assert not _is_trusted(impostor) and not _is_trusted(dict)


def test_a_model_of_16_bit_frames_loads_and_its_extra_attributes_are_checked(tmp_path):
    """A sampler fitted on deeper frames keeps their level and spread (raw_level_,
    raw_spread_): its file loads and detects as the model does; forged values or a
    missing one are refused."""
    from tunnelsense import FrameRecord

    tour = make_tunnel_tour(60, random_state=0, first_indicator_m=20.0)
    X, y, _ = to_xy([tour])
    X = [FrameRecord(r.tour, r.frame, r.image.astype(np.uint16) * 257) for r in X]
    model = make_indicator_pipeline(random_state=0).fit(X, y)
    sampler = model.named_steps["keypoints"]
    assert sampler.raw_spread_ > 0
    loaded = load_trusted_model(save_model(model, tmp_path / "wide.skops"),
                                last_step="motion", command="x")
    assert _detections(loaded, X) == _detections(model, X)
    assert any(_detections(model, X))
    for name, value in (("raw_spread_", 0.0), ("raw_level_", float("nan")),
                        ("raw_level_", None)):
        forged = copy.deepcopy(model)
        if value is None:
            del forged.named_steps["keypoints"].raw_level_
        else:
            setattr(forged.named_steps["keypoints"], name, value)
        path = save_model(forged, tmp_path / f"{name}-{value}.skops")
        with pytest.raises(UntrustedModelError, match=name):
            load_trusted_model(path, last_step="motion", command="x")
