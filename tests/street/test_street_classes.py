"""Vehicle classes: the rule on features, on simulated streets, in the object
table, its CSV file, the scores per class and the census."""

import numpy as np
import pandas as pd
import pytest
from sklearn.base import clone

from tunnelsense.datasets import make_street_scans
from tunnelsense.exceptions import InputFormatError
from tunnelsense.io import read_objects, read_run, read_run_gt, write_run
from tunnelsense.metrics import street_class_scores, street_report
from tunnelsense.street import (
    CENSUS_CLASSES,
    OBJECT_COLUMNS,
    OBJECT_CSV_COLUMNS,
    VEHICLE_CLASSES,
    ScanClusterer,
    _census,
    _classes,
    census,
    class_features,
    scan_distances,
    train_detector,
    vehicle_class,
    write_objects,
)


def features(**kw):
    f = {"roof": 0.9, "wall": 0.0, "top": 1.5, "extent": 1.6, "length": 4.2}
    f.update(kw)
    return f


def test_one_definition_of_the_classes():
    assert _classes.VEHICLE_CLASSES is _census.VEHICLE_CLASSES is VEHICLE_CLASSES
    assert VEHICLE_CLASSES == ("car", "van", "motorbike")
    assert CENSUS_CLASSES[:3] == VEHICLE_CLASSES


@pytest.mark.parametrize("kw, expected", [
    ({}, "car"),
    ({"length": 2.6, "extent": 1.3}, "car"),  # a city car
    ({"roof": 0.0, "length": 4.5, "extent": 1.5}, "car"),  # no roof seen, car-sized
    ({"wall": 0.6, "roof": 0.2, "top": 2.0}, "van"),  # above the region of interest
    ({"top": 1.85}, "van"),  # below the ceiling, high over most of its length
    ({"length": 9.0, "top": 1.5}, "van"),  # a long low lorry
    ({"roof": 0.0, "top": 1.2, "length": 2.0, "extent": 0.4}, "motorbike"),
    ({"roof": 0.0, "top": 1.3, "length": 0.8, "extent": 2.0}, "motorbike"),  # across
    ({"roof": 0.0, "top": 1.2, "length": 5.0, "extent": 0.5}, "motorbike"),  # a row
    ({"roof": 0.6, "top": 1.2, "length": 2.0, "extent": 0.9}, "car"),  # a roof
    ({"length": np.nan, "roof": 0.8}, "car"),  # passing: no length
    # a car seen end on (a bay at right angles): 1.7 m along, 2.8 m deep, its
    # roof not seen; a motorbike is never 1.2 m wide both ways
    ({"roof": 0.0, "top": 1.5, "length": 1.7, "extent": 2.8}, "car"),
    ({"roof": 0.0, "top": 1.3, "length": 1.0, "extent": 2.8}, "motorbike"),
    ({"roof": 0.0, "top": 1.3, "length": 1.7, "extent": 2.2}, "motorbike"),
])
def test_the_rule(kw, expected):
    assert vehicle_class(features(**kw)) == expected


def test_the_rule_follows_its_parameters():
    tall_suv = features(top=1.7)
    assert vehicle_class(tall_suv) == "car"
    assert vehicle_class(tall_suv, van_height=1.65) == "van"
    assert vehicle_class(features(length=7.5)) == "van"
    assert vehicle_class(features(length=7.5), van_length=8.0) == "car"
    end_on = features(roof=0.0, length=1.7, extent=2.8)
    assert vehicle_class(end_on) == "car"
    assert vehicle_class(end_on, min_car_length=3.0) == "motorbike"
    assert vehicle_class(end_on, motorbike_width=1.8) == "motorbike"


def test_class_features_per_scan():
    # 4 scans; scan 1 cut in two clusters (flank 5.0-5.2, roof 5.3-6.6)
    f = class_features(np.array([1, 3, 0, 2]), np.array([1.4, 1.6, 0.9, 2.0]),
                       np.array([0, 1, 1, 2, 3]),
                       np.array([5.0, 5.0, 5.3, np.inf, 5.0]),
                       np.array([6.5, 5.2, 6.6, np.nan, 5.2]), 4.0)
    assert f["roof"] == 0.5 and f["wall"] == 0.5
    assert f["top"] == 1.5 and f["length"] == 4.0  # the median of the profile
    assert f["extent"] == pytest.approx(1.5)  # median of 1.5, 1.6 (scan 1), 0.2


@pytest.fixture(scope="module")
def model():
    return train_detector([make_street_scans(800, scenario="sparse",
                                             random_state=41)])[0][-1]


@pytest.mark.parametrize("scenario, overrides, cut", [
    ("dense", {}, 0.6),  # cars, vans and parallel motorbikes nose to tail
    ("dense", {}, 0.4),  # a finer cut parts flanks from roofs: the same classes
    ("sparse", {"motorbike_fraction": 0.6, "motorbike_across_fraction": 0.6,
                "parked_cluster_size": 4.0, "parked_gap_m": 12.0}, 0.6),
])
def test_classes_of_a_simulated_street(model, scenario, overrides, cut):
    run = make_street_scans(1500, scenario=scenario, random_state=43, **overrides)
    detected = clone(model).set_params(cut=cut).fit(run.scans).detect(run.scans)
    assert list(detected.columns) == list(OBJECT_COLUMNS)
    assert set(detected["vehicle_class"]) <= set(VEHICLE_CLASSES)
    s = street_class_scores(run.gt, detected)
    present = [c for c in VEHICLE_CLASSES if s["classes"][c]["n"]]
    assert len(present) >= 2
    for c in present:
        assert s["classes"][c]["accuracy"] >= 0.9, (c, s["confusion"])
    assert s["accuracy"] >= 0.95


def test_objects_of_other_labels_have_no_class(model):
    run = make_street_scans(600, scenario="crowded", random_state=44)
    table = model.detect(run.scans, all_objects=True)
    other = table["label"] == "other"
    assert other.any()
    assert (table.loc[other, "vehicle_class"] == "").all()
    assert table.loc[~other, "vehicle_class"].isin(VEHICLE_CLASSES).all()


def test_the_class_confusion_matrix():
    gt = pd.DataFrame({"first_scan": [0, 20, 40, 60, 80], "last_scan": [9, 29, 49, 69, 89],
                       "label": ["parked"] * 4 + ["passing"],
                       "vehicle_class": ["car", "motorbike", "van", "car", "car"]})
    det = pd.DataFrame({"first_scan": [0, 21, 60, 80, 100],
                        "last_scan": [9, 29, 69, 89, 109],
                        "label": ["parked"] * 3 + ["passing", "parked"],
                        "vehicle_class": ["car", "car", "", "car", "van"]})
    s = street_class_scores(gt, det)
    m = s["confusion"]
    assert m.columns.tolist() == ["car", "van", "motorbike", "none", "missed"]
    assert m.loc["car"].tolist() == [1, 0, 0, 1, 0]  # the passing car is not counted
    assert m.loc["motorbike"].tolist() == [1, 0, 0, 0, 0]
    assert m.loc["van"].tolist() == [0, 0, 0, 0, 1]
    assert s["classes"]["car"] == {"n": 2, "matched": 2, "correct": 1, "recall": 1.0,
                                   "accuracy": 0.5}
    assert s["classes"]["van"]["accuracy"] is None
    assert s["accuracy"] == pytest.approx(1 / 3)
    text = street_report(gt, det)
    assert "by class" in text and "class accuracy 0.333" in text
    assert "by class" not in street_report(gt.drop(columns="vehicle_class"), det)
    with pytest.raises(ValueError, match="detected has no vehicle_class column"):
        street_class_scores(gt, det.drop(columns="vehicle_class"))


def test_the_csv_round_trip_keeps_the_classes(model, tmp_path):
    run = make_street_scans(900, scenario="dense", random_state=45)
    table = model.detect(run.scans)
    path = tmp_path / "objects.csv"
    write_objects(model, run.scans, path)
    assert path.read_text().splitlines()[0] == ",".join(OBJECT_CSV_COLUMNS)
    assert OBJECT_CSV_COLUMNS[-1] == "vehicle_class"
    back = read_objects(path)
    assert back["vehicle_class"].tolist() == table["vehicle_class"].tolist()
    assert back["first_scan"].tolist() == table["first_scan"].tolist()
    # a table of an older version (no class column) still reads, unclassified
    old = tmp_path / "old.csv"
    pd.read_csv(path).drop(columns="vehicle_class").to_csv(old, index=False)
    assert "vehicle_class" not in read_objects(old)
    counts = census(read_objects(old), scan_distances(
        [s.stamp for s in run.scans], 11.0), segment_length=1e4)
    assert counts["unclassified"].sum() == (table["label"] == "parked").sum()


def test_census_of_a_detect_table_counts_its_classes(model, tmp_path):
    run = make_street_scans(900, scenario="dense", random_state=46)
    path = tmp_path / "objects.csv"
    write_objects(model, run.scans, path)
    objects = read_objects(path)
    distances = scan_distances([s.stamp for s in run.scans], 11.0)
    table = census(objects, distances, segment_length=1e4)
    parked = objects[objects["label"] == "parked"]
    for c in VEHICLE_CLASSES:
        assert table[c].sum() == (parked["vehicle_class"] == c).sum()
    assert table["unclassified"].sum() == 0
    assert table[["car", "van"]].to_numpy().sum() > 0


def test_classes_from_hand_built_scans():
    """A sedan is a car, a box rising above the region of interest a van, and a
    narrow raised body without a roof, shorter than a car, a motorbike."""
    from _street_scenes import make_run, sedan

    boxes = [
        {"s0": 2.0, "s1": 6.4, "depth": 5.0, "width": 1.7, "top": sedan},
        {"s0": 9.0, "s1": 11.0, "depth": 5.0, "width": 0.5, "bottom": 0.35, "top": 1.2},
        {"s0": 14.0, "s1": 19.0, "depth": 4.8, "width": 1.9, "top": 2.6},
    ]
    run = make_run(boxes, ["parked"] * 3, n_scans=180, mount_height=2.4)
    det = ScanClusterer().fit(run.scans).detect(run.scans)
    assert det["label"].tolist() == ["parked"] * 3
    assert det["vehicle_class"].tolist() == ["car", "motorbike", "van"]


def test_the_ground_truth_carries_the_class_through_its_file(tmp_path):
    run = make_street_scans(600, scenario="hard", random_state=47)
    assert set(run.gt["vehicle_class"]) <= set(VEHICLE_CLASSES)
    kinds = {v["id"]: v["kind"] for v in run.info["vehicles"]}
    small = [i for i, k in kinds.items() if k == "small"]
    assert (run.gt.set_index("id").loc[small, "vehicle_class"] == "car").all()
    write_run(run, tmp_path / "run")
    back = read_run(tmp_path / "run").gt
    assert back["vehicle_class"].tolist() == run.gt["vehicle_class"].tolist()
    # a gt.csv without the column (an older run) reads as before; a bad class is refused
    gt = tmp_path / "run" / "gt.csv"
    text = gt.read_text()
    old = tmp_path / "old.csv"
    old.write_text("\n".join(",".join(line.split(",")[:4])
                             for line in text.splitlines()) + "\n")
    assert "vehicle_class" not in read_run_gt(old)
    gt.write_text(text.replace(",car\n", ",lorry\n", 1))
    with pytest.raises(InputFormatError, match="vehicle_class is 'lorry'"):
        read_run_gt(gt)


def test_an_objects_file_with_a_bad_class_is_refused(tmp_path):
    path = tmp_path / "o.csv"
    path.write_text("id,first_scan,last_scan,label,vehicle_class\n1,0,9,parked,car\n"
                    "2,10,19,parked,bus\n3,20,29,parked,\n")
    with pytest.raises(InputFormatError, match="line 3: vehicle_class is 'bus'"):
        read_objects(path)
    path.write_text("id,first_scan,last_scan,label,vehicle_class\n1,0,9,parked,car\n"
                    "3,20,29,other,\n")
    assert read_objects(path)["vehicle_class"].tolist() == ["car", ""]
