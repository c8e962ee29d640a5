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

import numbers

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
    FrameSequence,
    check_frames,
    decode_once,
)
from tunnelsense.tunnel._common import one_frame_shape
from tunnelsense.tunnel._intensity import (
    background_levels,
    cell_means,
    indicator_band,
    sample_keypoints,
)
from tunnelsense.tunnel._keypoints_canonical import (  # noqa: F401 (pickles)
    _canonical_pixels,
    canonical_frame,
    keypoint_frames,
    learn_contrast_band,
    learn_grey_band,
    reference_levels,
)
from tunnelsense.tunnel._keypoints_depth import (  # noqa: F401 (check_served_depth)
    _pixel_dtype,
    check_band_reaches_boxes,
    check_served_depth,
)
from tunnelsense.utils._sklearn_compat import Interval, StrOptions, _fit_context

__all__ = ["IntensityKeypointSampler", "indicator_band", "sample_keypoints"]


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
            self.ref_level_, self.ref_spread_, self.gain_tolerance_ = (
                reference_levels(levels, self.gain_tolerance))
        if self.radiometry == "contrast":
            learn_contrast_band(self, records, boxes, levels, _made)
        elif self.band == "learned":
            learn_grey_band(self, records, boxes)
        else:
            if self.low > self.high:
                raise ValueError(
                    f"low must not exceed high; got low={self.low}, high={self.high}"
                )
            self.low_, self.high_ = float(self.low), float(self.high)
            if self.radiometry == "raw" and boxes is not None:
                check_band_reaches_boxes(records, boxes, self.low_, self.high_,
                                         self.pixel_dtype_)
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
        return keypoint_frames(self, records, cells, made)

    def _canonical(self, image, index, record, *, small=None, levels=None, made=None):
        """:func:`~tunnelsense.tunnel._keypoints_canonical.canonical_frame` by this
        fit: the frame in the training frames' size and radiometry, the scale
        applied (or None) and the background cells (or None)."""
        return canonical_frame(self, image, index, record, small=small,
                               levels=levels, made=made)
