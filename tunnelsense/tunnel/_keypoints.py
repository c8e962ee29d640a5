"""Keypoint detection (section 3.1): a uniform grid and an intensity band.

Points are sampled on a uniform grid, every 6 px across and 7 px down (an emergency
telephone indicator is taller than it is wide), which cuts the number of candidates by
nearly two orders of magnitude; the grid points whose intensity lies in a band
``[low, high]`` are the keypoints.  The paper sets the band to [160, 190] by the
3-sigma rule on the intensities of indicator pixels, assumed Gaussian; this module
can also learn it that way from labelled frames (the math is in
:mod:`tunnelsense.tunnel._intensity`).
"""

from __future__ import annotations

import copy
import numbers
from functools import partial

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from tunnelsense._payload import (
    FRAME_SCALE,
    KEYPOINT_BAND,
    KEYPOINTS,
    check_image,
    where,
)
from tunnelsense._records import (
    DecodedImage,
    FrameRecord,
    FrameSequence,
    check_frames,
    decode_once,
)
from tunnelsense.exceptions import InputFormatError
from tunnelsense.tunnel._common import one_frame_shape, require_boxes
from tunnelsense.tunnel._contrast import (
    background_cells,
    contrast_band,
    sample_contrast_keypoints,
)
from tunnelsense.tunnel._intensity import (
    background_levels,
    beyond_tolerance,
    cell_means,
    indicator_band,
    normalize_frame,
    resample_frame,
    sample_keypoints,
)
from tunnelsense.utils._sklearn_compat import Interval, StrOptions, _fit_context

__all__ = ["IntensityKeypointSampler", "indicator_band", "sample_keypoints"]

#: The 8-bit picture a 16-bit camera's frames are mapped to with
#: ``radiometry="contrast"``: the background level at grey level 100 and the
#: training signs' median local contrast 75 grey levels above it (the paper's
#: camera: lining about 100, signs in [160, 190]), so every later stage (histograms
#: over [0, 256), appearance patches) reads 8-bit grey levels whatever the depth
CANONICAL_LEVEL, CANONICAL_SIGN = 100.0, 175.0


def _check_depth(image, index, record, expected, band=None):
    """Refuse a frame whose pixel type is not ``expected``, the units of the band.

    ``band`` is the fitted band (in ``transform``), or None (in ``fit``, where the
    other frames set ``expected``).
    """
    if image.dtype == expected:
        return image
    told = (
        f"the other frames are {expected}: fit on frames of one bit depth"
        if band is None
        else f"the sampler was fitted on {expected} frames: its intensity band "
        f"[{band[0]:g}, {band[1]:g}] is in {expected} grey levels"
    )
    raise InputFormatError(
        f"{where(record, index)}: a {image.dtype} frame, "
        f"but {told}. A 16-bit camera's raw counts are not 8-bit levels times 257 "
        "(the camera's gain decides); fit the detector on frames of this depth, or "
        "convert the frames to the fitted depth yourself"
    )


def check_served_depth(model, record, source):
    """Refuse, before any output is written, a source whose first frame has another
    pixel type than the frames ``model`` (a fitted indicator pipeline) was fitted
    on, naming the file and both types; a model without a fitted sampler of known
    depth passes (its own ``predict`` decides)."""
    step = getattr(model, "named_steps", {}).get("keypoints")
    fitted = getattr(step, "pixel_dtype_", None)
    image = record.image
    if fitted is None or str(image.dtype) == fitted:
        return
    origin = getattr(record.source, "origin", record.source)  # decoded: its file
    path = getattr(origin, "path", None) or str(source)
    raise InputFormatError(
        f"{path}: frame {record.frame} is {image.dtype}, but the detector was fitted "
        f"on {fitted} frames (its intensity band is in {fitted} grey levels). A "
        "16-bit camera's raw counts are not 8-bit levels times 257 (the camera's "
        "gain decides); fit the detector on frames of this depth, or convert the "
        "frames to the fitted depth yourself"
    )


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


def _pixel_dtype(records) -> str:
    """The pixel type of the frames (one decode at most when none is decoded)."""
    kinds = set()
    for r in records:
        source = r.source
        if isinstance(source, np.ndarray):
            kinds.add(str(source.dtype))
        elif hasattr(source, "array"):  # DecodedImage
            kinds.add(str(source.array.dtype))
    if not kinds and len(records):
        kinds.add(str(records[0].image.dtype))
    if len(kinds) > 1:
        raise InputFormatError(
            f"the frames mix pixel types ({', '.join(sorted(kinds))}); fit on frames "
            "of one bit depth: the intensity band is in grey levels of that depth"
        )
    return kinds.pop() if kinds else "uint8"


def _canonical_pixels(sampler, pixels):
    """The frame ``pixels`` as the fitted ``sampler`` hands it to the later stages
    (its canonical size and radiometry): what a pickled canonical frame remakes."""
    return sampler._canonical(pixels, 0, None)[0]


class IntensityKeypointSampler(TransformerMixin, BaseEstimator):
    """Keypoints of FIR frames: uniform grid points within an intensity band.

    Stage 1 of the FIR indicator detector (section 3.1 of the paper).  A frame stage:
    it takes a :class:`~tunnelsense.FrameSequence` (or any sequence of
    :class:`~tunnelsense.FrameRecord`, such as the plain list a CV fold gives) and
    returns a :class:`~tunnelsense.FrameSequence` of the same frames, in the same
    order, each evolved with

    * ``payload["keypoints"]``: ndarray of shape (n, 3), int32 -- the columns are
      ``(row, col, intensity)`` and the rows are in raster order (row by row, left to
      right);
    * ``payload["keypoint_band"]``: ``(low_, high_)``, the band in use (read by
      ``MSTClusterer(box="region")``).

    The image of each frame is read once per call.  The input is validated once per
    call, not per frame.

    Parameters
    ----------
    low : float, default=160
        Lower end of the intensity band (inclusive), in the frame's own units.
    high : float, default=190
        Upper end of the intensity band (inclusive), in the frame's own units.
    band : {"fixed", "learned"}, default="fixed"
        ``"fixed"`` uses ``[low, high]``.  ``"learned"`` sets the band in ``fit`` by
        the paper's 3-sigma rule: the centre plus or minus ``n_sigma`` standard
        deviations of the intensities of the pixels inside the indicator boxes ``y``
        (:func:`indicator_band`).
    n_sigma : float, default=3.0
        Half-width of a learned band, in standard deviations.
    band_estimator : {"median", "mean"}, default="median"
        How a learned band estimates the indicators' Gaussian: robustly (median and
        1.4826 x MAD), so that the soft edges and the rim of wall inside the boxes do
        not widen it, or by the plain mean and standard deviation of all box pixels.
    row_stride : int, default=7
        Grid spacing down the frame (px).
    col_stride : int, default=6
        Grid spacing across the frame (px).
    row_offset : int, default=0
        Row of the first grid point.
    col_offset : int, default=0
        Column of the first grid point.
    radiometry : {"raw", "frame", "contrast"}, default="raw"
        ``"raw"``: the paper's, grey levels as the camera gives them.  ``"frame"``:
        every frame's grey levels are first mapped affinely so that its background
        level and spread (:func:`~tunnelsense.tunnel._intensity.background_levels`:
        median and 10-90 % spread of the noise-free scene) equal those of the
        training frames; the band is learned and applied on such frames, and the
        later stages read them.  A unit's gain and offset, or an automatic gain
        control acting frame by frame, then change nothing but rounding.
        ``"contrast"``: frames mapped as with ``"frame"``, but the keypoints are the
        grid points whose **local contrast** (the frame minus its background: the
        frame averaged over a coarse grid of cells and median-filtered over 5 x 5
        cells, :func:`~tunnelsense.tunnel._contrast.background_cells`), in units of
        the frame's background spread, lies in a band learned from the indicators
        (``band="learned"`` is required).  A warmer lining lowers a sign's contrast
        without moving its grey level: ``min_contrast`` and ``max_contrast`` widen
        the learned contrast band, and a background that is warmer or cooler as a
        whole does not move the band.
        :func:`~tunnelsense.tunnel.make_indicator_pipeline` uses ``"contrast"``
        (``min_contrast=0.45``, ``max_contrast=1.5``).
    frame_size : {"native", "training"}, default="native"
        ``"training"``: a frame of another size than the training frames (the same
        aspect ratio within 2 %) is resampled to their size first, so that every
        length in pixels of every stage (grid, patches, MST cut, box limits, motion
        tolerances) keeps its meaning; the detections are mapped back to the frame's
        own pixels by :class:`PCCVerifier`.  A frame of another aspect ratio is
        refused.  ``"native"``: frames are used as they come.
    min_contrast : float, default=1.0
        A learned band's lower end moved toward the background level: ``low = level +
        min_contrast * (low_learned - level)``, so that signs seen with down to
        ``min_contrast`` times the training contrast above their background (warmer
        air, another emissivity) are still sampled.  1 keeps the learned band.  With
        ``radiometry="contrast"``: ``contrast_low_ = min_contrast * low_learned``.
    max_contrast : float, default=1.0
        With ``radiometry="contrast"``: the learned contrast band's upper end
        multiplied by this (at least 1), ``contrast_high_ = max_contrast *
        high_learned``, so that signs seen with more contrast than in training are
        still sampled.  Ignored by the other radiometries.
    gain_tolerance : "learned" or float, default="learned"
        With ``radiometry="frame"``: a frame's gain (its spread against the training
        frames') is corrected only by what exceeds this, in log units.
        ``"learned"``: the median of the training frames' own variation
        (``gain_tolerance_``); 0 corrects every frame fully.

    Attributes
    ----------
    low_, high_ : float
        The band in use (``low``/``high``, or the learned one).
    n_frames_fit_ : int
        Number of frames seen by ``fit``.
    ref_level_, ref_spread_ : float
        The training frames' background level and spread (``radiometry="frame"`` or
        ``"contrast"``).
    contrast_low_, contrast_high_ : float
        The band of local contrast in use, in units of ``ref_spread_``
        (``radiometry="contrast"``); ``low_, high_`` are then the grey levels
        ``ref_level_ + contrast * ref_spread_``, read by ``MSTClusterer(box="region")``.
    gain_tolerance_ : float
        How much (median absolute log ratio) the training frames' spreads vary about
        ``ref_spread_`` with the scene: a frame's gain is corrected only by what
        exceeds it, so the training camera's own frames are not rescaled by the
        scene's changes (``radiometry="frame"``).
    raw_level_, raw_spread_ : float
        With ``radiometry="contrast"`` on frames deeper than 8 bits: the training
        frames' background level and spread in the camera's raw counts;
        ``ref_level_, ref_spread_`` are then those of the 8-bit picture the frames
        are mapped to (``CANONICAL_LEVEL``, ``CANONICAL_SIGN``).
    frame_shape_ : (int, int)
        ``(height, width)`` of the training frames (``frame_size="training"``).
    pixel_dtype_ : str
        The pixel type of the frames ``fit`` saw (``"uint8"`` or ``"uint16"``): the
        units of the band.  A plain string, so it is saved with the model.

    Notes
    -----
    **16-bit frames.**  The band is compared with the raw pixel values, so it is in the
    frame's units: the default [160, 190] is meant for 8-bit frames (the paper's
    [0, 255] range).  For 16-bit frames either pass the band in raw counts (``low``,
    ``high``) or use ``band="learned"``, which learns it in whatever units the labelled
    frames have.  ``payload["keypoints"]`` then holds the raw 16-bit intensities.
    With ``radiometry="contrast"`` (the detector's default) the band is one of local
    contrast in units of the frame's own spread, whatever the depth, and a 16-bit
    frame is mapped to an 8-bit picture (background at grey level 100, the training
    signs' median contrast 75 grey levels above it: ``CANONICAL_LEVEL``,
    ``CANONICAL_SIGN``) that every later stage reads, so the verifier's histograms
    and the appearance patches are in 8-bit grey levels at any depth;
    ``payload["keypoints"]`` then holds the 8-bit values.

    **Frames of another bit depth are refused.**  ``transform`` raises
    :class:`~tunnelsense.exceptions.InputFormatError`, naming the frame, for a frame
    whose pixel type is not ``pixel_dtype_``, rather than find no keypoint (8-bit
    band on raw counts) or keypoints in the wrong places.  The frames are not
    converted: a FIR camera's 16-bit raw counts are not 8-bit grey levels times 257;
    the camera's gain and offset (its automatic gain control, for 8-bit video) decide
    the mapping, so no fixed rule is right for every camera.  Fit on frames of the
    depth the camera delivers, or convert them yourself.  ``fit`` likewise refuses
    frames of both depths.  A sampler fitted before ``pixel_dtype_`` existed (a model
    saved by an earlier version) has no such attribute and takes frames of any depth
    unchecked, as it did then.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import FrameSequence
    >>> from tunnelsense.tunnel import IntensityKeypointSampler
    >>> img = np.zeros((1, 30, 30), np.uint8)
    >>> img[0, 14:22, 12:16] = 175
    >>> out = IntensityKeypointSampler().fit_transform(FrameSequence.from_array(img))
    >>> out[0].payload["keypoints"]
    array([[ 14,  12, 175],
           [ 21,  12, 175]], dtype=int32)
    """

    _parameter_constraints: dict = {
        "low": [Interval(numbers.Real, None, None, closed="neither")],
        "high": [Interval(numbers.Real, None, None, closed="neither")],
        "band": [StrOptions({"fixed", "learned"})],
        "n_sigma": [Interval(numbers.Real, 0, None, closed="neither")],
        "band_estimator": [StrOptions({"median", "mean"})],
        "row_stride": [Interval(numbers.Integral, 1, None, closed="left")],
        "col_stride": [Interval(numbers.Integral, 1, None, closed="left")],
        "row_offset": [Interval(numbers.Integral, 0, None, closed="left")],
        "col_offset": [Interval(numbers.Integral, 0, None, closed="left")],
        "radiometry": [StrOptions({"raw", "frame", "contrast"})],
        "frame_size": [StrOptions({"native", "training"})],
        "min_contrast": [Interval(numbers.Real, 0, 1, closed="right")],
        "max_contrast": [Interval(numbers.Real, 1, None, closed="left")],
        "gain_tolerance": [StrOptions({"learned"}),
                           Interval(numbers.Real, 0, None, closed="left")],
    }

    _payload_reads = ()
    _payload_adds = (KEYPOINTS, KEYPOINT_BAND, FRAME_SCALE)

    def __init__(
        self,
        low=160,
        high=190,
        *,
        band="fixed",
        n_sigma=3.0,
        band_estimator="median",
        row_stride=7,
        col_stride=6,
        row_offset=0,
        col_offset=0,
        radiometry="raw",
        frame_size="native",
        min_contrast=1.0,
        max_contrast=1.0,
        gain_tolerance="learned",
    ):
        self.low = low
        self.high = high
        self.band = band
        self.n_sigma = n_sigma
        self.band_estimator = band_estimator
        self.row_stride = row_stride
        self.col_stride = col_stride
        self.row_offset = row_offset
        self.col_offset = col_offset
        self.radiometry = radiometry
        self.frame_size = frame_size
        self.min_contrast = min_contrast
        self.max_contrast = max_contrast
        self.gain_tolerance = gain_tolerance

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.two_d_array = False
        tags.transformer_tags.preserves_dtype = []
        if self.band == "learned" or self.radiometry == "contrast":
            tags.target_tags.required = True
        return tags

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y=None, _cells=None, _made=None):
        """Set the intensity band (fixed, or learned from labelled frames).

        Parameters
        ----------
        X : sequence of FrameRecord
            The frames.
        y : sequence of array-like of shape (k_i, 4), default=None
            Per frame, the indicator boxes ``(left, top, width, height)``; required
            when ``band="learned"``.

        Returns
        -------
        self : IntensityKeypointSampler
        """
        # _cells (private, from fit_transform): per frame, cell_means of its image;
        # _made (private, a dict from fit_transform) receives, by frame index, the
        # canonical frames the contrast band is learned on (see _canonical)
        records, boxes = check_frames(X, y)
        self.pixel_dtype_ = _pixel_dtype(records)
        for name in ("ref_level_", "ref_spread_", "gain_tolerance_", "frame_shape_",
                     "contrast_low_", "contrast_high_", "raw_level_", "raw_spread_"):
            if hasattr(self, name):
                delattr(self, name)
        if self.frame_size == "training":
            self.frame_shape_ = one_frame_shape(records)
        if self.radiometry != "raw":
            levels = np.array([
                background_levels(check_image(r.image, where(r, i)),
                                  small=None if _cells is None else _cells[i])
                for i, r in enumerate(records)
            ]).reshape(-1, 2)
            self.ref_level_, self.ref_spread_ = (
                float(v) for v in np.median(levels, axis=0)
            )
            # the spread of one camera's frames varies with the scene (lamps,
            # vehicles, lining; about 12 % from frame to frame): a gain within its
            # typical variation is left alone
            self.gain_tolerance_ = (
                float(np.median(np.abs(np.log(levels[:, 1] / self.ref_spread_))))
                if self.gain_tolerance == "learned" else float(self.gain_tolerance)
            )
        if self.radiometry == "contrast":
            if self.band != "learned":
                raise ValueError(
                    "radiometry='contrast' learns its band of local contrast from the "
                    "indicators: set band='learned' (and pass the boxes y)"
                )
            require_boxes(boxes, "IntensityKeypointSampler(radiometry='contrast')",
                          "to learn the contrast band from")
            # the frame's levels as computed above (the same call on the same image)
            images = [
                self._canonical(_check_depth(
                    check_image(r.image, where(r, i)), i, r, self.pixel_dtype_), i, r,
                    levels=tuple(float(v) for v in levels[i]),
                    made=None if _made is None else _made.setdefault(i, {}))[0]
                for i, r in enumerate(records) if len(boxes[i])
            ]
            low, high = contrast_band(images, [b for b in boxes if len(b)],
                                      self.n_sigma, unit=self.ref_spread_)
            if self.pixel_dtype_ != "uint8":
                # deeper frames: the later stages read an 8-bit picture whose
                # background level and sign contrast are set by the training
                # frames (the band, in units of the spread, is unchanged)
                self.raw_level_, self.raw_spread_ = self.ref_level_, self.ref_spread_
                self.ref_level_ = CANONICAL_LEVEL
                self.ref_spread_ = float((CANONICAL_SIGN - CANONICAL_LEVEL)
                                         / max(0.5 * (low + high), 1e-3))
            self.contrast_low_ = round(float(self.min_contrast * low), 6)
            self.contrast_high_ = round(float(self.max_contrast * high), 6)
            self.low_ = round(self.ref_level_ + self.contrast_low_ * self.ref_spread_, 6)
            self.high_ = round(self.ref_level_ + self.contrast_high_ * self.ref_spread_, 6)
        elif self.band == "learned":
            require_boxes(
                boxes, "IntensityKeypointSampler(band='learned')", "to learn the band from"
            )
            images = [
                self._canonical(_check_depth(
                    check_image(r.image, where(r, i)), i, r, self.pixel_dtype_), i, r)[0]
                for i, r in enumerate(records) if len(boxes[i])
            ]
            low, high = indicator_band(
                images, [b for b in boxes if len(b)], self.n_sigma,
                estimator=self.band_estimator,
            )
            if self.min_contrast < 1.0:
                level = (self.ref_level_ if self.radiometry == "frame" else
                         float(np.median([background_levels(im)[0] for im in images])))
                low = round(level + self.min_contrast * (low - level), 6)
            self.low_, self.high_ = low, high
        else:
            if self.low > self.high:
                raise ValueError(
                    f"low must not exceed high; got low={self.low}, high={self.high}"
                )
            self.low_, self.high_ = float(self.low), float(self.high)
        self.n_frames_fit_ = len(records)
        return self

    def fit_transform(self, X, y=None):
        """Fit, then detect the keypoints of every frame, decoding each frame once.

        Parameters
        ----------
        X : sequence of FrameRecord
            The frames.
        y : sequence of array-like of shape (k_i, 4), default=None
            Per frame, the indicator boxes (see :meth:`fit`).

        Returns
        -------
        X_new : FrameSequence
            As :meth:`transform` gives it.
        """
        records, _ = check_frames(X, y)
        records = FrameSequence([decode_once(r) for r in records])
        cells = None
        if self.radiometry != "raw":
            # every frame's cell averages once, for the fit's levels and the
            # transform's background (the same values as computing them twice)
            cells = [cell_means(check_image(r.image, where(r, i)))
                     for i, r in enumerate(records)]
        # the canonical frames the fit makes are reused by the transform where it
        # maps a frame by the same levels (see _canonical)
        made = {}
        return self.fit(records, y, _cells=cells, _made=made)._transform(
            records, cells, made)

    def transform(self, X):
        """Detect the keypoints of every frame.

        Parameters
        ----------
        X : sequence of FrameRecord
            The frames.

        Returns
        -------
        X_new : FrameSequence
            The same frames, each with ``payload["keypoints"]`` (see class docstring).
        """
        check_is_fitted(self)
        records, _ = check_frames(X)
        return self._transform(records)

    def _stream_frames(self, records):
        """:meth:`transform` for a stream state built after the fitted check: the
        records are checked, the estimator is not checked again a frame at a time."""
        return self._transform(check_frames(records)[0])

    def _transform(self, records, cells=None, made=None):
        """:meth:`transform`; ``cells`` (or None), per frame, ``cell_means`` of its
        decoded image; ``made`` (or None), by frame index, the canonical frames
        the fit made (``_canonical``'s ``made``)."""
        kw = dict(
            row_stride=self.row_stride,
            col_stride=self.col_stride,
            row_offset=self.row_offset,
            col_offset=self.col_offset,
        )
        band = (self.low_, self.high_)
        fitted = getattr(self, "pixel_dtype_", None)  # None: fitted before it existed
        out = []
        # the canonical frame from a frame's own pixels, by this fit (a snapshot:
        # a later fit of this sampler does not change it)
        remake = partial(_canonical_pixels, copy.copy(self))
        for i, r in enumerate(records):
            r = decode_once(r)  # the later stages of this pass read the same array
            image = check_image(r.image, where(r, i))
            if fitted is not None:
                _check_depth(image, i, r, fitted, band)
            raw = image
            image, scale, background = self._canonical(
                image, i, r, small=None if cells is None else cells[i],
                made=None if made is None else made.pop(i, None))
            if background is None:
                keypoints = sample_keypoints(image, self.low_, self.high_, **kw)
            else:
                unit = self.ref_spread_
                keypoints = sample_contrast_keypoints(
                    image, background, self.contrast_low_ * unit,
                    self.contrast_high_ * unit, **kw)
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

    def _canonical(self, image, index, record, *, small=None, levels=None, made=None):
        """The frame in the training frames' size and radiometry, the scale
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
        shape = getattr(self, "frame_shape_", None)
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
        if getattr(self, "ref_level_", None) is not None:
            if getattr(self, "contrast_low_", None) is not None:
                background, level, spread = background_cells(image, small=small)
            elif levels is not None:
                level, spread = levels
            else:
                level, spread = background_levels(image, small=small)
            raw_spread = getattr(self, "raw_spread_", None)
            tolerance = getattr(self, "gain_tolerance_", 0.0)
            if raw_spread is not None and image.dtype != np.uint8:
                # a deeper frame: the 8-bit picture (CANONICAL_LEVEL, CANONICAL_SIGN)
                spread = beyond_tolerance(spread, raw_spread, tolerance)
                image = to_canonical_8bit(image, level, spread, self.ref_level_,
                                          self.ref_spread_)
            else:
                spread = beyond_tolerance(spread, self.ref_spread_, tolerance)
                key = (level, spread, self.ref_level_, self.ref_spread_)
                if made and made.get("key") == key:
                    image = made["image"]
                else:
                    image = normalize_frame(image, level, spread, self.ref_level_,
                                            self.ref_spread_)
                    if made is not None:
                        made.update(key=key, image=image)
            if background is not None:  # the same affine map as the frame's
                background = (self.ref_level_
                              + (background - level) * (self.ref_spread_ / spread))
        return image, scale, background
