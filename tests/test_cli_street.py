"""``train|detect|evaluate street`` through the street module's own sub-parsers."""

import argparse
import json

import pandas as pd
import pytest

from tunnelsense import _cli_street
from tunnelsense.datasets import make_street_scans

io = pytest.importorskip("tunnelsense.io")


def run_cli(argv):
    p = argparse.ArgumentParser(prog="tunnelsense")
    sub = p.add_subparsers(dest="command")
    verbs = {v: sub.add_parser(v).add_subparsers(dest="kind", required=True)
             for v in ("train", "detect", "evaluate")}
    _cli_street.register(verbs)
    args = p.parse_args(argv)
    return args.func(args)


@pytest.fixture(scope="module")
def rundirs(tmp_path_factory):
    root = tmp_path_factory.mktemp("runs")
    paths = []
    for i, s in enumerate(("sparse", "dense")):
        path = root / f"run{i}"
        io.write_run(make_street_scans(500, scenario=s, random_state=20 + i), path)
        paths.append(str(path))
    return paths


def test_train_detect_evaluate(rundirs, tmp_path, capsys):
    model = tmp_path / "m.joblib"
    assert run_cli(["train", "street", *rundirs, "--model", str(model), "--search"]) == 0
    assert model.is_file()
    out = tmp_path / "objects.csv"
    draw = tmp_path / "draw"
    assert run_cli(["detect", "street", "--model", str(model), rundirs[1],
                    "--out", str(out), "--draw", str(draw)]) == 0
    obj = pd.read_csv(out)
    assert {"id", "first_scan", "last_scan", "label", "mean_depth"} <= set(obj.columns)
    assert set(obj.label) <= {"parked", "passing"}
    assert any(p.name.startswith("range_image") for p in draw.iterdir())
    capsys.readouterr()
    assert run_cli(["evaluate", "street", rundirs[1], str(out), "--json"]) == 0
    scores = json.loads(capsys.readouterr().out)
    assert set(scores) == {"parked", "passing"}
    assert set(scores["parked"]) == {"tp", "fp", "fn", "recall", "precision"}
    assert scores["parked"]["recall"] >= 0.9
    assert run_cli(["evaluate", "street", rundirs[1], str(out)]) == 0
    assert "N/A" in capsys.readouterr().out


def test_errors_are_reported_not_raised(rundirs, tmp_path, capsys):
    assert run_cli(["detect", "street", "--model", str(tmp_path / "none.joblib"),
                    rundirs[0], "--out", str(tmp_path / "o.csv")]) == 2
    assert "model file not found" in capsys.readouterr().err
    bad = tmp_path / "bad.csv"
    bad.write_text("a,b\n1,2\n")
    assert run_cli(["evaluate", "street", rundirs[0], str(bad)]) == 2
    assert "lacks column" in capsys.readouterr().err
    assert run_cli(["train", "street", rundirs[0], "--model", str(tmp_path / "m"),
                    "--search"]) == 2
