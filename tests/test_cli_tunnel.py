import argparse
import json

import numpy as np
import pytest

from tunnelsense import _cli_tunnel
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.io import read_mot_results, write_tour


def run(argv):
    parser = argparse.ArgumentParser(prog="tunnelsense")
    sub = parser.add_subparsers(dest="command")
    verbs = {
        v: sub.add_parser(v).add_subparsers(dest="kind", required=True)
        for v in ("train", "detect", "evaluate")
    }
    _cli_tunnel.register(verbs)
    _cli_tunnel.register_top(sub)
    args = parser.parse_args(argv)
    return args.func(args)


@pytest.fixture(scope="module")
def tour_dirs(tmp_path_factory):
    root = tmp_path_factory.mktemp("tours")
    dirs = []
    for seed in (0, 1):
        tour = make_tunnel_tour(120, random_state=seed, first_indicator_m=50.0)
        write_tour(tour, root / f"tour-{seed}")
        dirs.append(root / f"tour-{seed}")
    return dirs


def test_train_detect_evaluate(tour_dirs, tmp_path, capsys):
    model = tmp_path / "model.joblib"
    assert run(["train", "tunnel", str(tour_dirs[0]), "--model", str(model)]) == 0
    assert model.is_file()
    out = tmp_path / "res" / "results.txt"
    draw = tmp_path / "draw"
    assert run(["detect", "tunnel", "--model", str(model), str(tour_dirs[1]),
                "--out", str(out), "--draw", str(draw)]) == 0
    res = read_mot_results(out)
    assert list(res.columns[:7]) == ["frame", "id", "bb_left", "bb_top", "bb_width", "bb_height", "conf"]
    assert (res[["x", "y", "z"]] == -1).all().all()
    assert (out.parent / "results.clusters.csv").is_file()
    assert len(list(draw.glob("*.png"))) == 120
    capsys.readouterr()
    assert run(["evaluate", "tunnel", str(tour_dirs[1]), str(out), "--json"]) == 0
    scores = json.loads(capsys.readouterr().out)
    assert set(scores["cluster"]) == {
        "total", "correct", "misses", "false_alarms", "detection_rate", "false_alarm_rate"
    }
    assert set(scores["trajectory"]) == {"indicators", "detected", "false_alarms", "detection_rate"}
    assert scores["trajectory"]["indicators"] == 1
    assert 0 <= scores["cluster"]["false_alarm_rate"] <= 1
    # without the companion file the false-alarm rate is unknown
    (out.parent / "results.clusters.csv").unlink()
    assert run(["evaluate", "tunnel", str(tour_dirs[1]), str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["cluster"]["false_alarm_rate"] is None
    assert run(["evaluate", "tunnel", str(tour_dirs[1]), str(out)]) == 0
    text = capsys.readouterr().out
    assert "detection rate" in text and "n/a" in text


def test_detect_writes_the_detections_of_the_model(tour_dirs, tmp_path):
    import joblib

    from tunnelsense.io import read_tour

    model = tmp_path / "model.joblib"
    run(["train", "tunnel", str(tour_dirs[0]), "--model", str(model)])
    out = tmp_path / "r.txt"
    run(["detect", "tunnel", "--model", str(model), str(tour_dirs[1]), "--out", str(out)])
    records = joblib.load(model).predict(read_tour(tour_dirs[1]).frames)
    n = sum(len(r.payload["detections"]) for r in records)
    assert len(read_mot_results(out)) == n


def test_errors(tour_dirs, tmp_path):
    with pytest.raises(FileNotFoundError, match="model file"):
        run(["detect", "tunnel", "--model", str(tmp_path / "none"), str(tour_dirs[0]),
             "--out", str(tmp_path / "r.txt")])
    import joblib

    joblib.dump({"not": "a model"}, tmp_path / "bad.joblib")
    with pytest.raises(ValueError, match="not a model"):
        run(["detect", "tunnel", "--model", str(tmp_path / "bad.joblib"), str(tour_dirs[0]),
             "--out", str(tmp_path / "r.txt")])
    with pytest.raises(FileNotFoundError, match="results file"):
        run(["evaluate", "tunnel", str(tour_dirs[0]), str(tmp_path / "none.txt")])
    with pytest.raises(ValueError, match="at least 2 tours"):
        run(["train", "tunnel", str(tour_dirs[0]), "--model", str(tmp_path / "m"), "--search"])


def test_demo_is_registered():
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command")
    _cli_tunnel.register_top(sub)
    args = parser.parse_args(["demo", "--frames", "60"])
    assert args.frames == 60 and args.func is _cli_tunnel._cmd_demo
    assert np.isfinite(args.min_height)
