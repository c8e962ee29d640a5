"""``tunnelsense survey street`` end to end: a census of a simulated run."""

import numpy as np
import pandas as pd
import pytest

from tunnelsense import LaserGeometry, Run, ScanSequence
from tunnelsense._cli import main
from tunnelsense.datasets import make_street_scans
from tunnelsense.io import write_run
from tunnelsense.street import CENSUS_COLUMNS


@pytest.fixture(scope="module")
def street(tmp_path_factory):
    """A simulated dense street, a model trained on another run, its detections."""
    root = tmp_path_factory.mktemp("survey")
    train = write_run(make_street_scans(1500, scenario="dense", random_state=11),
                      root / "train")
    run = write_run(make_street_scans(2000, scenario="dense", random_state=12,
                                      name="street"), root / "run")
    model = root / "m.skops"
    assert main(["train", "street", str(train), "--model", str(model), "--quiet"]) == 0
    objects = root / "objects.csv"
    assert main(["detect", "street", str(run), "--model", str(model), "--out",
                 str(objects), "--quiet"]) == 0
    return {"root": root, "run": run, "model": model, "objects": objects}


def test_census_of_a_detected_run_with_its_picture(street, tmp_path, capsys):
    out, plot = tmp_path / "census.csv", tmp_path / "census.png"
    assert main(["survey", "street", str(street["run"]), "--model", str(street["model"]),
                 "--out", str(out), "--plot", str(plot), "--segment-length", "40"]) == 0
    captured = capsys.readouterr()
    assert "street: detecting" in captured.err  # the progress bar
    table = pd.read_csv(out)
    assert list(table.columns) == list(CENSUS_COLUMNS)
    detected = pd.read_csv(street["objects"])
    n_parked = int((detected["label"] == "parked").sum())
    assert n_parked > 20
    # the detector's classes are counted: no parked vehicle is unclassified
    assert table["parked"].sum() == n_parked
    assert table["unclassified"].sum() == 0
    parked = detected[detected["label"] == "parked"]
    for name in ("car", "van", "motorbike"):
        assert table[name].sum() == (parked["vehicle_class"] == name).sum()
    assert table["car"].sum() > 0
    assert f"{n_parked} parked vehicles" in captured.out
    # 40 m segments over the distance the run's speed gives (~2000 scans at ~40 km/h)
    assert (table["kerb_length_m"].iloc[:-1] == 40.0).all()
    assert 250 < table["end_m"].iloc[-1] < 340
    assert table["occupancy"].between(0.0, 1.0).all()
    assert table["occupancy"].mean() > 0.3  # a dense street
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_census_of_an_objects_file_equals_detecting(street, tmp_path):
    by_model, by_file = tmp_path / "a.csv", tmp_path / "b.csv"
    assert main(["survey", "street", str(street["run"]), "--model", str(street["model"]),
                 "--out", str(by_model), "--quiet"]) == 0
    assert main(["survey", "street", str(street["run"]), "--objects",
                 str(street["objects"]), "--out", str(by_file), "--quiet"]) == 0
    assert by_model.read_bytes() == by_file.read_bytes()


def test_the_detected_census_is_near_the_true_one(street, tmp_path):
    detected, true = tmp_path / "d.csv", tmp_path / "t.csv"
    assert main(["survey", "street", str(street["run"]), "--objects",
                 str(street["objects"]), "--out", str(detected), "--quiet"]) == 0
    assert main(["survey", "street", str(street["run"]), "--objects",
                 str(street["run"] / "gt.csv"), "--out", str(true), "--quiet"]) == 0
    d, t = pd.read_csv(detected), pd.read_csv(true)
    assert abs(d["parked"].sum() - t["parked"].sum()) <= 0.1 * t["parked"].sum()
    assert np.abs(d["occupancy"] - t["occupancy"]).max() < 0.1


def test_vehicle_classes_of_the_objects_file_are_counted(street, tmp_path):
    objects = pd.read_csv(street["objects"]).drop(columns="vehicle_class")
    parked = objects["label"] == "parked"
    classes = np.array(["car", "van", "motorbike"])[np.arange(len(objects)) % 3]
    objects["vehicle_class"] = np.where(parked, classes, "")
    path = tmp_path / "classified.csv"
    objects.to_csv(path, index=False)
    out = tmp_path / "census.csv"
    assert main(["survey", "street", str(street["run"]), "--objects", str(path),
                 "--out", str(out), "--quiet"]) == 0
    table = pd.read_csv(out)
    for name in ("car", "van", "motorbike"):
        assert table[name].sum() == (objects["vehicle_class"] == name).sum()
    assert table["unclassified"].sum() == 0


def test_an_existing_output_is_never_overwritten(street, tmp_path, capsys):
    out, plot = tmp_path / "census.csv", tmp_path / "census.png"
    out.write_text("precious\n")
    args = ["survey", "street", str(street["run"]), "--objects", str(street["objects"]),
            "--quiet"]
    assert main([*args, "--out", str(out)]) == 1
    assert "--out" in capsys.readouterr().err and out.read_text() == "precious\n"
    # the picture is refused before the census is written
    fresh = tmp_path / "fresh.csv"
    plot.write_bytes(b"old picture")
    assert main([*args, "--out", str(fresh), "--plot", str(plot)]) == 1
    assert "--plot" in capsys.readouterr().err
    assert not fresh.exists() and plot.read_bytes() == b"old picture"
    # nor may the picture be the census, nor either an input, even with --force
    assert main([*args, "--out", str(fresh), "--plot", str(fresh)]) == 1
    assert main([*args, "--out", str(fresh), "--plot", str(tmp_path / "p.jpg")]) == 1
    assert main([*args, "--out", str(street["objects"]), "--force"]) == 1
    assert "input of this command" in capsys.readouterr().err
    assert pd.read_csv(street["objects"])["label"].notna().all()
    assert not fresh.exists()
    # --force replaces an output
    assert main([*args, "--out", str(out), "--force"]) == 0
    assert list(pd.read_csv(out).columns) == list(CENSUS_COLUMNS)


def test_bad_inputs_are_named(street, tmp_path, capsys):
    out = tmp_path / "census.csv"
    short = write_run(make_street_scans(300, scenario="dense", random_state=1),
                      tmp_path / "short")
    # objects of the long run do not fit the short one
    assert main(["survey", "street", str(short), "--objects", str(street["objects"]),
                 "--out", str(out), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert str(street["objects"]) in err and "beyond the 300 scans" in err
    assert main(["survey", "street", str(short), "--objects",
                 str(tmp_path / "none.csv"), "--out", str(out), "--quiet"]) == 1
    assert "objects file not found" in capsys.readouterr().err
    assert not out.exists()
    with pytest.raises(SystemExit):
        main(["survey", "street", str(short), "--objects", str(street["objects"]),
              "--out", str(out), "--segment-length", "-5"])
    assert "--segment-length" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # --model or --objects, not both
        main(["survey", "street", str(short), "--objects", str(street["objects"]),
              "--model", str(street["model"]), "--out", str(out)])


GEOMETRY = LaserGeometry(-1.4, 0.0087, 0.05, 8.191, 2.0)


def _plain_run(name, speeds=None):
    stamps = np.arange(600) / 75
    run = Run.from_arrays(name, np.full((600, 8), 5.0), stamps, GEOMETRY)
    if speeds is not None:
        run = Run(name, ScanSequence([r.evolve(speed=float(v))
                                      for r, v in zip(run.scans, speeds, strict=True)]))
    return run


def test_a_run_without_speed_needs_speed(tmp_path, capsys):
    run = write_run(_plain_run("nospeed"), tmp_path / "run")
    objects = tmp_path / "objects.csv"
    objects.write_text("id,first_scan,last_scan,label\n0,75,149,parked\n")
    out = tmp_path / "census.csv"
    assert main(["survey", "street", str(run), "--objects", str(objects), "--out",
                 str(out), "--quiet"]) == 1
    assert "--speed" in capsys.readouterr().err and not out.exists()
    assert main(["survey", "street", str(run), "--objects", str(objects), "--out",
                 str(out), "--quiet", "--speed", "10", "--segment-length", "25"]) == 0
    table = pd.read_csv(out)
    # 600 scans at 75 per second and 10 m/s: 80 m; the object from 10 m to 20 m
    np.testing.assert_allclose(table["end_m"], [25, 50, 75, 80])
    np.testing.assert_allclose(table["parked_length_m"], [10, 0, 0, 0])
    np.testing.assert_allclose(table["occupancy"], [0.4, 0, 0, 0])


def test_distance_follows_a_bags_odometry(tmp_path):
    pytest.importorskip("rosbags")
    from tunnelsense.io import write_run_bag

    # 5 m/s for 4 s, then 15 m/s for 4 s: 20 m, then 60 m
    speeds = np.where(np.arange(600) < 300, 5.0, 15.0)
    bag = write_run_bag(_plain_run("odometry", speeds), tmp_path / "run.bag",
                        version="ros1")
    objects = tmp_path / "objects.csv"
    objects.write_text("id,first_scan,last_scan,label\n0,280,319,parked\n")
    out = tmp_path / "census.csv"
    assert main(["survey", "street", str(bag), "--objects", str(objects), "--out",
                 str(out), "--quiet", "--segment-length", "20"]) == 0
    table = pd.read_csv(out)
    np.testing.assert_allclose(table["end_m"], [20, 40, 60, 80], atol=1e-3)
    # 20 scans of 1/15 m before the boundary at 20 m, 20 scans of 0.2 m after it
    np.testing.assert_allclose(table["parked_length_m"], [1.333, 4.0, 0, 0], atol=2e-3)
    assert table["parked"].tolist() == [0, 1, 0, 0]


def test_survey_street_is_registered(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["survey", "street", "--help"])
    assert exc.value.code == 0
    text = capsys.readouterr().out
    assert "tunnelsense survey street" in text
    assert all(option in text for option in ("--segment-length", "--speed", "--plot"))



@pytest.mark.parametrize("clock, message", [
    ("reset", "stamps must not decrease; scan 300"),  # back 5 s at scan 300
    ("stalled", "stamps must span some time; all 600 scans"),  # never advances
])
def test_a_clock_that_resets_or_stalls_is_refused_naming_the_run(tmp_path, capsys,
                                                                 clock, message):
    stamps = (np.arange(600) / 75 - np.where(np.arange(600) >= 300, 5.0, 0.0)
              if clock == "reset" else np.zeros(600))
    run = write_run(Run.from_arrays(clock, np.full((600, 8), 5.0), stamps, GEOMETRY),
                    tmp_path / "run")
    objects = tmp_path / "objects.csv"
    objects.write_text("id,first_scan,last_scan,label\n0,75,149,parked\n")
    out = tmp_path / "census.csv"
    assert main(["survey", "street", str(run), "--objects", str(objects), "--out",
                 str(out), "--quiet", "--speed", "10"]) == 1
    err = capsys.readouterr().err
    assert str(run) in err and message in err
    assert not out.exists()
