"""Mutated genuine model files: a documented refusal, or the same detections."""

import io
import json
import warnings

import numpy as np
import pytest
from _model_files import LAST, _detections, _members, _zip, make_genuine
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tunnelsense.exceptions import InputFormatError, ModelVersionWarning
from tunnelsense.io._trust import load_trusted_model


@pytest.fixture(scope="module")
def genuine(tmp_path_factory):
    return make_genuine(tmp_path_factory.mktemp("genuine"))


# --- mutations of genuine schemas: a documented error, or the same detections ---

#: Values no tunnelsense model holds for any parameter or fitted number (non-finite,
#: beyond 2**53, a string where a number is, a list).
_BAD_VALUES = [float("nan"), float("inf"), -float("inf"), 1e300, 10**20, -(10**20),
               "x", [1, 2]]

#: Shapes no documented fitted array has.
_BAD_SHAPES = [(0,), (3,), (7, 3), (1, 1, 1)]


def _json_paths(node, path=()):
    """Paths of every JsonNode, array node and object node in a schema."""
    if isinstance(node, dict):
        if node.get("__loader__") in ("JsonNode", "NdArrayNode", "ObjectNode"):
            yield path
        for k, v in node.items():
            yield from _json_paths(v, (*path, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _json_paths(v, (*path, i))


def _at(schema, path):
    for p in path:
        schema = schema[p]
    return schema


@st.composite
def mutations(draw, schema):
    paths = sorted(_json_paths(schema), key=repr)
    path = draw(st.sampled_from(paths))
    what = draw(st.sampled_from(["value", "type", "array", "drop"]))
    detail = draw(st.one_of(st.sampled_from(_BAD_VALUES),
                            st.sampled_from(["MSTClusterer", "PCCVerifier",
                                             "ScanClusterer", "WeightedAdaBoost"])))
    shape = draw(st.sampled_from(_BAD_SHAPES))
    dtype = draw(st.sampled_from(["float64", "int64", "bool", "float32"]))
    return path, what, detail, shape, dtype


_MODULES = {"MSTClusterer": "tunnelsense.tunnel._clustering",
            "PCCVerifier": "tunnelsense.tunnel._motion",
            "ScanClusterer": "tunnelsense.street._detector",
            "WeightedAdaBoost": "tunnelsense.tunnel._appearance"}


def _mutate(members, mutation):
    path, what, detail, shape, dtype = mutation
    schema = json.loads(members["schema.json"])
    node = _at(schema, path)
    loader = node["__loader__"]
    if what == "drop" and path and isinstance(path[-1], str) and path[-2] == "content":
        del _at(schema, path[:-1])[path[-1]]
    elif loader == "ObjectNode" or (what == "type" and isinstance(detail, str)
                                    and detail in _MODULES):
        name = detail if isinstance(detail, str) and detail in _MODULES else "PCCVerifier"
        node.update({"__class__": name, "__module__": _MODULES[name]})
    elif loader == "NdArrayNode" or what == "array":
        if loader == "NdArrayNode":
            buffer = io.BytesIO()
            np.save(buffer, np.ones(shape, dtype=dtype))
            members[node["file"]] = buffer.getvalue()
        else:
            node["content"] = json.dumps([1, 2])
    else:
        node["content"] = json.dumps(detail)
    members["schema.json"] = json.dumps(schema).encode()
    return members


# examples from the Hypothesis profile (tests/conftest.py: few by default, many in CI)
MUTATIONS = settings(deadline=None, suppress_health_check=list(HealthCheck))


@pytest.mark.parametrize("kind", ["street", "tunnel"])
def test_mutated_schemas_are_refused_or_detect_the_same(genuine, tmp_path_factory, kind):
    members = _members(genuine[kind])
    schema = json.loads(members["schema.json"])
    folder = tmp_path_factory.mktemp("mutated")

    @MUTATIONS
    @given(mutations(schema))
    def check(mutation):
        path = folder / "m.skops"
        path.write_bytes(_zip(_mutate(dict(members), mutation)))
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ModelVersionWarning)
                model = load_trusted_model(path, last_step=LAST[kind], command="x")
        except InputFormatError as exc:  # UntrustedModelError is one
            assert str(path) in str(exc)
            return
        assert _detections(model, genuine["X"][kind]) == genuine["detections"][kind], (
            mutation)

    check()
