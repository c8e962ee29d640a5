"""Lit panels (emergency-exit signs) on the signs' wall: drawn, in no ground truth."""

import cv2
import numpy as np
import pytest

from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.datasets._tunnel_render import PANEL_HEIGHT_M, PANEL_SIZE_M

QUIET = dict(first_indicator_m=40.0, lateral_jitter_m=0.0, pitch_jitter_deg=0.0,
             traffic_per_km=0.0, speed_kmh=80.0, noise_sigma=0.0, fpn_sigma=0.0,
             focal_length_px=700.0, mount_height_m=1.3)


def test_panels_are_lit_landscape_shapes_on_the_signs_wall_and_no_indicators():
    plain = make_tunnel_tour(60, random_state=5, **QUIET)
    lit = make_tunnel_tour(60, random_state=5, panel_spacing_m=20.0, **QUIET)
    assert lit.info["panel_spacing_m"] == 20.0 and "panel_spacing_m" not in plain.info
    # the same tunnel, signs and ground truth: the panels have a stream of their own
    assert lit.gt.equals(plain.gt)
    assert lit.info["first_indicator_m"] == plain.info["first_indicator_m"]
    H, W = plain.image_shape
    warm_w = warm_h = 0
    for a, b in zip(plain.frames, lit.frames, strict=True):
        diff = b.image.astype(float) - a.image.astype(float)
        changed = np.abs(diff) > 20
        if not changed.any():
            continue
        rows, cols = np.nonzero(changed)
        # on the left wall (the signs'), below the horizon: 2 m high, camera at 1.3 m
        assert cols.max() < W / 2 and rows.min() < H / 2
        assert 165 <= np.percentile(b.image[changed], 50) <= 182
        # the largest panel in view: wider than tall, as 0.8 m x 0.4 m
        _, _, stats, _ = cv2.connectedComponentsWithStats(changed.astype(np.uint8))
        x, y, w, h, _ = stats[1 + np.argmax(stats[1:, 4])]
        if w > warm_w:
            warm_w, warm_h = w, h
    assert warm_w > 10
    assert warm_w > 1.3 * warm_h
    assert PANEL_SIZE_M[0] > PANEL_SIZE_M[1] and PANEL_HEIGHT_M == 2.0


def test_panel_spacing_is_checked():
    with pytest.raises(ValueError, match="panel_spacing_m"):
        make_tunnel_tour(2, random_state=0, panel_spacing_m=1.0)
