"""The focus-of-expansion check of the motion stage (``max_focus_offset``)."""

import math

import numpy as np
import pytest

from tunnelsense import DecodedImage, FrameRecord, ImageFile
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.tunnel import PCCVerifier
from tunnelsense.tunnel._pcc_measures import focus_offset
from tunnelsense.tunnel._pcc_stream import frame_size

W, H = 640, 480
IMG = np.zeros((H, W), np.uint8)


def approached(z, lateral, rise, f=700.0, focus=(W / 2, H / 2), size=1.0):
    """Boxes of a sign ``size`` m tall at ``lateral``, ``rise`` m from the line of
    travel, seen at ranges ``z`` by a pinhole camera whose focus is ``focus``."""
    z = np.asarray(z, float)
    h = f * size / z
    x = focus[0] + f * lateral / z
    y = focus[1] + f * rise / z
    return np.column_stack([x - 0.225 * h, y - h / 2, 0.45 * h, h])


def centres(boxes):
    return boxes[:, 0] + boxes[:, 2] / 2, boxes[:, 1] + boxes[:, 3] / 2, boxes[:, 3]


def records(tracks, image=IMG):
    n = max(len(b) for b in tracks.values())
    out = []
    for k in range(n):
        ids = [t for t, b in tracks.items() if k < len(b)]
        out.append(FrameRecord("t", k + 1, image, {
            "cluster_boxes": np.array([tracks[t][k] for t in ids], float).reshape(-1, 4),
            "appearance": np.ones(len(ids), bool),
            "track_ids": np.array(ids, np.int64)}))
    return out


@pytest.mark.parametrize("yaw, pitch", [(0.0, 0.0), (4.0, 0.0), (-4.0, 3.0), (0.0, -3.0)])
def test_a_signs_path_passes_the_centre_within_the_focus_offset(yaw, pitch):
    """The path's line goes through the focus of expansion: it passes the
    frame's centre no farther than the focus is (yaw and pitch move the focus),
    at any resolution."""
    f = 700.0
    focus = (W / 2 + f * math.tan(math.radians(yaw)),
             H / 2 - f * math.tan(math.radians(pitch)))
    boxes = approached(np.linspace(60.0, 8.0, 40), -4.0, 0.3, f=f, focus=focus)
    x, y, _ = centres(boxes)
    bound = math.hypot((focus[0] - W / 2) / (W / 2), (focus[1] - H / 2) / (H / 2))
    offset = focus_offset(x, y, W, H)
    assert offset <= bound + 1e-9
    assert offset == pytest.approx(focus_offset(2 * x, 2 * y, 2 * W, 2 * H), abs=1e-12)
    if yaw == pitch == 0:
        assert offset == pytest.approx(0.0, abs=1e-9)


def test_a_far_sign_with_small_noisy_boxes_passes_near_the_centre():
    """Boxes 6-8 px tall rounded to whole pixels, their centres 0.5 px noisy, the
    camera turning (a curve): the short path still passes near the centre."""
    rng = np.random.default_rng(0)
    z = np.linspace(120.0, 90.0, 12)
    offsets = []
    for _ in range(300):
        x, y, _ = centres(approached(z, -4.0, 1.5))
        x = x + np.linspace(0.0, rng.uniform(-15, 15), len(x)) + rng.normal(0, 0.5, len(x))
        y = y + np.linspace(0.0, rng.uniform(-15, 15), len(y)) + rng.normal(0, 0.5, len(y))
        offsets.append(focus_offset(x, y, W, H))
    assert max(offsets) < 0.25
    # a path that does not move: where it is
    assert focus_offset([400.0, 400.0], [120.0, 120.0], W, H) == pytest.approx(
        math.hypot(0.25, 0.5))


def _bar(n=20):
    """A grey-scale bar burned in at the right edge: its thresholded extent grows
    downward with the frame's grey levels, so its centre slides down a nearly
    vertical, perfectly straight path (|r| = 1) while its height grows."""
    grow = np.linspace(0.0, 40.0, n)
    y = 230.0 + grow / 2
    x = 627.5 + 0.02 * grow
    h = 200.0 + grow
    return np.column_stack([x - 5, y - h / 2, np.full(n, 10.0), h])


def test_max_focus_offset_drops_a_burned_in_bar_and_keeps_signs():
    sign = approached(np.linspace(50.0, 12.0, 20), -4.0, 0.3,
                      focus=(W / 2 + 49.0, H / 2 - 37.0))  # yawed and pitched
    X = records({1: sign, 2: _bar()})
    found = {}
    for offset in (None, 0.5):
        out = PCCVerifier(max_focus_offset=offset).fit(X).predict(X)
        found[offset] = {int(d[4]) for r in out for d in r.payload["detections"]}
        state = PCCVerifier(max_focus_offset=offset).fit(X).start_stream()
        streamed = [r for x in X for r in state.push(x)] + state.close()
        assert [r.payload["detections"].tolist() for r in streamed] == \
            [r.payload["detections"].tolist() for r in out]
    assert found == {None: {1, 2}, 0.5: {1}}


def test_records_without_a_tour_name_are_checked_too():
    # frames built by hand may carry no tour name (None): the frame size is still
    # read from the first one, and the bar still dropped
    sign = approached(np.linspace(50.0, 12.0, 20), -4.0, 0.3)
    X = [FrameRecord(None, r.frame, r.source, r.payload)
         for r in records({1: sign, 2: _bar()})]
    out = PCCVerifier(max_focus_offset=0.5).fit(X).predict(X)
    assert {int(d[4]) for r in out for d in r.payload["detections"]} == {1}


def test_frame_size_is_that_of_the_boxes_pixels_without_decoding():
    rec = FrameRecord("t", 1, IMG, {})
    assert frame_size(rec) == (640.0, 480.0)
    # the detector's canonical frame (resampled): its own size, not the file's
    canonical = DecodedImage(ImageFile("missing.png", (240, 320)), np.zeros((480, 640)))
    assert frame_size(FrameRecord("t", 1, canonical, {})) == (640.0, 480.0)
    # a file that knows its shape is not read (this one does not exist)
    assert frame_size(FrameRecord("t", 1, ImageFile("missing.png", (240, 320)), {})) \
        == (320.0, 240.0)


def test_max_focus_offset_is_validated():
    X = records({1: _bar()})
    with pytest.raises(ValueError, match="max_focus_offset"):
        PCCVerifier(max_focus_offset=-0.1).fit(X)


@pytest.mark.parametrize("kw", [dict(yaw_deg=4.0), dict(pitch_deg=-3.0),
                                dict(curve_radius_m=-1500.0), dict(shake_deg=0.3),
                                dict(vertical_curve_radius_m=-800.0)])
def test_simulated_signs_trace_back_near_the_middle(kw):
    """Every sign's ground-truth path in a yawed, pitched, curving, shaken or
    cresting tour passes the centre within a few tenths of the half frame (far
    signs too: a height-based fit would put the focus of a far sign on a crest
    of 800 m at 0.8 of the half frame)."""
    tour = make_tunnel_tour(150, scenario="light", random_state=2,
                            indicator_spacing_m=60.0, **kw)
    gt = tour.gt[(tour.gt["class"] == 1) & (tour.gt["bb_height"] >= 4)]
    offsets = []
    for _, g in gt.groupby("id"):
        if len(g) >= 10:
            x = g.bb_left + g.bb_width / 2
            y = g.bb_top + g.bb_height / 2
            offsets.append(focus_offset(x, y, W, H))
    assert offsets and max(offsets) < 0.35, offsets
