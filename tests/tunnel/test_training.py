"""fit_indicator_detector (train tunnel's fit): the model equals a plain pipeline fit."""

import numpy as np
import pytest

from tunnelsense import to_xy
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.io import read_tour, write_tour
from tunnelsense.tunnel import fit_indicator_detector, make_indicator_pipeline


def fitted_state(obj, depth=0):
    """Every fitted value of an estimator (attributes ending in ``_``), recursively,
    as nested lists / dicts of arrays and plain values."""
    if depth > 6:
        return repr(type(obj))
    if isinstance(obj, np.ndarray):
        return obj
    if isinstance(obj, (list, tuple)):
        return [fitted_state(v, depth + 1) for v in obj]
    if isinstance(obj, dict):
        return {k: fitted_state(v, depth + 1) for k, v in obj.items()}
    if hasattr(obj, "get_params"):  # every attribute a fit set, private ones too
        params = obj.get_params(deep=False)
        state = {k: v for k, v in vars(obj).items() if k not in params}
        return {k: fitted_state(v, depth + 1) for k, v in state.items()}
    if hasattr(obj, "__dict__") and not callable(obj):
        state = {k: v for k, v in vars(obj).items()
                 if k.endswith("_") and not k.startswith("_")}
        return {k: fitted_state(v, depth + 1) for k, v in state.items()}
    return obj


def assert_same(a, b, where="model"):
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        assert a.dtype == b.dtype and a.shape == b.shape, where
        assert np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"), where
    elif isinstance(a, dict):
        assert isinstance(b, dict) and a.keys() == b.keys(), where
        for k in a:
            assert_same(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), where
        for i, (u, v) in enumerate(zip(a, b, strict=True)):
            assert_same(u, v, f"{where}[{i}]")
    else:
        assert a == b or (a != a and b != b), where


@pytest.fixture(scope="module")
def tours(tmp_path_factory):
    made = [make_tunnel_tour(50, scenario=s, random_state=i, first_indicator_m=20.0)
            for i, s in enumerate(["light", "heavy"])]
    root = tmp_path_factory.mktemp("tours")
    return made, [read_tour(write_tour(t, root / f"t{i}")) for i, t in enumerate(made)]


@pytest.mark.parametrize("n_jobs", [1, 2])
def test_fit_equals_the_plain_pipeline_fit(tours, n_jobs):
    # whatever the command overlaps or runs in threads, every fitted array is the
    # plain make_indicator_pipeline(...).fit(X, y)'s, from memory or from files
    in_memory, on_disk = tours
    plain = make_indicator_pipeline(random_state=0).fit(*to_xy(in_memory)[:2])
    model, summary = fit_indicator_detector(on_disk, n_jobs=n_jobs)
    assert summary["frames_fitted"] == 100
    for (name, ours), (_, theirs) in zip(model.steps, plain.steps, strict=True):
        state = fitted_state(ours)
        assert state, name
        assert_same(state, fitted_state(theirs), name)
