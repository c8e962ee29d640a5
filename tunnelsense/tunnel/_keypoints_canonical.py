"""The frames a fitted keypoint sampler hands to the later stages, and the bands
it learns on them: each frame resampled to the training frames' size and mapped
to their radiometry (an 8-bit picture for deeper frames), its keypoints sampled
in the band (the math is in :mod:`tunnelsense.tunnel._intensity` and
:mod:`tunnelsense.tunnel._contrast`)."""

from __future__ import annotations

import copy
from functools import partial

import numpy as np

from tunnelsense._payload import (
    FRAME_SCALE,
    KEYPOINT_BAND,
    KEYPOINTS,
    check_image,
    where,
)
from tunnelsense._records import DecodedImage, FrameRecord, FrameSequence, decode_once
from tunnelsense.exceptions import InputFormatError
from tunnelsense.tunnel._common import require_boxes
from tunnelsense.tunnel._contrast import (
    background_cells,
    contrast_band,
    sample_contrast_keypoints,
)
from tunnelsense.tunnel._intensity import (
    background_levels,
    beyond_tolerance,
    indicator_band,
    normalize_frame,
    resample_frame,
    sample_keypoints,
)
from tunnelsense.tunnel._keypoints_depth import _check_depth

__all__ = ["CANONICAL_LEVEL", "CANONICAL_SIGN", "canonical_frame", "learn_contrast_band",
           "keypoint_frames", "learn_grey_band", "reference_levels",
           "to_canonical_8bit"]

#: The 8-bit picture a 16-bit camera's frames are mapped to with
#: ``radiometry="contrast"``: the background level at grey level 100 and the
#: training signs' median local contrast 75 grey levels above it (the paper's
#: camera: lining about 100, signs in [160, 190]), so every later stage (histograms
#: over [0, 256), appearance patches) reads 8-bit grey levels whatever the depth
CANONICAL_LEVEL, CANONICAL_SIGN = 100.0, 175.0


def to_canonical_8bit(image, level, spread, ref_level, ref_spread):
    """A frame of any depth mapped affinely so that its background ``(level,
    spread)`` becomes ``(ref_level, ref_spread)``, rounded and clipped to 8 bits.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.array([[7000, 7400, 7800, 9800]], np.uint16)
    >>> to_canonical_8bit(img, 7400.0, 800.0, 100.0, 30.0)
    array([[ 85, 100, 115, 190]], dtype=uint8)
    """
    g = ref_spread / spread
    out = ref_level + (image.astype(np.float32) - np.float32(level)) * np.float32(g)
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


def canonical_frame(sampler, image, index, record, *, small=None, levels=None,
                    made=None):
    """The frame in the training frames' size and radiometry (those of the fitted
    :class:`~tunnelsense.tunnel.IntensityKeypointSampler` ``sampler``), the scale
    ``(sx, sy)`` applied (None when the size is kept) and, for
    ``radiometry="contrast"``, the mapped frame's background cells (else None).

    ``small`` (``cell_means(image)``) and ``levels`` (``background_levels(image)``),
    when given, are used for a frame of the training size instead of computing
    them again.  ``made`` (a dict, or None) carries a mapped frame from one call
    to a later one on the same frame (fit, then transform): the first stores
    the grey-level map's four numbers and its result, a later one whose map
    has the same four numbers takes that result instead of mapping again (the
    same pixels: the map is a function of them alone).
    """
    scale = None
    shape = getattr(sampler, "frame_shape_", None)
    if shape is not None and image.shape != tuple(shape):
        h, w = image.shape
        sy, sx = shape[0] / h, shape[1] / w
        if abs(sx / sy - 1.0) > 0.02:
            raise InputFormatError(
                f"{where(record, index)}: a {w}x{h} frame, but the detector was "
                f"fitted on {shape[1]}x{shape[0]} frames and serves other sizes of "
                "the same aspect ratio only (it resamples them to the training "
                "size); fit it on frames of this camera"
            )
        image = resample_frame(image, shape)
        scale = (float(sx), float(sy))
        small = levels = None  # they were those of the frame before resampling
    background = None
    if getattr(sampler, "ref_level_", None) is not None:
        if getattr(sampler, "contrast_low_", None) is not None:
            background, level, spread = background_cells(image, small=small)
        elif levels is not None:
            level, spread = levels
        else:
            level, spread = background_levels(image, small=small)
        raw_spread = getattr(sampler, "raw_spread_", None)
        tolerance = getattr(sampler, "gain_tolerance_", 0.0)
        if raw_spread is not None and image.dtype != np.uint8:
            # a deeper frame: the 8-bit picture (CANONICAL_LEVEL, CANONICAL_SIGN)
            spread = beyond_tolerance(spread, raw_spread, tolerance)
            image = to_canonical_8bit(image, level, spread, sampler.ref_level_,
                                      sampler.ref_spread_)
        else:
            spread = beyond_tolerance(spread, sampler.ref_spread_, tolerance)
            key = (level, spread, sampler.ref_level_, sampler.ref_spread_)
            if made and made.get("key") == key:
                image = made["image"]
            else:
                image = normalize_frame(image, level, spread, sampler.ref_level_,
                                        sampler.ref_spread_)
                if made is not None:
                    made.update(key=key, image=image)
        if background is not None:  # the same affine map as the frame's
            background = (sampler.ref_level_
                          + (background - level) * (sampler.ref_spread_ / spread))
    return image, scale, background


def reference_levels(levels, gain_tolerance):
    """The training frames' background level and spread (the medians of
    ``levels``, shape (n_frames, 2)) and the gain tolerance: ``gain_tolerance``,
    or for ``"learned"`` the median absolute log ratio of the frames' spreads to
    the reference one.

    Examples
    --------
    >>> import numpy as np
    >>> reference_levels(np.array([[100.0, 20.0], [102.0, 40.0], [98.0, 20.0]]),
    ...                  "learned")
    (100.0, 20.0, 0.0)
    """
    ref_level, ref_spread = (float(v) for v in np.median(levels, axis=0))
    # the spread of one camera's frames varies with the scene (lamps, vehicles,
    # lining; about 12 % from frame to frame): a gain within its typical variation
    # is left alone
    tolerance = (float(np.median(np.abs(np.log(levels[:, 1] / ref_spread))))
                 if gain_tolerance == "learned" else float(gain_tolerance))
    return ref_level, ref_spread, tolerance


def learn_contrast_band(sampler, records, boxes, levels, made):
    """Set the fitted attributes of ``radiometry="contrast"`` on ``sampler`` (in
    its ``fit``): the band of local contrast learned from the indicator boxes, in
    units of the background spread, and its grey levels ``low_, high_``; for
    frames deeper than 8 bits, the 8-bit picture's reference levels.  ``levels``:
    per frame, its background level and spread; ``made``: as ``fit``'s ``_made``."""
    if sampler.band != "learned":
        raise ValueError(
            "radiometry='contrast' learns its band of local contrast from the "
            "indicators: set band='learned' (and pass the boxes y)"
        )
    require_boxes(boxes, "IntensityKeypointSampler(radiometry='contrast')",
                  "to learn the contrast band from")
    # the frame's levels as computed above (the same call on the same image)
    images = [
        sampler._canonical(_check_depth(
            check_image(r.image, where(r, i)), i, r, sampler.pixel_dtype_), i, r,
            levels=tuple(float(v) for v in levels[i]),
            made=None if made is None else made.setdefault(i, {}))[0]
        for i, r in enumerate(records) if len(boxes[i])
    ]
    low, high = contrast_band(images, [b for b in boxes if len(b)],
                              sampler.n_sigma, unit=sampler.ref_spread_)
    if sampler.pixel_dtype_ != "uint8":
        # deeper frames: the later stages read an 8-bit picture whose
        # background level and sign contrast are set by the training
        # frames (the band, in units of the spread, is unchanged)
        sampler.raw_level_ = sampler.ref_level_
        sampler.raw_spread_ = sampler.ref_spread_
        sampler.ref_level_ = CANONICAL_LEVEL
        sampler.ref_spread_ = float((CANONICAL_SIGN - CANONICAL_LEVEL)
                                    / max(0.5 * (low + high), 1e-3))
    sampler.contrast_low_ = round(float(sampler.min_contrast * low), 6)
    sampler.contrast_high_ = round(float(sampler.max_contrast * high), 6)
    level, unit = sampler.ref_level_, sampler.ref_spread_
    sampler.low_ = round(level + sampler.contrast_low_ * unit, 6)
    sampler.high_ = round(level + sampler.contrast_high_ * unit, 6)


def learn_grey_band(sampler, records, boxes):
    """Set ``low_, high_`` on ``sampler`` (in its ``fit`` with ``band="learned"``
    and a grey-level radiometry): the 3-sigma band of the indicators' grey levels
    (:func:`~tunnelsense.tunnel._intensity.indicator_band`) on the canonical
    frames, its lower end moved toward the background by ``min_contrast``."""
    require_boxes(
        boxes, "IntensityKeypointSampler(band='learned')", "to learn the band from"
    )
    images = [
        sampler._canonical(_check_depth(
            check_image(r.image, where(r, i)), i, r, sampler.pixel_dtype_), i, r)[0]
        for i, r in enumerate(records) if len(boxes[i])
    ]
    low, high = indicator_band(
        images, [b for b in boxes if len(b)], sampler.n_sigma,
        estimator=sampler.band_estimator,
    )
    if sampler.min_contrast < 1.0:
        level = (sampler.ref_level_ if sampler.radiometry == "frame" else
                 float(np.median([background_levels(im)[0] for im in images])))
        low = round(level + sampler.min_contrast * (low - level), 6)
    sampler.low_, sampler.high_ = low, high


def _canonical_pixels(sampler, pixels):
    """The frame ``pixels`` as the fitted ``sampler`` hands it to the later stages
    (its canonical size and radiometry): what a pickled canonical frame remakes."""
    return sampler._canonical(pixels, 0, None)[0]


def keypoint_frames(sampler, records, cells=None, made=None):
    """The fitted ``sampler``'s ``transform`` of ``records``: each frame checked
    for its bit depth, made canonical (:func:`canonical_frame`), its keypoints
    sampled in the band, and evolved with them (a canonical frame replaces the
    frame's pixels for the later stages).  ``cells`` (or None), per frame,
    ``cell_means`` of its decoded image; ``made`` (or None), by frame index, the
    canonical frames the fit made (:func:`canonical_frame`'s ``made``)."""
    kw = dict(
        row_stride=sampler.row_stride,
        col_stride=sampler.col_stride,
        row_offset=sampler.row_offset,
        col_offset=sampler.col_offset,
    )
    band = (sampler.low_, sampler.high_)
    fitted = getattr(sampler, "pixel_dtype_", None)  # None: fitted before it existed
    out = []
    # the canonical frame from a frame's own pixels, by this fit (a snapshot:
    # a later fit of this sampler does not change it)
    remake = partial(_canonical_pixels, copy.copy(sampler))
    for i, r in enumerate(records):
        r = decode_once(r)  # the later stages of this pass read the same array
        image = check_image(r.image, where(r, i))
        if fitted is not None:
            _check_depth(image, i, r, fitted, band)
        raw = image
        image, scale, background = sampler._canonical(
            image, i, r, small=None if cells is None else cells[i],
            made=None if made is None else made.pop(i, None))
        if background is None:
            keypoints = sample_keypoints(image, sampler.low_, sampler.high_, **kw)
        else:
            unit = sampler.ref_spread_
            keypoints = sample_contrast_keypoints(
                image, background, sampler.contrast_low_ * unit,
                sampler.contrast_high_ * unit, **kw)
        extra = {
            KEYPOINTS: keypoints,
            KEYPOINT_BAND: band,
            FRAME_SCALE: (1.0, 1.0) if scale is None else scale,
        }
        if image is not raw:  # the later stages read the canonical frame
            # a frame from a file keeps its file as origin, so a stage that
            # releases the image can decode the frame (its own pixels) again;
            # pickled (to a worker process) or copied, it is made again from
            # them, not read as the file's pixels
            source = (DecodedImage(r.source.origin, image, remake)
                      if isinstance(r.source, DecodedImage) else image)
            r = FrameRecord(r.tour, r.frame, source, r.payload)
        out.append(r.evolve(**extra))
    return FrameSequence(out)
