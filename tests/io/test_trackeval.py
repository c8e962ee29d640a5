"""Our MOTChallenge results files, scored by TrackEval's CLEAR MOT metrics.

TrackEval (the ``trackeval`` extra) is the tracking community's reference code for
MOTChallenge files.  These tests write a simulated tour and the detector's results
with the public writers of :mod:`tunnelsense.io` (and the ``detect tunnel``
command), score them with TrackEval's ``MotChallenge2DBox`` dataset and ``CLEAR``
metric, and compare with :mod:`tunnelsense.metrics`.

**What the two scorers share, and where they differ.**

* *The same boxes.*  TrackEval evaluates one class ("pedestrian", MOTChallenge class
  1) and treats class 2 as a distractor (detections matching it are dropped).  Class
  1 is our indicator and class 2 our lamp, so TrackEval is given a copy of the ground
  truth restricted to class 1: both scorers then see the indicator boxes only, in the
  same frames.  TrackEval drops ground-truth rows whose ``conf`` is 0; the simulator
  writes 1 everywhere (checked).  So ``CLR_TP + CLR_FN`` is exactly the number of
  indicator boxes, and ``CLR_TP + CLR_FP`` exactly the number of results lines.
* *Matching.*  TrackEval matches a detection to a box when their IoU is at least 0.5
  (one to one per frame, preferring the previous frame's pairs).  Our scorer matches a
  detection to an indicator when the centre of the detection's rectangle lies in the
  box (``tunnelsense.metrics.tunnel_scores``; a keypoint cluster's rectangle is often
  a grid-quantized sliver of the sign, which IoU would punish).  The two rules nest:
  if the centre of a rectangle B lies outside a box A, less than half of B overlaps A
  along one axis, so ``|A & B| < |B| / 2 <= |A | B| / 2`` and the IoU is below 0.5.
  Hence every TrackEval match is a detection our scorer counts on an indicator
  (``CLR_TP <= total``), and every detection our scorer calls a false alarm is a
  TrackEval false positive (``false_alarms <= CLR_FP``); with perfect boxes the two
  agree exactly, and a detection shifted so that only its centre stays in the box is a
  hit for us and a miss plus a false positive for TrackEval.
* *Counted boxes.*  Our scorer ignores indicators smaller than ``min_height`` (14 px,
  don't care); TrackEval counts every box.  The comparison uses ``min_height=0``;
  TrackEval is also run on the boxes our scorer counts.
* *What is counted.*  MOTA, ``CLR_FN`` and ``IDSW`` are per box and per identity
  switch; our figures are per cluster (``total``, ``correct``, ``false_alarms``) and
  per indicator (``indicators``, ``detected``, ``false_alarms`` trajectories).  An
  indicator found by two trajectories is one identity switch for TrackEval and one
  detected indicator for us, so those figures are not compared; MOTA is checked
  against its definition, ``1 - (FN + FP + IDSW) / boxes``.

CI installs TrackEval and sets ``TUNNELSENSE_REQUIRE_TRACKEVAL=1``, which turns a
missing TrackEval into a failure instead of a skip.
"""

import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tunnelsense import MOT_GT_COLUMNS
from tunnelsense._cli import main
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.io import (
    read_mot_gt,
    read_mot_results,
    write_mot_gt,
    write_mot_results,
    write_tour,
)
from tunnelsense.metrics import tunnel_scores

if os.environ.get("TUNNELSENSE_REQUIRE_TRACKEVAL"):
    import trackeval
else:
    trackeval = pytest.importorskip(
        "trackeval", reason="TrackEval is the optional trackeval extra"
    )

SEQ = "tour-a"


def write_sequence(root: Path, gt: pd.DataFrame, results: pd.DataFrame, n_frames: int):
    """TrackEval's folder layout: gt/<seq>/{seqinfo.ini,gt/gt.txt}, trackers/ts/data/."""
    seq = root / "gt" / SEQ
    seq.mkdir(parents=True)
    (seq / "seqinfo.ini").write_text(
        f"[Sequence]\nname={SEQ}\nimDir=img1\nframeRate=30\nseqLength={n_frames}\n"
        "imWidth=640\nimHeight=480\nimExt=.png\n"
    )
    write_mot_gt(gt[gt["class"] == 1], seq / "gt" / "gt.txt")
    write_mot_results(results, root / "trackers" / "ts" / "data" / f"{SEQ}.txt")


def trackeval_clear(root: Path) -> dict:
    """TrackEval's CLEAR metrics of tracker ``ts`` on ``SEQ`` (no files written)."""
    evaluator = trackeval.Evaluator(
        {
            "USE_PARALLEL": False,
            "BREAK_ON_ERROR": True,
            "PRINT_RESULTS": False,
            "PRINT_ONLY_COMBINED": False,
            "PRINT_CONFIG": False,
            "TIME_PROGRESS": False,
            "DISPLAY_LESS_PROGRESS": True,
            "OUTPUT_SUMMARY": False,
            "OUTPUT_EMPTY_CLASSES": False,
            "OUTPUT_DETAILED": False,
            "PLOT_CURVES": False,
        }
    )
    dataset = trackeval.datasets.MotChallenge2DBox(
        {
            "GT_FOLDER": str(root / "gt"),
            "TRACKERS_FOLDER": str(root / "trackers"),
            "TRACKERS_TO_EVAL": ["ts"],
            "SKIP_SPLIT_FOL": True,
            "SEQ_INFO": {SEQ: None},
            "PRINT_CONFIG": False,
        }
    )
    results, messages = evaluator.evaluate([dataset], [trackeval.metrics.CLEAR()])
    assert messages["MotChallenge2DBox"]["ts"] == "Success"
    return results["MotChallenge2DBox"]["ts"][SEQ]["pedestrian"]["CLEAR"]


def our_scores(gt: pd.DataFrame, results: pd.DataFrame, min_height=0.0) -> dict:
    """tunnelsense.metrics on a results file: every line a positive detection."""
    hyp = pd.DataFrame(
        {
            "tour": SEQ,
            "frame": results["frame"],
            "track_id": results["id"],
            "bb_left": results["bb_left"],
            "bb_top": results["bb_top"],
            "bb_width": results["bb_width"],
            "bb_height": results["bb_height"],
            "indicator": True,
            "trajectory_positive": True,
        }
    )
    return tunnel_scores(hyp, gt.assign(tour=SEQ), min_height=min_height, complete=False)


def assert_shared_definitions(clear, ours, gt, results):
    n_boxes = int((gt["class"] == 1).sum())
    assert (gt["conf"] != 0).all()  # TrackEval would drop conf-0 boxes, we would not
    assert clear["CLR_TP"] + clear["CLR_FN"] == n_boxes
    assert clear["CLR_TP"] + clear["CLR_FP"] == len(results)
    # IoU >= 0.5 implies centre inside: the two matching rules nest.
    assert clear["CLR_TP"] <= ours["cluster"]["total"]
    assert ours["cluster"]["false_alarms"] <= clear["CLR_FP"]
    assert ours["cluster"]["total"] + ours["cluster"]["false_alarms"] == len(results)
    mota = 1 - (clear["CLR_FN"] + clear["CLR_FP"] + clear["IDSW"]) / n_boxes
    assert clear["MOTA"] == pytest.approx(mota)


def small_gt():
    """Two indicators over 4 frames, and a lamp (class 2) in every frame."""
    rows = []
    for frame in range(1, 5):
        rows.append((frame, 1, 100.0 + 5 * frame, 200.0, 20.0, 40.0, 1.0, 1, 1.0))
        rows.append((frame, 2, 400.0 - 5 * frame, 180.0, 16.0, 32.0, 1.0, 1, 1.0))
        rows.append((frame, 3, 300.0, 50.0, 30.0, 10.0, 1.0, 2, 1.0))
    return pd.DataFrame(rows, columns=list(MOT_GT_COLUMNS))


def as_results(boxes: pd.DataFrame, ids) -> pd.DataFrame:
    return pd.DataFrame(
        {
            "frame": boxes["frame"].to_numpy(),
            "id": np.asarray(ids),
            "bb_left": boxes["bb_left"].to_numpy(),
            "bb_top": boxes["bb_top"].to_numpy(),
            "bb_width": boxes["bb_width"].to_numpy(),
            "bb_height": boxes["bb_height"].to_numpy(),
            "conf": 1.0,
        }
    )


def test_perfect_results_agree_exactly(tmp_path):
    gt = small_gt()
    indicators = gt[gt["class"] == 1]
    results = as_results(indicators, indicators["id"])
    write_sequence(tmp_path, gt, results, n_frames=4)
    clear = trackeval_clear(tmp_path)
    ours = our_scores(gt, results)
    assert_shared_definitions(clear, ours, gt, results)
    assert (clear["CLR_TP"], clear["CLR_FN"], clear["CLR_FP"], clear["IDSW"]) == (8, 0, 0, 0)
    assert clear["MOTA"] == 1.0
    assert (ours["cluster"]["total"], ours["cluster"]["correct"]) == (8, 8)
    assert ours["cluster"]["false_alarms"] == 0
    assert ours["trajectory"]["detected"] == ours["trajectory"]["indicators"] == 2


def test_where_the_matching_rules_differ(tmp_path):
    """A box shifted by 40 % of its size: centre inside (ours: hit), IoU < 0.5 (miss)."""
    gt = small_gt()
    indicators = gt[gt["class"] == 1]
    shifted = indicators.assign(
        bb_left=indicators["bb_left"] + 0.4 * indicators["bb_width"],
        bb_top=indicators["bb_top"] + 0.4 * indicators["bb_height"],
    )
    # one detection far from any indicator, on the lamp: a false alarm for both
    lamp = gt[(gt["class"] == 2) & (gt["frame"] == 1)]
    results = pd.concat(
        [as_results(shifted, shifted["id"]), as_results(lamp, [9])], ignore_index=True
    )
    write_sequence(tmp_path, gt, results, n_frames=4)
    clear = trackeval_clear(tmp_path)
    ours = our_scores(gt, results)
    assert_shared_definitions(clear, ours, gt, results)
    assert (clear["CLR_TP"], clear["CLR_FN"], clear["CLR_FP"]) == (0, 8, 9)
    assert (ours["cluster"]["total"], ours["cluster"]["false_alarms"]) == (8, 1)


def test_identity_switch_is_counted_by_trackeval_only(tmp_path):
    gt = small_gt()
    indicators = gt[gt["class"] == 1].reset_index(drop=True)
    ids = np.where(indicators["id"] == 1, 1, 2)
    ids[(indicators["id"] == 1) & (indicators["frame"] >= 3)] = 7  # a new trajectory
    results = as_results(indicators, ids)
    write_sequence(tmp_path, gt, results, n_frames=4)
    clear = trackeval_clear(tmp_path)
    ours = our_scores(gt, results)
    assert_shared_definitions(clear, ours, gt, results)
    assert clear["IDSW"] == 1
    assert clear["MOTA"] == pytest.approx(1 - 1 / 8)
    # ours: two trajectories on indicator 1, still one indicator detected, no false alarm
    assert ours["trajectory"]["detected"] == 2
    assert ours["trajectory"]["false_alarms"] == 0


def test_detect_tunnel_results_scored_by_trackeval(tmp_path):
    """Simulate, train and detect with the command line; score the results file."""
    train = make_tunnel_tour(240, scenario="heavy", random_state=0, first_indicator_m=40.0)
    test = make_tunnel_tour(240, scenario="light", random_state=3, first_indicator_m=50.0)
    write_tour(train, tmp_path / "train")
    write_tour(test, tmp_path / "test")
    model, out = tmp_path / "model.skops", tmp_path / "results.txt"
    assert main(["train", "tunnel", str(tmp_path / "train"), "--model", str(model),
                 "--quiet"]) == 0
    assert main(["detect", "tunnel", "--model", str(model), str(tmp_path / "test"),
                 "--out", str(out), "--quiet", "--jobs", "0"]) == 0

    gt = read_mot_gt(tmp_path / "test" / "gt" / "gt.txt")
    results = read_mot_results(out)
    assert len(results) > 0
    root = tmp_path / "trackeval"
    write_sequence(root, gt, results, n_frames=len(test))
    clear = trackeval_clear(root)
    ours = our_scores(gt, results)
    assert_shared_definitions(clear, ours, gt, results)
    # The detector's boxes are the signs' own regions: most detections on an
    # indicator also overlap its box by IoU >= 0.5.
    assert clear["CLR_TP"] >= 0.8 * ours["cluster"]["total"]
    # Every indicator taller than 14 px somewhere (the default) is found.
    trajectory = our_scores(gt, results, min_height=14.0)["trajectory"]
    assert trajectory["detected"] == trajectory["indicators"] >= 1

    # Most indicator boxes are far signs a few pixels tall, which our scorer does not
    # count (and the detector does not aim at); TrackEval counts them as misses.
    # Given only the boxes our scorer counts, TrackEval's MOTA is high.
    counted = gt[(gt["class"] != 1) | (gt["bb_height"] >= 14.0)]
    root = tmp_path / "trackeval-counted"
    write_sequence(root, counted, results, n_frames=len(test))
    clear = trackeval_clear(root)
    assert clear["CLR_TP"] + clear["CLR_FN"] == int((counted["class"] == 1).sum())
    assert clear["MOTA"] >= 0.8
    assert clear["IDSW"] == 0
