"""Today's detections, byte for byte: a refactor must not change what a user gets.

The tours, runs and models are made afresh from fixed seeds through the public API and
the command line; the results files are compared with the ones committed in
``tests/data/golden``.  A change that is meant to alter detections regenerates them
deliberately with ``TUNNELSENSE_REGENERATE_GOLDEN=1 pytest tests/test_golden.py`` and
says why in its commit.
"""

import os
from pathlib import Path

import pytest

from tunnelsense._cli import main
from tunnelsense.datasets import make_street_scans, make_tunnel_tour
from tunnelsense.io import write_run, write_tour

GOLDEN = Path(__file__).parent / "data" / "golden"
REGENERATE = os.environ.get("TUNNELSENSE_REGENERATE_GOLDEN") == "1"


def _compare(produced: Path, name: str) -> None:
    expected = GOLDEN / name
    if REGENERATE:
        expected.write_bytes(produced.read_bytes())
    assert expected.is_file(), f"no golden file {expected}"
    got = produced.read_bytes()
    want = expected.read_bytes()
    assert got == want, (
        f"{name}: detections differ from the golden file "
        f"({len(got)} bytes vs {len(want)}); first lines:\n"
        + "\n".join(got.decode().splitlines()[:5])
    )


@pytest.fixture(scope="module")
def tunnel_results(tmp_path_factory):
    root = tmp_path_factory.mktemp("golden-tunnel")
    train = make_tunnel_tour(300, scenario="light", random_state=11, first_indicator_m=40.0)
    test = make_tunnel_tour(300, scenario="heavy", random_state=12, first_indicator_m=30.0)
    write_tour(train, root / "train")
    write_tour(test, root / "test")
    model = root / "m.skops"
    assert main(["train", "tunnel", str(root / "train"), "--model", str(model),
                 "--quiet"]) == 0
    out = root / "test.txt"
    assert main(["detect", "tunnel", "--model", str(model), str(root / "test"),
                 "--out", str(out), "--quiet"]) == 0
    return out


def test_tunnel_detections_unchanged(tunnel_results):
    _compare(tunnel_results, "tunnel-results.txt")


def test_tunnel_clusters_unchanged(tunnel_results):
    companion = tunnel_results.with_name(tunnel_results.stem + ".clusters.csv")
    assert companion.is_file()
    _compare(companion, "tunnel-results.clusters.csv")


@pytest.mark.parametrize("scenario", ["dense", "crowded"])
def test_street_detections_unchanged(scenario, tmp_path):
    write_run(make_street_scans(1200, scenario="sparse", random_state=31), tmp_path / "a")
    write_run(make_street_scans(1200, scenario=scenario, random_state=32), tmp_path / "b")
    model = tmp_path / "m.skops"
    assert main(["train", "street", str(tmp_path / "a"), "--model", str(model)]) == 0
    out = tmp_path / "b.csv"
    assert main(["detect", "street", "--model", str(model), str(tmp_path / "b"),
                 "--out", str(out)]) == 0
    _compare(out, f"street-{scenario}.csv")
