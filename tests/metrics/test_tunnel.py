import pickle

import numpy as np
import pandas as pd
import pytest

from tunnelsense import FrameRecord
from tunnelsense.metrics import (
    gt_from_boxes,
    hypotheses_from_records,
    indicator_scores,
    make_tunnel_scorer,
    tunnel_scores,
)

IMG = np.zeros((100, 100), np.uint8)


def hyp(rows):
    return pd.DataFrame(
        rows,
        columns=["tour", "frame", "track_id", "bb_left", "bb_top", "bb_width", "bb_height",
                 "indicator", "trajectory_positive"],
    )


GT = pd.DataFrame(
    {
        "tour": ["t"] * 4,
        "frame": [1, 2, 3, 3],
        "id": [1, 1, 1, 2],
        "bb_left": [10.0, 10, 10, 60],
        "bb_top": [10.0, 10, 10, 60],
        "bb_width": [8.0, 8, 8, 4],
        "bb_height": [20.0, 20, 20, 8],  # id 2 is too small to count
    }
)


def test_table_1_counts():
    h = hyp(
        [
            ("t", 1, 1, 12, 12, 2, 14, True, True),  # hit
            ("t", 2, 1, 12, 12, 2, 14, False, True),  # miss
            ("t", 3, 1, 12, 12, 2, 14, True, True),  # hit
            ("t", 3, 2, 61, 61, 1, 4, True, False),  # on a small indicator: don't care
            ("t", 1, 3, 80, 80, 2, 2, True, False),  # false alarm
            ("t", 2, 3, 80, 80, 2, 2, False, False),  # correct negative
            ("t", 3, 3, 80, 80, 2, 2, False, False),  # correct negative
            ("t", 3, 4, 30, 30, 2, 2, False, False),  # correct negative
        ]
    )
    s = tunnel_scores(h, GT)
    assert s["cluster"] == {
        "total": 3, "correct": 2, "misses": 1, "false_alarms": 1,
        "detection_rate": 2 / 3, "false_alarm_rate": 1 / 4,
    }
    assert s["trajectory"] == {"indicators": 1, "detected": 1, "false_alarms": 0, "detection_rate": 1.0}
    assert tunnel_scores(h, GT, min_height=25)["cluster"]["total"] == 0
    assert tunnel_scores(h, GT, complete=False)["cluster"]["false_alarm_rate"] is None


def test_false_alarm_trajectory_and_majority_rule():
    h = hyp(
        [
            ("t", 1, 5, 80, 80, 2, 2, True, True),
            ("t", 2, 5, 80, 80, 2, 2, True, True),
            ("t", 3, 5, 12, 12, 2, 2, True, True),  # 1 of 3 on the indicator
        ]
    )
    s = tunnel_scores(h, GT)["trajectory"]
    assert s == {"indicators": 1, "detected": 0, "false_alarms": 1, "detection_rate": 0.0}


def test_class_column_filters_indicators():
    gt = GT.assign(**{"class": [1, 1, 1, 2]})
    gt.loc[3, "bb_height"] = 30.0
    h = hyp([("t", 3, 1, 61, 61, 1, 4, False, False)])
    assert tunnel_scores(h, gt)["cluster"]["total"] == 0  # a lamp is no indicator
    assert tunnel_scores(h, gt.assign(**{"class": 1}))["cluster"]["total"] == 1


def test_gt_from_boxes_links_identities():
    recs = [FrameRecord("t", f, IMG) for f in (1, 2, 3, 5)] + [FrameRecord("u", 1, IMG)]
    y = [
        np.array([[10, 10, 8, 20.0]]),
        np.array([[11, 10, 8, 20.0], [70, 10, 5, 10]]),
        np.array([[12, 10, 8, 20.0]]),
        np.array([[13, 10, 8, 20.0]]),  # a frame lost: the same sign, moved on
        np.array([[10, 10, 8, 20.0]]),
    ]
    gt = gt_from_boxes(recs, y)
    assert gt["id"].tolist() == [1, 1, 2, 1, 1, 1]
    assert gt["tour"].tolist() == ["t"] * 5 + ["u"]


def _moving_sign(frames, shown=None):
    """A sign 6 px wide moving 5 px a frame and growing 1 px taller a frame: its box
    at each frame of ``frames`` (or at the frame ``shown[f]`` shows, for a frozen
    picture)."""
    shown = shown or {}
    return [np.array([[100 + 5 * shown.get(f, f), 50, 6, 12 + shown.get(f, f)]])
            for f in frames]


def test_gt_from_boxes_counts_time_in_frame_numbers():
    # frames lost: one sign whatever the gaps, up to a second of them
    frames = [1, 2, 3, 5, 6, 9, 10, 11]
    recs = [FrameRecord("t", f, IMG, {"frame_rate": 30.0}) for f in frames]
    assert set(gt_from_boxes(recs, _moving_sign(frames))["id"]) == {1}
    # numbered without the gaps, the sign jumps by more than its reach: two signs
    recs = [FrameRecord("t", f, IMG, {"frame_rate": 30.0}) for f in range(1, 9)]
    assert set(gt_from_boxes(recs, _moving_sign(frames))["id"]) == {1, 2}
    # more than a second apart: another sign
    frames = [1, 2, 3, 40]
    recs = [FrameRecord("t", f, IMG, {"frame_rate": 30.0}) for f in frames]
    assert gt_from_boxes(recs, _moving_sign(frames))["id"].tolist() == [1, 1, 1, 2]


def test_gt_from_boxes_a_frozen_picture_keeps_its_identities():
    # frames 4-9 repeat the picture of frame 3 (a flat-field freeze), then the
    # sign is where it has moved meanwhile
    frames = list(range(1, 14))
    shown = {f: 3 for f in range(4, 10)}
    recs = [FrameRecord("t", f, IMG) for f in frames]
    gt = gt_from_boxes(recs, _moving_sign(frames, shown))
    assert set(gt["id"]) == {1}


def records_for_scoring():
    out = []
    for f in range(1, 4):
        out.append(
            FrameRecord(
                "t", f, IMG,
                {
                    "cluster_boxes": np.array([[12, 12, 2, 14], [80, 80, 2, 2]], float),
                    "track_ids": np.array([1, 2]),
                    "indicator": np.array([True, f == 1]),
                    "trajectory_positive": np.array([True, False]),
                },
            )
        )
    y = [np.array([[10, 10, 8, 20.0]])] * 3
    return out, y


def test_indicator_scores_and_scorers():
    recs, y = records_for_scoring()
    s = indicator_scores(recs, y)
    assert s["cluster"]["correct"] == 3 and s["cluster"]["false_alarms"] == 1
    assert s["cluster"]["false_alarm_rate"] == pytest.approx(1 / 3)

    class Fitted:
        def predict(self, X):
            return recs

    est = Fitted()
    assert make_tunnel_scorer("cluster_detection_rate")(est, recs, y) == 1.0
    assert make_tunnel_scorer("cluster_false_alarm_rate")(est, recs, y) == pytest.approx(-1 / 3)
    assert make_tunnel_scorer()(est, recs, y) == pytest.approx(2 / 3)
    assert make_tunnel_scorer("trajectory_false_alarms")(est, recs, y) == 0.0
    scorer = pickle.loads(pickle.dumps(make_tunnel_scorer("trajectory_detection_rate")))
    assert scorer(est, recs, y) == 1.0
    with pytest.raises(ValueError, match="metric"):
        make_tunnel_scorer("accuracy")


def test_hypotheses_need_detector_output():
    with pytest.raises(ValueError, match="predict"):
        hypotheses_from_records([FrameRecord("t", 1, IMG, {"cluster_boxes": np.zeros((1, 4))})])
    assert len(hypotheses_from_records([])) == 0


def test_gt_from_boxes_follows_a_sign_clipped_by_the_frame_edge():
    # the last frame of an indicator leaving the image: its clipped box jumps left
    # and no longer overlaps the previous one, but it is the same indicator
    recs = [FrameRecord("t", f, IMG) for f in (1, 2, 3)]
    y = [
        np.array([[12.0, 80, 35, 78]]),
        np.array([[7.5, 75.6, 35.2, 78.2]]),
        np.array([[-34.6, 53.5, 39.9, 88.5]]),
    ]
    assert gt_from_boxes(recs, y)["id"].tolist() == [1, 1, 1]
    # a box far from the previous one (more than half its size away) is another sign
    y[2] = np.array([[200.0, 75.6, 35.2, 78.2]])
    assert gt_from_boxes(recs, y)["id"].tolist() == [1, 1, 2]


def test_gt_from_boxes_follows_a_fast_sign_at_a_low_frame_rate():
    # a sign's last three frames at 15 fps: it moves more than its width per frame,
    # beyond the grown box, but as its motion continues (constant velocity)
    recs = [FrameRecord("t", f, IMG) for f in (1, 2, 3)]
    y = [
        np.array([[79.1, 100.0, 28.2, 62.5]]),
        np.array([[38.1, 76.5, 33.0, 73.2]]),
        np.array([[-19.8, 44.4, 39.7, 88.2]]),
    ]
    assert gt_from_boxes(recs, y)["id"].tolist() == [1, 1, 1]
    # without a predecessor there is no motion to continue: another sign
    assert gt_from_boxes(recs[1:], y[1:])["id"].tolist() == [1, 2]
    # nor against the motion
    y[2] = np.array([[120.0, 110.0, 39.7, 88.2]])
    assert gt_from_boxes(recs, y)["id"].tolist() == [1, 1, 2]
