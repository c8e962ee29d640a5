"""The tunnel commands' text reports and the demonstration: tunnel/_reports.py."""

import pytest

from tunnelsense.tunnel._reports import format_detection, run_demo


def test_format_detection_says_what_was_drawn_and_written():
    facts = {"drawn": [200_000, 300_000], "detections": 3, "frames": 9,
             "trajectories": 1}
    text = format_detection(facts, "r/out.txt", draw="pics")
    drawn, wrote = text.splitlines()
    assert drawn == "drew 2 pictures (0.5 MB) in pics"
    assert wrote.startswith("wrote r/out.txt: 3 detections on 9 frames")
    assert "r/out.clusters.csv" in wrote


def test_run_demo_refuses_a_tour_without_indicators():
    with pytest.raises(ValueError, match="--frames 10 is too short"):
        next(run_demo(10))
