"""The indicator detector's pictures: the paper's colours, a legend, the frame number."""

import numpy as np

from tunnelsense import FrameRecord
from tunnelsense.plotting import DRAW_COLOURS, draw_detections


def _record(frame, image):
    return FrameRecord("t", frame, image, {
        "cluster_boxes": np.array([[100.0, 80.0, 8.0, 16.0], [40.0, 90.0, 6.0, 6.0]]),
        "appearance": np.array([True, False]), "track_ids": np.array([1, 2]),
        "trajectory_positive": np.array([True, False])})


def test_pictures_carry_a_legend_and_the_frame_number():
    image = np.full((120, 160), 90, np.uint8)
    (_, plain), = draw_detections([_record(7, image)], legend=False)
    (_, seven), = draw_detections([_record(7, image)])
    (_, eight), = draw_detections([_record(8, image)])
    changed = np.argwhere((seven != plain).any(axis=2))
    rows, cols = changed.max(axis=0)
    # the top of the picture only (OpenCV's text widths differ between releases:
    # 130 px with 5.0, 140 px with 4.8)
    assert changed.size and rows < 70 and cols < 150
    for key in DRAW_COLOURS:  # a key for every colour
        assert (seven[:70, :150] == DRAW_COLOURS[key]).all(axis=2).any(), key
    assert (seven[:14] != eight[:14]).any()  # the frame number differs
    assert (seven[14:] == eight[14:]).all()
    assert (plain[85:90, 98:110] == DRAW_COLOURS["appearance_positive"]).all(axis=2).any()


def test_sixteen_bit_frames_are_drawn_in_eight_bits():
    image = np.linspace(0, 60000, 120 * 160).reshape(120, 160).astype(np.uint16)
    (record, picture), = draw_detections([_record(1, image)], scale=2)
    assert record.frame == 1 and picture.dtype == np.uint8
    assert picture.shape == (240, 320, 3)
