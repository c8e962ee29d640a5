"""``tunnelsense train|detect|evaluate street`` end to end."""

import json

import pandas as pd
import pytest

from tunnelsense import io
from tunnelsense._cli import main
from tunnelsense.datasets import make_street_scans


def run_cli(argv):
    """The real command line: errors go through its one handler."""
    return main(argv)


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
    # the progress counts the search's fits (9 settings, a fold per run, the refit)
    err = capsys.readouterr().err.replace("\r", "\n")
    assert "grid search (9 settings x 2 folds), fits: 100%" in err and "19/19" in err
    out = tmp_path / "objects.csv"
    draw = tmp_path / "draw"
    assert run_cli(["detect", "street", "--model", str(model), rundirs[1],
                    "--out", str(out), "--draw", str(draw)]) == 1
    assert "--trust-pickle" in capsys.readouterr().err
    assert not out.exists()
    assert run_cli(["detect", "street", "--model", str(model), rundirs[1],
                    "--out", str(out), "--draw", str(draw), "--trust-pickle"]) == 0
    obj = pd.read_csv(out)
    assert {"id", "first_scan", "last_scan", "label", "mean_depth"} <= set(obj.columns)
    assert set(obj.label) <= {"parked", "passing"}
    assert any(p.name.startswith("range_image") for p in draw.iterdir())
    capsys.readouterr()
    assert run_cli(["evaluate", "street", rundirs[1], str(out), "--json"]) == 0
    scores = json.loads(capsys.readouterr().out)
    assert set(scores) == {"parked", "passing", "parked_classes"}
    assert set(scores["parked"]) == {"tp", "fp", "fn", "recall", "precision"}
    assert scores["parked"]["recall"] >= 0.9
    # per vehicle class: the truth's classes (rows) against the detected ones
    classes = scores["parked_classes"]
    assert set(classes["confusion"]) == {"car", "van", "motorbike"}
    assert set(classes["confusion"]["car"]) == {"car", "van", "motorbike", "none",
                                                "missed"}
    found = sum(sum(v for k, v in row.items() if k != "missed")
                for row in classes["confusion"].values())
    assert found == scores["parked"]["tp"]
    assert classes["classes"]["car"]["accuracy"] >= 0.9
    assert run_cli(["evaluate", "street", rundirs[1], str(out)]) == 0
    printed = capsys.readouterr().out
    assert "parked vehicles by class" in printed and "class accuracy" in printed
    assert "n/a" in printed  # the undefined true negatives of the confusion matrix
    assert "NaN" not in printed and "N/A" not in printed


def test_errors_are_reported_not_raised(rundirs, tmp_path, capsys):
    assert run_cli(["detect", "street", "--model", str(tmp_path / "none.joblib"),
                    rundirs[0], "--out", str(tmp_path / "o.csv")]) == 1
    assert "model file not found" in capsys.readouterr().err
    bad = tmp_path / "bad.csv"
    bad.write_text("a,b\n1,2\n")
    assert run_cli(["evaluate", "street", rundirs[0], str(bad)]) == 1
    assert "lacks column" in capsys.readouterr().err
    assert run_cli(["train", "street", rundirs[0], "--model", str(tmp_path / "m"),
                    "--search"]) == 1


@pytest.fixture(scope="module")
def long_run(tmp_path_factory):
    root = tmp_path_factory.mktemp("long")
    path = root / "run"
    io.write_run(make_street_scans(3000, scenario="dense", random_state=5), path)
    model = root / "m.skops"
    assert run_cli(["train", "street", str(path), "--model", str(model)]) == 0
    full = root / "full.csv"
    assert run_cli(["detect", "street", "--model", str(model), str(path), "--out",
                    str(full), "--quiet"]) == 0
    return path, model, full


def test_train_writes_safe_model_with_summary(long_run):
    from tunnelsense.io import describe_model

    info = describe_model(long_run[1])
    assert info["format"] == "skops"
    assert [r["name"] for r in info["summary"]["runs"]] == ["street-dense-5"]
    assert info["summary"]["runs"][0]["parked"] > 10
    assert info["summary"]["scans"] == 3000
    assert info["summary"]["parameters"]["cluster__cut"] == 0.6


def test_detect_joblib_equals_skops(long_run, tmp_path, capsys):
    path, model, full = long_run
    pickle = tmp_path / "m.joblib"
    import joblib

    from tunnelsense.io import load_model
    joblib.dump(load_model(model), pickle)
    out = tmp_path / "o.csv"
    assert run_cli(["detect", "street", "--model", str(pickle), str(path), "--out",
                    str(out), "--quiet", "--trust-pickle"]) == 0
    assert "pickle" in capsys.readouterr().err
    assert out.read_bytes() == full.read_bytes()
    rows = pd.read_csv(full)
    assert len(rows) > 40
    assert rows["id"].is_monotonic_increasing


def test_resume_after_truncation_equals_uninterrupted(long_run, tmp_path):
    path, model, full = long_run
    data = full.read_bytes()
    for cut in (len(data) // 3, len(data) // 2 + 7, len(data) - 3):
        out = tmp_path / "o.csv"
        out.write_bytes(data[:cut])  # killed while writing a row
        assert run_cli(["detect", "street", "--model", str(model), str(path), "--out",
                        str(out), "--resume", "--quiet"]) == 0
        assert out.read_bytes() == data
    # resuming another run's file is refused, not mixed
    out.write_bytes(data.replace(b",parked,", b",passing,", 1)[: len(data) // 2])
    assert run_cli(["detect", "street", "--model", str(model), str(path), "--out",
                    str(out), "--resume", "--quiet"]) == 1


def test_killed_detect_leaves_valid_rows_and_resumes(long_run, tmp_path):
    import signal
    import subprocess
    import sys
    import time

    path, model, full = long_run
    out = tmp_path / "o.csv"
    cmd = [sys.executable, "-c", "import sys; from tunnelsense._cli import main; "
           "sys.exit(main())", "detect", "street", "--model", str(model), str(path),
           "--out", str(out), "--quiet"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:
        if out.is_file() and out.read_bytes().count(b"\n") >= 4:
            proc.send_signal(signal.SIGKILL)
            break
        time.sleep(0.002)
    proc.wait(timeout=60)
    left = out.read_bytes()
    whole = full.read_bytes()
    complete = left[: left.rfind(b"\n") + 1]
    assert whole.startswith(complete)  # every complete row is a row of the full run
    assert len(complete.splitlines()) >= 4
    pd.read_csv(out)  # valid CSV
    assert run_cli(["detect", "street", "--model", str(model), str(path), "--out",
                    str(out), "--resume", "--quiet"]) == 0
    assert out.read_bytes() == whole


def _fitted(estimator):
    return {k: v for k, v in vars(estimator).items()
            if k.endswith("_") and not k.startswith("_")}


def test_train_street_equals_fit_in_python(rundirs, tmp_path):
    """The command line and Python fit the same model on the same runs: the ego
    speed comes with the scans that read_run reads, not from the command line."""
    import numpy as np

    from tunnelsense import to_xy
    from tunnelsense.io import load_model, read_run
    from tunnelsense.street import ScanClusterer

    model = tmp_path / "m.skops"
    assert run_cli(["train", "street", *rundirs, "--model", str(model)]) == 0
    cli = load_model(model).named_steps["cluster"]
    runs = [read_run(p) for p in rundirs]
    X, y, _ = to_xy(runs)
    assert X[0].payload["speed"] == pytest.approx(runs[0].info["speed_kmh_mean"] / 3.6)
    est = ScanClusterer().fit(X, y)
    assert est.get_params() == cli.get_params()
    assert _fitted(est).keys() == _fitted(cli).keys() and _fitted(est)
    for key, value in _fitted(est).items():
        assert np.array_equal(np.asarray(value), np.asarray(_fitted(cli)[key]))
    assert all(np.array_equal(a, b)
               for a, b in zip(est.predict(X), cli.predict(X), strict=True))
    assert est.detect(X).equals(cli.detect(X))


def test_a_run_without_speed_asks_for_it(tmp_path, capsys):
    """A run folder whose info gives no ego speed is never measured at a guessed
    speed: train and detect refuse it, naming the run and --speed."""
    from tunnelsense import Run, ScanSequence

    run = make_street_scans(300, scenario="sparse", random_state=24)
    info = {k: v for k, v in run.info.items() if not k.startswith("speed")}
    bare = Run(run.name, ScanSequence([r.evolve(speed=float("nan")) for r in run.scans]),
               run.gt, info)
    path = tmp_path / "bare"
    io.write_run(bare, path)
    assert io.ego_speed(io.read_run(path).info) is None
    model = tmp_path / "m.skops"
    assert run_cli(["train", "street", str(path), "--model", str(model)]) == 1
    err = capsys.readouterr().err
    assert str(path) in err and "no ego speed" in err and "--speed M/S" in err
    assert not model.exists()
    assert run_cli(["train", "street", str(path), "--model", str(model),
                    "--speed", "11.1"]) == 0
    out = tmp_path / "o.csv"
    capsys.readouterr()
    assert run_cli(["detect", "street", "--model", str(model), str(path),
                    "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert str(path) in err and "no ego speed" in err and "--speed M/S" in err
    assert not out.exists()
    assert run_cli(["detect", "street", "--model", str(model), str(path),
                    "--out", str(out), "--speed", "11.1"]) == 0
    assert len(pd.read_csv(out)) > 0
