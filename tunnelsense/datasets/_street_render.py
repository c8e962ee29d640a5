"""Rendering the ranges: every beam of every scan ray-cast against the scene.

The beams are cast, a chunk of scans at a time, against the road (with camber), the
kerb face and the sidewalk, and against the boxes of the objects the scan plane cuts.
"""

from __future__ import annotations

import numpy as np

from tunnelsense.datasets._street_sensor import HIT_KERB, HIT_NONE, HIT_ROAD
from tunnelsense.datasets._street_shapes import BODY as _BODY
from tunnelsense.datasets._street_shapes import cross_sections

__all__ = ["ray_cast"]

_CHUNK = 256  # scans ray-cast at once


def _cast_ground(p, height, cos, sin):
    """Range to the road (with camber), the kerb face or the sidewalk; and which."""
    kerb, kh = p["kerb_depth"], p["kerb_height"] - p["cross_fall"] * p["kerb_depth"]
    H = height[:, None]
    tan = sin / cos
    down = tan < -1e-9
    # road: z = -q * y**2 - c * y (level at the vehicle, dropping camber_drop at the
    # kerb, plus a plane cross-fall c towards the kerb)
    q = p["camber_drop"] / kerb**2
    c = p["cross_fall"]
    slope = tan + c if c else tan
    disc = slope**2 - 4 * q * H
    with np.errstate(invalid="ignore", divide="ignore"):
        y_road = np.where(down & (disc >= 0),
                          2 * H / (-slope + np.sqrt(np.maximum(disc, 0))), np.inf)
        z_at_kerb = H + kerb * tan
        past = y_road > kerb
        y_walk = np.where(down, (H - kh) / -tan, np.inf)
    face = past & (z_at_kerb <= kh) & (z_at_kerb > -q * kerb**2 - c * kerb)
    y = np.where(~past, y_road, np.where(face, kerb, np.where(down, np.maximum(y_walk, kerb),
                                                               np.inf)))
    hit = np.where(~past, HIT_ROAD, HIT_KERB)
    hit = np.where(np.isfinite(y), hit, HIT_NONE)
    return y / cos, hit


def ray_cast(p, objects, stamps, x_ego, roll, height, angles, pitch=None):
    """True ranges, what each beam hit (object index or HIT_*), and the hit material.

    A pitched scan plane (``pitch`` rad per scan) leans along the street: a beam of
    elevation ``theta`` goes ``(cos theta, sin theta cos pitch)`` across and up per
    metre of range (and ``sin theta sin pitch`` along the street, a few centimetres
    at these angles, neglected), so its range is the ray parameter of that direction.
    """
    n_scans, n_beams = len(stamps), len(angles)
    theta = angles[None, :] + roll[:, None]
    cos, sin = np.cos(theta), np.sin(theta)
    if pitch is not None and np.any(pitch != 0):
        sin = sin * np.cos(pitch)[:, None]
    rng_true, hit = _cast_ground(p, height, cos, sin)
    material = np.full((n_scans, n_beams), _BODY, dtype=np.int8)
    scans, owners, boxes = cross_sections(objects, stamps, x_ego)
    if not len(scans):
        return rng_true, hit, material
    # slot of every box within its scan
    starts = np.searchsorted(scans, np.arange(n_scans))
    slot = np.arange(len(scans)) - starts[scans]
    K = int(slot.max()) + 1
    pad = np.full((n_scans, K, 4), np.inf)
    pad[scans, slot] = boxes[:, :4]
    own = np.full((n_scans, K), -1, dtype=np.int64)
    own[scans, slot] = owners
    mat = np.zeros((n_scans, K), dtype=np.int8)
    mat[scans, slot] = boxes[:, 4].astype(np.int8)
    inv_cos = 1.0 / cos
    safe_sin = np.where(np.abs(sin) < 1e-12, 1e-12, sin)
    inv_sin = 1.0 / safe_sin
    for a in range(0, n_scans, _CHUNK):
        b = min(a + _CHUNK, n_scans)
        # number of boxes actually used in this chunk
        k = int(np.isfinite(pad[a:b, :, 0]).sum(axis=1).max(initial=0))
        if k == 0:
            continue
        P = pad[a:b, :k]
        ic, isn = inv_cos[a:b, None, :], inv_sin[a:b, None, :]
        H = height[a:b, None, None]
        ty0 = P[:, :, 0, None] * ic
        ty1 = P[:, :, 1, None] * ic
        tz0 = (P[:, :, 2, None] - H) * isn
        tz1 = (P[:, :, 3, None] - H) * isn
        t_in = np.maximum(ty0, np.minimum(tz0, tz1))
        t_out = np.minimum(ty1, np.maximum(tz0, tz1))
        t = np.where((t_in <= t_out) & (t_out > 0), t_in, np.inf)
        best = np.argmin(t, axis=1)
        t_best = np.take_along_axis(t, best[:, None, :], axis=1)[:, 0]
        closer = t_best < rng_true[a:b]
        rows = np.arange(b - a)[:, None]
        rng_true[a:b] = np.where(closer, t_best, rng_true[a:b])
        hit[a:b] = np.where(closer, own[a:b][rows, best], hit[a:b])
        material[a:b] = np.where(closer, mat[a:b][rows, best], material[a:b])
    return rng_true, hit, material
