"""The receding-object check of the motion stage (``max_inward_offset``) and the
quadratic path's refusal of a cluster hopping between fixed spots."""

import math

import numpy as np
import pytest

from tunnelsense import FrameRecord
from tunnelsense.tunnel import PCCVerifier, make_indicator_pipeline
from tunnelsense.tunnel._pcc_measures import curve_fit_r, inward_offset

W, H = 640, 480
IMG = np.zeros((H, W), np.uint8)


def seen(z, lateral, rise, f=700.0, focus=(W / 2, H / 2), size=1.0, width=0.45):
    """Boxes of an object ``size`` m tall at ``lateral``, ``rise`` m from the line
    of travel, at ranges ``z`` (falling: approached; rising: receding), seen by a
    pinhole camera whose focus of expansion is ``focus``."""
    z = np.asarray(z, float)
    h = f * size / z
    x = focus[0] + f * lateral / z
    y = focus[1] + f * rise / z
    return np.column_stack([x - width * h / 2, y - h / 2, width * h, h])


def centres(boxes):
    return boxes[:, 0] + boxes[:, 2] / 2, boxes[:, 1] + boxes[:, 3] / 2


def records(tracks, image=IMG, tour="t"):
    n = max(len(b) for b in tracks.values())
    out = []
    for k in range(n):
        ids = [t for t, b in tracks.items() if k < len(b)]
        out.append(FrameRecord(tour, k + 1, image, {
            "cluster_boxes": np.array([tracks[t][k] for t in ids], float).reshape(-1, 4),
            "appearance": np.ones(len(ids), bool),
            "track_ids": np.array(ids, np.int64)}))
    return out


def focus_at(yaw, pitch, f=700.0):
    return (W / 2 + f * math.tan(math.radians(yaw)), H / 2 - f * math.tan(math.radians(pitch)))


@pytest.mark.parametrize("yaw, pitch", [(0.0, 0.0), (4.0, 0.0), (-4.0, 3.0), (0.0, -3.0)])
@pytest.mark.parametrize("lateral, rise", [(-4.0, 0.3), (4.0, 0.3), (-4.0, 2.5)])
def test_an_approached_sign_heads_away_from_the_focus(yaw, pitch, lateral, rise):
    """A sign the camera approaches, on either wall, low or high, its camera yawed
    or pitched: its inward offset is at most the focus's own offset from the
    centre, at any resolution and frame rate (every other frame)."""
    focus = focus_at(yaw, pitch)
    bound = math.hypot((focus[0] - W / 2) / (W / 2), (focus[1] - H / 2) / (H / 2))
    for z in (np.linspace(60.0, 8.0, 40), np.linspace(120.0, 100.0, 12)):  # near, far
        x, y = centres(seen(z, lateral, rise, focus=focus))
        value = inward_offset(x, y, W, H)
        assert value <= bound + 1e-9
        assert value == pytest.approx(inward_offset(2 * x, 2 * y, 2 * W, 2 * H), abs=1e-12)
        assert inward_offset(x[::2], y[::2], W, H) <= bound + 1e-9


@pytest.mark.parametrize("lateral, rise", [(1.0, 0.5), (-0.8, 0.6), (0.9, -0.4)])
def test_a_receding_object_heads_for_the_focus(lateral, rise):
    """A warm part of a vehicle pulling away (its wheels, exhaust, a tail light)
    shrinks toward the focus: its inward offset is its mean distance from it."""
    x, y = centres(seen(np.linspace(6.0, 12.0, 30), lateral, rise))
    u, v = (x - W / 2) / (W / 2), (y - H / 2) / (H / 2)
    assert inward_offset(x, y, W, H) == pytest.approx(np.hypot(u.mean(), v.mean()), rel=1e-6)
    assert inward_offset(x, y, W, H) > 0.25
    # the same path driven the other way (the camera approaching) heads outward
    assert inward_offset(x[::-1], y[::-1], W, H) < -0.25


def test_inward_offset_of_degenerate_paths():
    assert inward_offset([], [], W, H) == 0.0
    assert inward_offset([500.0], [100.0], W, H) == 0.0
    assert inward_offset([500.0, 500.0, 500.0], [100.0, 100.0, 100.0], W, H) == 0.0


def _receding_tail_light():
    """A tail light 0.9 m right, 0.5 m below the camera on a vehicle pulling away
    from 3 to 8 m: a straight path through the focus, travelling far."""
    return seen(np.linspace(3.0, 8.0, 30), 0.9, 0.5, size=0.2, width=1.0)


def test_max_inward_offset_drops_a_receding_object_and_keeps_signs():
    signs = {1: seen(np.linspace(50.0, 12.0, 20), -4.0, 0.3, focus=focus_at(4.0, -3.0)),
             2: seen(np.linspace(110.0, 90.0, 14), 4.0, 0.3, focus=focus_at(-4.0, 3.0)),
             # a sign in a queue at a crawl: it grows by a tenth over the trajectory
             3: seen(np.linspace(20.0, 18.0, 40), -4.0, 0.3)}
    X = records({**signs, 9: _receding_tail_light()})
    found = {}
    for limit in (None, 0.3):
        kw = dict(criterion="quadratic-motion", min_travel=0.0, max_inward_offset=limit)
        out = PCCVerifier(**kw).fit(X).predict(X)
        found[limit] = {int(d[4]) for r in out for d in r.payload["detections"]}
        state = PCCVerifier(**kw).fit(X).start_stream()
        streamed = [r for x in X for r in state.push(x)] + state.close()
        assert [r.payload["detections"].tolist() for r in streamed] == \
            [r.payload["detections"].tolist() for r in out]
    assert found == {None: {1, 2, 3, 9}, 0.3: {1, 2, 3}}


def test_max_inward_offset_reads_each_tours_frame_size():
    """Two tours of different sizes in one call: each trajectory is judged in
    its own tour's frame (the tail light of a 1280 x 960 tour is refused, the
    same boxes read as a sign on the left half of a 2560 x 1920 one are not)."""
    light = _receding_tail_light() * 2  # 1280 x 960
    small = records({9: light}, image=np.zeros((2 * H, 2 * W), np.uint8), tour="a")
    big = records({9: light}, image=np.zeros((4 * H, 4 * W), np.uint8), tour="b")
    out = PCCVerifier(max_inward_offset=0.3).fit(small + big).predict(small + big)
    found = {r.tour for r in out if len(r.payload["detections"])}
    assert found == {"b"}


def test_max_inward_offset_is_validated():
    X = records({1: _receding_tail_light()})
    with pytest.raises(ValueError, match="max_inward_offset"):
        PCCVerifier(max_inward_offset=-0.1).fit(X)


def _hopping(n=30):
    """A 1-pixel cluster linked across three stuck pixels near one another: it
    stays on one spot, then hops to another, and back."""
    spots = np.array([[331.0, 258.0], [319.0, 258.0], [318.0, 252.0]])
    which = np.array([0] * 12 + [1] * 8 + [0] * 6 + [2] + [1] * 3)[:n]
    xy = spots[which]
    return np.column_stack([xy[:, 0] - 0.5, xy[:, 1] - 0.5, np.ones(n), np.ones(n)])


def test_a_parabola_through_three_spots_is_no_path():
    x, y = centres(_hopping())
    assert curve_fit_r(x, y) == 0.0
    # four distinct abscissae on a bending path: a fit that means something
    t = np.arange(12.0)
    assert curve_fit_r(300 - 3 * t, 200 + 0.1 * t * t) == pytest.approx(1.0)


def test_the_default_motion_check_refuses_a_cluster_hopping_between_stuck_pixels():
    params = {k.split("__", 1)[1]: v
              for k, v in make_indicator_pipeline().get_params().items()
              if k.startswith("motion__")}
    sign = seen(np.linspace(50.0, 12.0, 20), -4.0, 0.3)
    X = records({1: sign, 2: _hopping()})
    out = PCCVerifier(**params).fit(X).predict(X)
    assert {int(d[4]) for r in out for d in r.payload["detections"]} == {1}


def test_a_saved_verifier_keeps_max_inward_offset_and_the_strict_reader_checks_it(tmp_path):
    from tunnelsense.io import UntrustedModelError, load_model, save_model
    from tunnelsense.io._model_checks import _check_step

    X = records({1: seen(np.linspace(50.0, 12.0, 20), -4.0, 0.3),
                 9: _receding_tail_light()})
    model = PCCVerifier(max_inward_offset=0.3).fit(X)
    back = load_model(save_model(model, tmp_path / "m.skops"))
    assert back.max_inward_offset == 0.3
    assert [r.payload["detections"].tolist() for r in back.predict(X)] == \
        [r.payload["detections"].tolist() for r in model.predict(X)]
    _check_step("m.skops", "motion", back)  # the detector's reader accepts it
    forged = PCCVerifier(max_inward_offset=0.3).fit(X)
    forged.max_inward_offset = -0.1
    with pytest.raises(UntrustedModelError, match="max_inward_offset"):
        _check_step("m.skops", "motion", forged)
    older = PCCVerifier().fit(X)  # a model saved before the parameter existed
    del older.max_inward_offset
    with pytest.raises(UntrustedModelError, match="missing attributes max_inward_offset"):
        _check_step("m.skops", "motion", older)


def on_a_curve(radius, wall, s_sign=90.0, frames=30, step=0.56, f=700.0, size=1.0,
               rise=0.3, width=0.45):
    """Boxes of a sign ``wall`` m left of the line of travel (negative: right) at
    ``s_sign`` m along a road curving left with ``radius`` m (negative: right), seen
    by a camera driving along it ``step`` m a frame, pointing along the road."""
    turn = np.arange(frames) * step / radius
    cam = np.column_stack([radius * np.sin(turn), radius * (1 - np.cos(turn))])
    ahead = np.column_stack([np.cos(turn), np.sin(turn)])
    left = np.column_stack([-np.sin(turn), np.cos(turn)])
    phi = s_sign / radius
    sign = np.array([(radius - wall) * np.sin(phi), radius - (radius - wall) * np.cos(phi)])
    z = ((sign - cam) * ahead).sum(axis=1)
    h = f * size / z
    x = W / 2 - f * ((sign - cam) * left).sum(axis=1) / z
    y = H / 2 + f * rise / z
    return np.column_stack([x - width * h / 2, y - h / 2, width * h, h])


@pytest.mark.parametrize("radius, wall", [(300.0, 5.0), (-300.0, -5.0), (250.0, 5.0)])
def test_a_far_sign_on_the_inside_of_a_sharp_curve_is_kept(radius, wall):
    """On a sharp curve the camera turns: the far stretch of a sign on the curve's
    inside drifts toward the frame's centre (8 to 10 px tall, 90 m ahead on a 300 m
    radius: inward offset 0.44) - but it grows, which a vehicle pulling away never
    does.  The default detector's motion check keeps it."""
    boxes = on_a_curve(radius, wall)
    x, y = centres(boxes)
    assert inward_offset(x, y, W, H) > 0.3  # heads inward from beyond the limit
    params = make_indicator_pipeline().named_steps["motion"].get_params()
    assert params["max_inward_offset"] == 0.3
    X = records({1: boxes})
    out = PCCVerifier(**params).fit(X).predict(X)
    assert all(r.payload["trajectory_positive"].all() for r in out)
    # the same path shrinking (its heights reversed about the same centres): refused
    shrinking = boxes.copy()
    shrinking[:, 2:] = boxes[::-1, 2:]
    shrinking[:, :2] = np.column_stack(centres(boxes)) - shrinking[:, 2:] / 2
    assert np.allclose(np.column_stack(centres(shrinking)), np.column_stack(centres(boxes)))
    X = records({1: shrinking})
    out = PCCVerifier(**params).fit(X).predict(X)
    assert not any(r.payload["trajectory_positive"].any() for r in out)
