"""A mark burned into the picture (``overlay=``): where it is, what it changes."""

import numpy as np
import pytest

from tunnelsense.datasets import make_tunnel_tour


def _tour(n=12, **kw):
    return make_tunnel_tour(n, scenario="light", random_state=4, **kw)


def _images(tour):
    return np.stack([r.image for r in tour.frames])


def test_bar_is_static_at_the_right_edge_and_changes_nothing_else():
    plain, bar = _tour(), _tour(overlay="bar")
    a, b = _images(plain), _images(bar)
    changed = (a != b).any(axis=0)
    rows, cols = np.nonzero(changed)
    h, w = a.shape[1:]
    # half the frame high, a few pixels wide, at the right edge
    assert rows.min() >= h // 4 and rows.max() < h // 4 + h // 2
    assert cols.min() >= w - 16 and cols.max() < w - 5
    strip = b[:, h // 4 : h // 4 + h // 2, w - 16 : w - 6]
    assert (strip == strip[0]).all()  # the same in every frame
    assert strip[0, 0, 0] == 255 and strip[0, -1, 0] == 0  # white to black
    assert np.all(np.diff(strip[0, :, 0].astype(int)) <= 0)
    assert plain.gt.equals(bar.gt)  # a mark is no object


def test_clock_runs_in_the_top_left_corner():
    plain, clock = _tour(n=40), _tour(n=40, overlay="clock")
    a, b = _images(plain), _images(clock)
    rows, cols = np.nonzero((a != b).any(axis=0))
    h, w = a.shape[1:]
    assert rows.max() < h // 10 and cols.max() < w // 2
    text = b[:, : h // 10, : w // 2].astype(int)
    assert text.max() == 255
    # the hundredths run from frame to frame; the text differs a second apart
    assert (text[0] != text[30]).any()
    assert plain.gt.equals(clock.gt)


def test_marks_keep_their_place_at_any_sensor_size_and_bit_depth():
    small = _images(_tour(n=2, overlay="bar", sensor_scale=0.5))
    h, w = small.shape[1:]
    assert (h, w) == (240, 320)
    assert small[0, h // 4, w - 6] == 255 and small[0, h // 4 + h // 2 - 1, w - 6] == 0
    deep = _images(_tour(n=2, overlay="bar", bit_depth=14))
    assert deep.dtype == np.uint16 and deep[0, 120, 630] == 255 * 64


def test_unknown_overlay_is_refused_naming_it():
    with pytest.raises(ValueError, match="overlay must be one of"):
        _tour(n=2, overlay="logo")
