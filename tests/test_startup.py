"""Start-up: building the command line imports none of the heavy libraries.

A command imports what it needs when it runs; ``tunnelsense --version``, ``--help`` and
the parser itself must not pay for scikit-learn, pandas, SciPy, NumPy or OpenCV.  (Which
modules are loaded, not how long it takes: timing is for benchmarks/.)
"""

import json
import subprocess
import sys

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
    assert tunnelsense.tunnel._detect.SEARCH_GRID is tunnelsense.tunnel._search_grid.SEARCH_GRID


def test_a_missing_name_is_an_attribute_error():
    import pytest

    import tunnelsense

    with pytest.raises(AttributeError, match="no attribute 'not_a_name'"):
        tunnelsense.not_a_name  # noqa: B018
