"""Object matching and scores of the street detector."""

import numpy as np
import pandas as pd
import pytest

from tunnelsense import LaserGeometry, ScanSequence
from tunnelsense.metrics import (
    interval_iou,
    make_street_scorer,
    match_objects,
    objects_from_targets,
    street_confusion_matrix,
    street_scores,
)


def table(rows, run=None):
    df = pd.DataFrame(rows, columns=["first_scan", "last_scan", "label"])
    if run is not None:
        df.insert(0, "run", run)
    return df


def test_interval_iou_inclusive():
    np.testing.assert_allclose(interval_iou([[0, 9]], [[0, 9], [10, 19], [5, 14]]),
                               [[1.0, 0.0, 5 / 15]])


def test_match_is_one_to_one_and_threshold():
    gt = table([(0, 9, "parked")])
    det = table([(0, 9, "parked"), (1, 10, "parked"), (3, 12, "parked")])
    m = match_objects(gt, det)
    assert m["gt"].tolist() == [0] and m["detected"].tolist() == [0]
    s = street_scores(gt, det)["parked"]
    assert (s["tp"], s["fp"], s["fn"]) == (1, 2, 0)
    assert s["precision"] == pytest.approx(1 / 3)
    # IoU 0.5 exactly matches, below does not
    assert len(match_objects(table([(0, 9, "parked")]), table([(5, 14, "parked")]))) == 0
    assert len(match_objects(table([(0, 9, "parked")]), table([(0, 19, "parked")]))) == 1


def test_labels_are_preferred_and_counted_per_label():
    gt = table([(0, 19, "parked"), (2, 17, "passing")])
    det = table([(1, 18, "passing"), (0, 19, "parked")])
    s = street_scores(gt, det)
    assert s["parked"]["tp"] == 1 and s["passing"]["tp"] == 1
    wrong = street_scores(table([(0, 19, "parked")]), table([(0, 19, "passing")]))
    assert wrong["parked"]["fn"] == 1 and wrong["passing"]["fp"] == 1


def test_runs_do_not_match_across():
    gt = table([(0, 9, "parked")], run="a")
    assert street_scores(gt, table([(0, 9, "parked")], run="b"))["parked"]["tp"] == 0
    assert street_scores(gt, table([(0, 9, "parked")], run="a"))["parked"]["tp"] == 1


def test_paper_confusion_matrix():
    # the paper's TABLE 1: 36 detected, 4 missed, no false positive
    gt = table([(20 * i, 20 * i + 9, "parked") for i in range(40)])
    det = table([(20 * i, 20 * i + 9, "parked") for i in range(36)])
    m = street_confusion_matrix(gt, det)
    assert np.isnan(m.loc["negative", "negative"])
    assert m.loc["negative", "positive"] == 0
    assert m.loc["positive", "negative"] == 4 and m.loc["positive", "positive"] == 36
    s = street_scores(gt, det)["parked"]
    assert s["recall"] == pytest.approx(0.9) and s["precision"] == 1.0


def test_objects_from_targets_and_scorer():
    geom = LaserGeometry(0.0, 0.1, 0.0, 9.0, 1.0)
    X = ScanSequence.from_arrays(np.ones((6, 3)), np.arange(6.0), geom, run="r")
    y = [[[3, 1]], [[3, 1]], [[3, 1], [4, 2]], [[4, 2]], [], []]
    obj = objects_from_targets(X, y)
    assert obj[["id", "first_scan", "last_scan", "label"]].values.tolist() == [
        [3, 0, 2, "parked"], [4, 2, 3, "passing"]]

    class Echo:
        def predict(self, X):
            return [np.asarray(t, dtype=np.int64).reshape(-1, 2) for t in y]

    assert make_street_scorer("parked", "f1")(Echo(), X, y) == 1.0
    assert make_street_scorer("passing", "recall")(Echo(), X, y) == 1.0
    with pytest.raises(ValueError, match="label code 9"):
        objects_from_targets(X, [[[1, 9]]] + [[]] * 5)
    with pytest.raises(ValueError, match="metric"):
        make_street_scorer("parked", "accuracy")


def test_bad_tables():
    with pytest.raises(ValueError, match="lacks column"):
        street_scores(pd.DataFrame({"first_scan": [0]}), table([]))
    with pytest.raises(ValueError, match="first_scan <= last_scan"):
        street_scores(table([(5, 1, "parked")]), table([]))
    with pytest.raises(TypeError, match="DataFrame"):
        street_scores([(0, 1, "parked")], table([]))


def test_report_prints_undefined_rates_as_na():
    from tunnelsense.metrics import street_report

    gt = pd.DataFrame({"first_scan": [0, 20], "last_scan": [9, 29],
                       "label": ["parked", "parked"]})
    det = pd.DataFrame({"first_scan": [1], "last_scan": [10], "label": ["parked"]})
    report = street_report(gt, det)
    parked, passing = report.splitlines()[:2]
    assert "recall 0.500" in parked and "precision 1.000" in parked
    # no passing vehicle in the truth nor the detections: rates undefined, not 0
    assert passing.split()[-4:] == ["recall", "n/a", "precision", "n/a"]
    assert "NaN" not in report and "nan" not in report and "N/A" not in report
    assert street_scores(gt, det, zero_division=None)["passing"]["recall"] is None
