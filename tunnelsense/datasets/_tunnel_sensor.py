"""Artefacts of a real FIR camera and its recorder, for the tunnel simulator.

Each is off by default and draws from a random stream of its own (a child of the
tour's seed), so turning one on leaves every other draw, and a default tour, as it
was:

* the **flat-field correction** (NUC) shutter: every few tens of seconds an
  uncooled camera closes a shutter in front of the sensor for a fraction of a second
  to recalibrate its pixels' offsets, and its output repeats the last picture
  before the shutter closed (repeated, identical frames);
* **dropped frames**: the recorder loses frames; the camera's frame counter runs on,
  so the frames it writes carry numbers with gaps (the time between two frames is
  their difference in numbers over the frame rate), or, with a recorder that numbers
  what it writes itself, consecutive numbers (the time of a lost frame is lost);
* **defective pixels**: pixels stuck at full scale (hot), at zero (dead) or at a
  level of their own, and whole dead columns (a failed column amplifier), at the
  same place in every frame;
* **vibration** (camera shake): the mount's pitch and yaw jitter from frame to
  frame (engine and road at 10-30 Hz, faster than a frame).

And, drawing nothing at random, the camera's **output stage**: a non-linear
response (a gamma curve on the grey levels), the bit depth of the frames
(14-bit counts in 16-bit words, as many FIR cameras record) and a mark burned
into the picture (a clock's text, a grey-scale bar: :func:`burn_overlay`).
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from tunnelsense._records import FrameRecord, FrameSequence

__all__ = ["OVERLAYS", "Recording", "burn_overlay", "camera_output", "defect_map",
           "dropped_frames", "nuc_freezes", "panel_layout", "shake"]

#: the marks a camera or recorder can burn into the picture (``overlay=``)
OVERLAYS = ("none", "clock", "bar")

#: spawn keys of the artefacts' random streams (children of the tour's seed)
_NUC_STREAM, _DROP_STREAM, _DEFECT_STREAM, _SHAKE_STREAM = 7301, 7302, 7303, 7304
_PANEL_STREAM = 7305


def _stream(seed, key):
    return np.random.default_rng([int(seed), key])


def nuc_freezes(seed, n_frames, fps, interval_s, freeze_s):
    """Which frame each output frame shows: ``source[f]`` is ``f``, or, while the
    shutter is closed, the last frame before it closed.

    The first correction comes at a time drawn uniformly in ``[0, interval)`` and
    each next one an interval later, the intervals drawn uniformly in
    ``interval_s`` and the freezes' durations in ``freeze_s`` (seconds; each at
    least one frame).

    Examples
    --------
    >>> src = nuc_freezes(0, 300, 30.0, (2.0, 3.0), (0.3, 0.5))
    >>> frozen = np.flatnonzero(src != np.arange(300))
    >>> bool(len(frozen) > 0), bool((src[frozen] < frozen).all())
    (True, True)
    """
    source = np.arange(n_frames)
    if interval_s is None:
        return source
    rng = _stream(seed, _NUC_STREAM)
    lo, hi = interval_s
    t = rng.uniform(0.0, rng.uniform(lo, hi))
    while True:
        start = int(math.ceil(t * fps))
        if start >= n_frames:
            break
        n = max(int(round(rng.uniform(*freeze_s) * fps)), 1)
        if start > 0:
            source[start : start + n] = start - 1
        t += rng.uniform(lo, hi)
    return source


def dropped_frames(seed, n_frames, fraction):
    """A mask of the frames the recorder keeps: each lost with probability
    ``fraction``, independently (the first frame is always kept).

    Examples
    --------
    >>> keep = dropped_frames(0, 1000, 0.05)
    >>> bool(keep[0]), 900 < int(keep.sum()) < 990
    (True, True)
    """
    keep = np.ones(n_frames, bool)
    if fraction <= 0:
        return keep
    keep[1:] = _stream(seed, _DROP_STREAM).random(n_frames - 1) >= fraction
    return keep


def defect_map(seed, shape, fraction, n_columns):
    """The sensor's defective pixels: ``(rows, cols, levels)`` of stuck pixels (a
    third hot at 255, a third dead at 0, a third stuck at a level drawn uniformly
    in 0-255) and the indices of dead columns (reading 0).

    Examples
    --------
    >>> rows, cols, levels, dead = defect_map(0, (48, 64), 0.01, 1)
    >>> len(rows), len(dead), bool(set(levels.tolist()) >= {0.0, 255.0})
    (31, 1, True)
    """
    H, W = shape
    rng = _stream(seed, _DEFECT_STREAM)
    k = int(round(fraction * H * W))
    flat = rng.choice(H * W, size=k, replace=False) if k else np.zeros(0, np.int64)
    kind = rng.integers(0, 3, size=k)
    levels = np.where(kind == 0, 255.0, np.where(kind == 1, 0.0,
                                                 np.floor(rng.uniform(0, 256, k))))
    dead = np.sort(rng.choice(W, size=int(n_columns), replace=False))
    return flat // W, flat % W, levels.astype(np.float32), dead


def shake(seed, pitch, yaw_deg, sigma_deg):
    """The camera's pitch and yaw per frame (radians): ``pitch`` (the body's) and
    the static ``yaw_deg`` (right positive), each plus an independent normal jitter
    of ``sigma_deg`` per frame (vibration).

    Examples
    --------
    >>> p, y = shake(0, np.zeros(500), 3.0, 0.3)
    >>> round(float(np.rad2deg(y).mean()), 1), round(float(np.rad2deg(p).std()), 1)
    (3.0, 0.3)
    """
    n = len(pitch)
    yaw = np.full(n, math.radians(yaw_deg))
    if sigma_deg > 0:
        jitter = np.deg2rad(_stream(seed, _SHAKE_STREAM).normal(0.0, sigma_deg, (2, n)))
        pitch = pitch + jitter[0]
        yaw = yaw + jitter[1]
    return pitch, yaw


def panel_layout(seed, s_end, spacing):
    """Where the lit panels stand (metres along the tunnel, the first within one
    ``spacing`` of the start, from a random stream of their own) and their looks
    ``(housing, lit face, pictograph)`` grey levels: lit from inside like the
    indicators' faces (170-180).

    Examples
    --------
    >>> s, looks = panel_layout(0, 100.0, 50.0)
    >>> len(s) == len(looks), bool(0 <= s[0] < 50), bool(np.allclose(np.diff(s), 50))
    (True, True, True)
    """
    if spacing is None:
        return np.zeros(0), []
    rng = _stream(seed, _PANEL_STREAM)
    first = rng.uniform(0.0, spacing)
    s = first + spacing * np.arange(int((s_end + 300.0 - first) // spacing) + 1)
    looks = [(rng.uniform(164, 170), rng.uniform(170, 180), rng.uniform(150, 160))
             for _ in range(len(s))]
    return s, looks


def camera_output(img, gamma, bit_depth):
    """The frame the camera writes from its linear grey levels ``img`` (float32,
    0-255 scale, modified in place): clipped, the response curve ``255 (I / 255) **
    gamma`` when ``gamma != 1``, scaled to ``2 ** bit_depth`` counts when
    ``bit_depth > 8`` (the 8-bit scale's 255 at ``255 * 2 ** (bit_depth - 8)``),
    rounded.

    Examples
    --------
    >>> img = np.array([[0.0, 63.75, 255.0, 300.0]], np.float32)
    >>> camera_output(img.copy(), 1.0, 8).tolist()
    [[0.0, 64.0, 255.0, 255.0]]
    >>> camera_output(img.copy(), 0.5, 8).tolist()
    [[0.0, 128.0, 255.0, 255.0]]
    >>> camera_output(img.copy(), 1.0, 14).tolist()
    [[0.0, 4080.0, 16320.0, 16320.0]]
    """
    np.clip(img, 0, 255, out=img)
    if gamma != 1.0:
        img /= np.float32(255.0)
        np.power(img, np.float32(gamma), out=img)
        img *= np.float32(255.0)
    if bit_depth > 8:
        img *= np.float32(2 ** (bit_depth - 8))
    np.rint(img, out=img)
    return img


def burn_overlay(img, kind, time_s, full_scale):
    """Burn the mark ``kind`` (:data:`OVERLAYS`) into the output frame ``img`` (in
    place), at ``time_s`` seconds into the tour; ``full_scale`` is the output's
    white.  ``"clock"``: the camera's name and a clock to the hundredth of a
    frame second, in white text at the top left (as recorders stamp the time);
    ``"bar"``: a grey-scale bar at the right edge, half the frame high, white at
    its top to black at its bottom (as thermal cameras show their colour scale).
    Sizes and places are fractions of the frame (drawn for 640 x 480), so every
    sensor size shows the same picture.  ``"none"`` changes nothing.

    Examples
    --------
    >>> img = np.zeros((480, 640), np.float32)
    >>> bar = burn_overlay(img, "bar", 0.0, 255.0)[120:360, 624:634]
    >>> float(bar[0, 0]), float(bar[-1, 0]), bar.shape
    (255.0, 0.0, (240, 10))
    """
    if kind == "none":
        return img
    h, w = img.shape[:2]
    if kind == "bar":
        top, rows = h // 4, h // 2
        ramp = np.rint(np.linspace(full_scale, 0.0, rows)).astype(img.dtype)
        img[top : top + rows, w - round(16 * w / 640) : w - round(6 * w / 640)] = \
            ramp[:, None]
    elif kind == "clock":
        centi = int(round(time_s * 100))
        text = (f"CAM1 12:{centi // 6000 % 60:02d}:{centi // 100 % 60:02d}."
                f"{centi % 100:02d}")
        mask = np.zeros((h, w), np.uint8)  # text is drawn on 8 bits only
        cv2.putText(mask, text, (round(10 * w / 640), round(25 * h / 480)),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.6 * h / 480, 255,
                    max(1, round(2 * h / 480)))
        img[mask > 0] = full_scale
    else:
        raise ValueError(f"overlay must be one of {list(OVERLAYS)}; got {kind!r}")
    return img


class Recording:
    """What reaches the recording of a tour of ``n_frames`` rendered frames: which
    rendered frame each output frame shows (the flat-field freezes) and which output
    frames the recorder keeps."""

    def __init__(self, seed, n_frames, fps, p):
        self.source = nuc_freezes(seed, n_frames, fps, p["nuc_interval_s"],
                                  p["nuc_freeze_s"])
        self.keep = dropped_frames(seed, n_frames, p["dropped_frames"])
        self.plain = bool((self.source == np.arange(n_frames)).all() and self.keep.all())
        kept = np.flatnonzero(self.keep)
        # the number each frame kept is written under: the camera's frame counter,
        # or the recorder's own count (the time of a lost frame is lost with it)
        self.numbers = (kept + 1 if p["frame_numbers"] == "counter"
                        else np.arange(1, len(kept) + 1))
        self.kept = kept

    def rows(self, per_frame):
        """The ground-truth rows of the frames kept, from the rows ``per_frame`` of
        each rendered frame (those of the picture shown, under its own number)."""
        return [(int(k), *row[1:])
                for f, k in zip(self.kept.tolist(), self.numbers, strict=True)
                for row in per_frame[self.source[f]]]

    def frames(self, name, images):
        """The frames kept, each under its own number (gaps where frames were lost)."""
        return FrameSequence(FrameRecord(name, int(k), images[self.source[f]])
                             for f, k in zip(self.kept.tolist(), self.numbers,
                                             strict=True))

    def info(self, p):
        """The artefacts' entries of the tour's ``info`` (none when off)."""
        out = {}
        if p["nuc_interval_s"] is not None:
            out["nuc_interval_s"] = "{:g},{:g}".format(*p["nuc_interval_s"])
            out["nuc_freeze_s"] = "{:g},{:g}".format(*p["nuc_freeze_s"])
            out["nuc_frozen_frames"] = int(
                (self.source != np.arange(len(self.source))).sum())
        if p["dropped_frames"] > 0:
            out["frames_dropped"] = int(len(self.keep) - self.keep.sum())
        if p["frame_numbers"] != "counter":
            out["frame_numbers"] = p["frame_numbers"]
        return out
