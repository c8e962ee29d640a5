"""Start-up: building the command line imports none of the heavy libraries.

A command imports what it needs when it runs; ``tunnelsense --version``, ``--help`` and
the parser itself must not pay for scikit-learn, pandas, SciPy, NumPy or OpenCV.  (Which
modules are loaded, not how long it takes: timing is for benchmarks/.)
"""

import json
import subprocess
import sys

import pytest

_HEAVY = ("sklearn", "pandas", "scipy", "numpy", "cv2", "matplotlib", "skops",
          "dask", "distributed", "joblib", "cryptography", "tqdm")

_LOADED = """
import json, sys
import tunnelsense, tunnelsense.cli
tunnelsense.cli.build_parser()
heavy = set(json.loads(sys.argv[1]))
print(json.dumps(sorted({m.partition(".")[0] for m in sys.modules} & heavy)))
"""


def _loaded(code):
    done = subprocess.run([sys.executable, "-c", code, json.dumps(_HEAVY)],
                          capture_output=True, text=True, timeout=120, check=True)
    return json.loads(done.stdout.splitlines()[-1])


def test_the_parser_imports_no_heavy_library():
    assert _loaded(_LOADED) == []


def test_a_public_name_imports_its_module_on_first_use():
    code = _LOADED.replace("tunnelsense.cli.build_parser()",
                           "tunnelsense.ScanClusterer; tunnelsense.cli.build_parser()")
    assert "numpy" in _loaded(code)  # the estimator's module was imported


def test_lazy_names_are_the_package_names():
    import tunnelsense
    import tunnelsense.io
    import tunnelsense.street
    import tunnelsense.tunnel

    for package in (tunnelsense, tunnelsense.io, tunnelsense.street, tunnelsense.tunnel):
        for name in package.__all__:
            assert getattr(package, name) is not None
            assert name in dir(package)
    assert tunnelsense.tunnel._training.SEARCH_GRID is tunnelsense.tunnel._search_grid.SEARCH_GRID


def test_a_missing_name_is_an_attribute_error():
    import pytest

    import tunnelsense

    with pytest.raises(AttributeError, match="no attribute 'not_a_name'"):
        tunnelsense.not_a_name  # noqa: B018


_DEFER = """
import sys
from tunnelsense._deferred import defer
assert defer(["pandas", "scipy.stats", "not_a_module_xyz"]) == ["pandas", "scipy.stats"]
import pandas as pd
import scipy.stats
stand_in = type(sys.modules["pandas"]).__name__
assert pd.DataFrame({"a": [1, 2]})["a"].sum() == 3  # the first use imports pandas
assert type(sys.modules["pandas"]).__name__ == "module"
assert pd.__version__ == sys.modules["pandas"].__version__
import pandas.api.types  # a submodule of a deferred module
assert scipy.stats.norm.cdf(0.0) == 0.5
print(stand_in)
"""


def test_a_deferred_module_is_imported_on_first_use():
    done = subprocess.run([sys.executable, "-c", _DEFER], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["_Deferred"]


_DETECT = """
import sys
from tunnelsense.cli import main
sys.argv = ["tunnelsense", *sys.argv[1:]]
status = main()
real = [m for m in ("pandas", "scipy.stats")
        if type(sys.modules.get(m)).__name__ == "module"]
print("imported:", *real)
sys.exit(status)
"""


_FLOOR = """
import sys
from tunnelsense._deferred import defer
defer()
import sklearn.pipeline
real = [m for m in ("pandas", "scipy.stats")
        if type(sys.modules.get(m)).__name__ == "module"]
print("imported:", *real)
"""


def test_the_street_command_detects_without_pandas_or_scipy_stats(tmp_path):
    """Detecting needs neither: the command imports no more of them than scikit-learn
    itself does as it starts (none on today's releases; scikit-learn 1.6 reads
    ``pandas.__version__`` at import, so there pandas is part of that floor)."""
    from tunnelsense import make_parking_pipeline, to_xy
    from tunnelsense._cli import main
    from tunnelsense.datasets import make_street_scans
    from tunnelsense.io import save_model, write_run

    X, y, _ = to_xy(make_street_scans(600, random_state=0))
    model = save_model(make_parking_pipeline().fit(X, y), tmp_path / "m.skops")
    run = write_run(make_street_scans(300, random_state=1), tmp_path / "run")
    argv = ["detect", "street", str(run), "--model", str(model), "--quiet", "--out"]
    done = subprocess.run([sys.executable, "-c", _DETECT, *argv,
                           str(tmp_path / "command.csv")],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    floor = subprocess.run([sys.executable, "-c", _FLOOR], capture_output=True,
                           text=True, timeout=120)
    assert floor.returncode == 0, floor.stderr
    # neither was needed beyond what importing scikit-learn itself imports
    assert done.stdout.splitlines()[-1] == floor.stdout.splitlines()[-1]
    assert main([*argv, str(tmp_path / "call.csv")]) == 0  # everything imported
    assert (tmp_path / "command.csv").read_text() == (tmp_path / "call.csv").read_text()


def test_detection_reads_no_ground_truth(tmp_path):
    """Detection opens runs and tours without their ground truth (pandas, parsing):
    a malformed ground-truth file is refused by a reader that reads it, not by one
    that does not."""
    from tunnelsense.datasets import make_street_scans, make_tunnel_tour
    from tunnelsense.io import open_run_stream, open_tour, write_run, write_tour
    from tunnelsense.tunnel._detect import open_frames

    run = write_run(make_street_scans(50, random_state=0), tmp_path / "run")
    (run / "gt.csv").write_text("id,first_scan,last_scan,label\n1,0,9999,parked\n")
    with pytest.raises(ValueError, match="beyond the run"):
        open_run_stream(run)
    stream = open_run_stream(run, ground_truth=False)
    assert stream.gt is None and len(list(stream)) == 50
    tour = write_tour(make_tunnel_tour(3, random_state=0), tmp_path / "tour")
    (tour / "gt" / "gt.txt").write_text("99,1,1,1,5,5,1,1,1\n")
    with pytest.raises(ValueError, match="outside"):
        open_tour(tour)
    assert open_tour(tour, ground_truth=False).gt is None
    frames, total = open_frames(tour)
    assert total == 3 and [r.frame for r in frames] == [1, 2, 3]


_TUNNEL = """
import sys
from tunnelsense.cli import main
sys.argv = ["tunnelsense", *sys.argv[1:]]
status = main()
print(" ".join(sorted(m for m in sys.modules if m.startswith(
    ("tunnelsense.street", "tunnelsense.datasets._tunnel", "tqdm")))))
sys.exit(status)
"""


def test_the_tunnel_command_imports_neither_the_street_detector_nor_the_simulator(
        tmp_path):
    """Reading a tunnel model builds only the classes it names; --quiet draws no
    progress bar."""
    from tunnelsense import make_indicator_pipeline, to_xy
    from tunnelsense.datasets import make_tunnel_tour
    from tunnelsense.io import save_model, write_tour

    X, y, _ = to_xy(make_tunnel_tour(60, random_state=0, first_indicator_m=20.0))
    model = save_model(make_indicator_pipeline(random_state=0).fit(X, y),
                       tmp_path / "m.skops")
    tour = write_tour(make_tunnel_tour(5, random_state=1), tmp_path / "tour")
    done = subprocess.run(
        [sys.executable, "-c", _TUNNEL, "detect", "tunnel", "--model", str(model),
         str(tour), "--out", str(tmp_path / "r.txt"), "--quiet"],
        capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1] == ""


_SERVED = """
import sys
from tunnelsense._deferred import defer
assert "sklearn.preprocessing" in defer()
import sklearn.pipeline  # imports FunctionTransformer from sklearn.preprocessing
from scipy.optimize import linear_sum_assignment
kinds = [type(sys.modules[m]).__name__ for m in ("sklearn.preprocessing", "scipy.optimize")]
light = "scipy.interpolate" not in sys.modules
served = sklearn.pipeline.FunctionTransformer
from sklearn.preprocessing import StandardScaler  # any other name: the whole package
import sklearn.preprocessing as pre
import scipy.optimize
same = (pre.FunctionTransformer is served
        and pre._function_transformer.FunctionTransformer is served
        and scipy.optimize.linear_sum_assignment is linear_sum_assignment
        and StandardScaler is pre.StandardScaler)
assert type(sys.modules["sklearn.preprocessing"]).__name__ == "module"
assert scipy.optimize.minimize is sys.modules["scipy.optimize"].minimize
print(*kinds, light, same)
"""


def test_a_deferred_package_serves_named_submodules_then_imports_whole():
    done = subprocess.run([sys.executable, "-c", _SERVED], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["_Deferred", "_Deferred", "True", "True"]


_LINALG = """
import importlib.util
import sys
import numpy as np
from tunnelsense._deferred import defer
names = []
if importlib.util.find_spec("narwhals") is not None:  # scikit-learn >= 1.7 uses it
    names += ["narwhals", "narwhals.stable", "narwhals.stable.v2"]
deferred = defer()
assert set(names) <= set(deferred)
# SciPy's linear algebra is never deferred: at the lowest SciPy allowed a stand-in
# broke ``scipy.sparse.linalg`` looked up through ``scipy.sparse``
assert not [n for n in deferred if "linalg" in n or "csgraph" in n]
import sklearn.pipeline
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components  # as the keypoint clusters do
graph = coo_matrix((np.ones(2), ([0, 2], [1, 3])), shape=(5, 5))
n, labels = connected_components(graph, directed=False)
import scipy.linalg
import scipy.sparse.csgraph
import scipy.sparse.linalg
assert np.allclose(scipy.linalg.svd(np.eye(2))[1], [1.0, 1.0])
tree = scipy.sparse.csgraph.minimum_spanning_tree(graph)
vals = scipy.sparse.linalg.eigsh(np.diag([1.0, 2.0, 3.0, 4.0]), k=1)[0]
# scikit-learn's validation looks at data frames through narwhals' stable API
import pandas as pd
from sklearn.preprocessing import StandardScaler
scaler = StandardScaler().fit(pd.DataFrame({"a": [1.0, 3.0], "b": [2.0, 2.0]}))
assert scaler.feature_names_in_.tolist() == ["a", "b"]
if "narwhals" in names:
    import narwhals.stable.v2 as nw
    assert nw.from_native(pd.DataFrame({"a": [1]})).columns == ["a"]
assert all(type(sys.modules[m]).__name__ == "module" for m in names)
print(n, labels.tolist(), tree.nnz, round(float(vals[0]), 6))
"""


def test_linear_algebra_and_data_frames_work_whole_after_deferral():
    done = subprocess.run([sys.executable, "-c", _LINALG], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["3", "[0,", "0,", "1,", "1,", "2]", "2", "4.0"]


_ELSEWHERE = """
import sys
from tunnelsense import _deferred
# a served name kept elsewhere in this release: the whole package instead
_deferred.SERVED["email"] = {"message_from_string": "email._not_a_module"}
assert _deferred.defer(["email"]) == ["email"]
from email import message_from_string
print(type(sys.modules["email"]).__name__, message_from_string("Subject: x").get("subject"))
"""


def test_a_served_name_kept_elsewhere_imports_the_whole_package():
    done = subprocess.run([sys.executable, "-c", _ELSEWHERE], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["module", "x"]


_NUMPY_PARTS = """
import gc, sys
from tunnelsense._deferred import (
    IMPORT_GC_THRESHOLD, NUMPY_PARTS, end_imports, start_command, start_imports)
usual = gc.get_threshold()
assert start_imports() == [] and gc.get_threshold() == usual  # not the command
assert "scipy.special" in start_command()
import numpy as np
# the parts this NumPy does not import with itself (older ones import some eagerly;
# a module already imported is not deferred)
lazy = [m for m in NUMPY_PARTS if m not in sys.modules]
assert start_imports() == lazy
assert gc.get_threshold() == (IMPORT_GC_THRESHOLD, *usual[1:])
import sklearn.pipeline  # SciPy's array-API layer looks up every name of numpy
end_imports()
assert gc.get_threshold() == usual and gc.get_freeze_count() > 0
kinds = [type(sys.modules[m]).__name__ for m in (*lazy, "scipy.special")]
from numpy.testing import assert_array_equal  # the first use imports the real one
assert_array_equal(np.polynomial.polynomial.polyval(2.0, [1.0, 1.0]), 3.0)
import scipy.special._ufuncs  # a submodule of a deferred module
import scipy.stats
assert scipy.stats.norm.cdf(0.0) == 0.5 and scipy.special.erf(0.0) == 0.0
used = [m for m in ("numpy.testing", "numpy.polynomial") if m in lazy]
real = [type(sys.modules[m]).__name__ for m in (*used, "scipy.special")]
same = np.testing is sys.modules["numpy.testing"] and np.testing.assert_array_equal is (
    assert_array_equal)
print(*set(kinds), *set(real), same)
"""


def test_the_command_defers_numpy_parts_and_collects_seldom_while_importing():
    done = subprocess.run([sys.executable, "-c", _NUMPY_PARTS], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["_Deferred", "module", "True"]
