"""The tunnel command's train and evaluate on tours of their own, and its demo
verb: no shared trained model (see test_cli_tunnel.py for detect and the model files)."""

import argparse
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from tunnelsense.cli import main
from tunnelsense.cli import tunnel as cli_tunnel
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.io import mot_result_lines, read_tour, write_tour


def lines_of(records):
    """Results lines of records, as detect writes them."""
    return [line for r in records for line in mot_result_lines(r)]



@pytest.fixture(scope="module")
def tour_dir(tmp_path_factory):
    """A tour folder of 60 frames."""
    tour = make_tunnel_tour(60, random_state=5, first_indicator_m=20.0)
    return write_tour(tour, tmp_path_factory.mktemp("tour") / "t")


def run(argv):
    parser = argparse.ArgumentParser(prog="tunnelsense")
    sub = parser.add_subparsers(dest="command")
    verbs = {
        v: sub.add_parser(v).add_subparsers(dest="kind", required=True)
        for v in ("train", "detect", "evaluate")
    }
    cli_tunnel.register(verbs)
    args = parser.parse_args(argv)
    return args.func(args)


def test_errors(tour_dir, tmp_path):
    with pytest.raises(FileNotFoundError, match="model file"):
        run(["detect", "tunnel", "--model", str(tmp_path / "none.skops"), str(tour_dir),
             "--out", str(tmp_path / "r.txt")])
    import joblib

    joblib.dump({"not": "a model"}, tmp_path / "bad.joblib")
    with pytest.raises(ValueError, match="not a model"):
        run(["detect", "tunnel", "--model", str(tmp_path / "bad.joblib"), str(tour_dir),
             "--out", str(tmp_path / "r.txt"), "--trust-pickle"])
    with pytest.raises(ValueError, match="pass --trust-pickle"):
        run(["detect", "tunnel", "--model", str(tmp_path / "bad.joblib"), str(tour_dir),
             "--out", str(tmp_path / "r.txt")])
    assert not (tmp_path / "r.txt").exists()
    with pytest.raises(FileNotFoundError, match="results file"):
        run(["evaluate", "tunnel", str(tour_dir), str(tmp_path / "none.txt")])
    with pytest.raises(ValueError, match="at least 2 tours"):
        run(["train", "tunnel", str(tour_dir), "--model", str(tmp_path / "m.skops"), "--search"])
    with pytest.raises(ValueError, match=r"\.skops"):
        run(["train", "tunnel", str(tour_dir), "--model", str(tmp_path / "m.bin")])


def test_demo_is_registered():
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command")
    cli_tunnel.register_top(sub)
    args = parser.parse_args(["demo", "--frames", "60"])
    assert args.frames == 60 and args.func is cli_tunnel._cmd_demo
    assert np.isfinite(args.min_height)


def test_evaluate_spells_a_missing_rate_n_a(tmp_path, capsys):
    """A tour without indicators: rates of 0 of 0 are n/a (JSON null), never a number."""
    from tunnelsense import Tour

    write_tour(Tour.from_array("empty", np.zeros((3, 16, 16), np.uint8)), tmp_path / "t")
    results = tmp_path / "r.txt"
    results.write_text("")
    assert main(["evaluate", "tunnel", str(tmp_path / "t"), str(results)]) == 0
    text = capsys.readouterr().out
    assert text.count("n/a") == 3 and "nan" not in text.lower()
    assert "0.0 %" not in text and "100.0 %" not in text
    assert main(["evaluate", "tunnel", str(tmp_path / "t"), str(results), "--json"]) == 0
    scores = json.loads(capsys.readouterr().out)
    assert scores["cluster"]["detection_rate"] is None
    assert scores["trajectory"]["detection_rate"] is None


def test_train_progress_names_each_stage(tmp_path, capsys):
    from tunnelsense.tunnel import make_indicator_pipeline

    tour = write_tour(make_tunnel_tour(60, random_state=5, first_indicator_m=20.0),
                      tmp_path / "t")
    assert main(["train", "tunnel", str(tour), "--model", str(tmp_path / "m.skops")]) == 0
    err = capsys.readouterr().err.replace("\r", "\n")
    assert "decoding frames: 100%" in err and "60/60" in err
    for name, _ in make_indicator_pipeline().steps:
        assert f"fitting {name}:" in err, name
    assert "fitted: 100%" in err and "6/6" in err


def test_train_sample_rate_decodes_and_fits_a_sample_in_time(tmp_path, capsys):
    """By default (and with --sample-rate all) every frame is fitted; --sample-rate 6
    fits every 5th frame of the 30 fps tour, the model that of those frames (the model
    card and the report say so); a rate that is not a positive number is refused by
    name before anything is read."""
    from tunnelsense import to_xy
    from tunnelsense.io import describe_model, load_model
    from tunnelsense.tunnel import make_indicator_pipeline

    def read_model_summary(path):
        return describe_model(path)["summary"]

    tour = write_tour(make_tunnel_tour(60, random_state=5, first_indicator_m=20.0),
                      tmp_path / "t")
    model = tmp_path / "m.skops"
    for extra in ([], ["--sample-rate", "all"]):
        assert main(["train", "tunnel", str(tour), "--model", str(model), "--force",
                     *extra]) == 0
        captured = capsys.readouterr()
        assert "60/60" in captured.err.replace("\r", "\n")
        assert "fitted on" not in captured.out
        summary = read_model_summary(model)
        assert summary["sample_rate"] is None and summary["frames_fitted"] == 60
    assert main(["train", "tunnel", str(tour), "--model", str(model), "--force",
                 "--sample-rate", "6"]) == 0
    assert "fitted on 12 frames (6 a second of each tour)" in capsys.readouterr().out
    summary = read_model_summary(model)
    assert summary["sample_rate"] == 6.0 and summary["frames_fitted"] == 12
    X, y, _ = to_xy([read_tour(tour)])
    assert X[0].payload["frame_rate"] == 30.0
    fitted = make_indicator_pipeline(random_state=0,
                                     verifier__n_jobs=os.cpu_count() or 1)
    fitted.fit(X[::5], y[::5])
    trained = load_model(model)
    assert lines_of(fitted.predict(X)) == lines_of(trained.predict(X))
    assert trained["keypoints"].low_ == fitted["keypoints"].low_
    assert trained["keypoints"].high_ == fitted["keypoints"].high_
    for bad in ("0", "-3", "nan", "fast"):
        with pytest.raises(SystemExit):
            main(["train", "tunnel", str(tour), "--model", str(tmp_path / "x.skops"),
                  "--sample-rate", bad])
        assert "--sample-rate: expected a positive number" in capsys.readouterr().err
    # a search fits every frame: not with a sample
    assert main(["train", "tunnel", str(tour), str(tour), "--model",
                 str(tmp_path / "x.skops"), "--search", "--sample-rate", "6"]) == 1
    assert "--sample-rate: --search fits every frame" in capsys.readouterr().err
    assert not (tmp_path / "x.skops").exists()


_TRAIN_AS_COMMAND = """
import gc, sys
import tunnelsense._fitting as fitting
import tunnelsense.io._sources as sources
usual = gc.get_threshold()
seen = {}
decode_tours, fit_pipeline = sources.decode_tours, fitting.fit_pipeline
def decoding(*args, **kwargs):  # the readers start while the command imports
    seen["importing"] = gc.get_threshold()[0] > usual[0]
    return decode_tours(*args, **kwargs)
def fitting_(*args, **kwargs):
    seen["fitting"] = gc.get_threshold() == usual and gc.get_freeze_count() > 0
    return fit_pipeline(*args, **kwargs)
sources.decode_tours, fitting.fit_pipeline = decoding, fitting_
sys.argv = ["tunnelsense", "train", "tunnel", sys.argv[1], "--model", sys.argv[2],
            "--quiet"]
from tunnelsense._cli import main
assert main() == 0  # as the command runs (its own process: start_command)
print(seen["importing"], seen["fitting"])
"""


def test_train_as_the_command_collects_seldom_while_importing(tmp_path):
    # as detect does: the garbage collector's threshold raised while the command
    # imports, then what was imported frozen out of its reach and the usual
    # thresholds back for the fit (a library call of the command does neither)
    tour = write_tour(make_tunnel_tour(40, random_state=5, first_indicator_m=20.0),
                      tmp_path / "t")
    done = subprocess.run([sys.executable, "-c", _TRAIN_AS_COMMAND, str(tour),
                           str(tmp_path / "m.skops")], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split()[-2:] == ["True", "True"]
    assert (tmp_path / "m.skops").is_file()
