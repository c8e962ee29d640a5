"""Keypoint detection (section 3.1): a uniform grid and an intensity band.

Points are sampled on a uniform grid, every 6 px across and 7 px down (an emergency
telephone indicator is taller than it is wide), which cuts the number of candidates by
nearly two orders of magnitude; the grid points whose intensity lies in a band
``[low, high]`` are the keypoints.  The paper sets the band to [160, 190] by the
3-sigma rule on the intensities of indicator pixels, assumed Gaussian; this module
can also learn it that way from labelled frames.
"""

from __future__ import annotations

import numbers

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin, _fit_context
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.validation import check_is_fitted

from tunnelsense._payload import KEYPOINT_BAND, KEYPOINTS, check_image, where
from tunnelsense._records import FrameSequence, check_frames, decode_once
from tunnelsense.exceptions import InputFormatError

__all__ = ["IntensityKeypointSampler", "indicator_band", "sample_keypoints"]


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


def sample_keypoints(
    image, low=160, high=190, *, row_stride=7, col_stride=6, row_offset=0, col_offset=0
) -> np.ndarray:
    """Grid points of ``image`` whose intensity lies in ``[low, high]``.

    Parameters
    ----------
    image : ndarray of shape (height, width), uint8 or uint16
        The frame.
    low, high : float, default=160, 190
        The intensity band, inclusive, in the frame's own units.
    row_stride, col_stride : int, default=7, 6
        Grid spacing down and across (px).
    row_offset, col_offset : int, default=0
        Row and column of the first grid point.

    Returns
    -------
    keypoints : ndarray of shape (n, 3), int32
        ``(row, col, intensity)`` of every keypoint, in raster order.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.zeros((20, 20), np.uint8)
    >>> img[7, 12] = 170
    >>> sample_keypoints(img)
    array([[  7,  12, 170]], dtype=int32)
    """
    grid = image[row_offset::row_stride, col_offset::col_stride]
    # Compare in the image's dtype when the band is representable there (fast path).
    lo = np.ceil(low)
    hi = np.floor(high)
    info = np.iinfo(grid.dtype)
    if hi < lo or hi < info.min or lo > info.max:
        return np.empty((0, 3), dtype=np.int32)
    lo = grid.dtype.type(max(lo, info.min))
    hi = grid.dtype.type(min(hi, info.max))
    mask = (grid >= lo) & (grid <= hi)
    i, j = np.nonzero(mask)
    out = np.empty((len(i), 3), dtype=np.int32)
    out[:, 0] = i * row_stride + row_offset
    out[:, 1] = j * col_stride + col_offset
    out[:, 2] = grid[i, j]
    return out


def indicator_band(images, boxes, n_sigma=3.0, *, estimator="median"):
    """The intensity band ``centre +/- n_sigma * sd`` of the pixels inside indicator boxes.

    The paper's 3-sigma rule: indicator intensities are assumed Gaussian, and the band
    keeps all but about 0.3 % of them.  A box holds more than the sign's plate: its
    soft edges and a rim of the cooler wall.  ``estimator="median"`` (default)
    estimates the plate's Gaussian robustly, by the median and ``1.4826`` times the
    median absolute deviation, so that those pixels do not widen the band;
    ``"mean"`` uses the plain mean and standard deviation of all box pixels.  On
    simulated tours (boxes drawn around the signs) the median gave about
    [155, 191], the mean about [130, 209], against the paper's [160, 190].

    Parameters
    ----------
    images : iterable of ndarray of shape (height, width)
        The frames.
    boxes : iterable of ndarray of shape (k, 4)
        Per frame, the indicator boxes ``(left, top, width, height)``; a box covers the
        pixels ``left <= col < left + width``, ``top <= row < top + height``.
    n_sigma : float, default=3.0
        Half-width of the band in standard deviations.
    estimator : {"median", "mean"}, default="median"
        How the centre and the standard deviation are estimated (see above).

    Returns
    -------
    low, high : float
        The band, in the frames' units.  Raises ``ValueError`` when the boxes cover
        no pixel.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.full((10, 10), 100, np.uint8)
    >>> img[2:6, 2:4] = [[170], [180], [170], [180]]
    >>> indicator_band([img], [np.array([[2, 2, 2, 4.]])], estimator="mean")
    (160.0, 190.0)

    A plate of mean 175 and sd 5 in a box that also holds a column of the wall (100):

    >>> rng = np.random.default_rng(0)
    >>> img = np.full((20, 20), 100, np.uint8)
    >>> img[2:14, 2:8] = rng.normal(175, 5, (12, 6)).round()
    >>> box = [np.array([[2, 2, 7, 12.]])]
    >>> [round(v) for v in indicator_band([img], box, estimator="mean")]
    [84, 245]
    >>> [round(v) for v in indicator_band([img], box)]
    [157, 192]
    """
    if estimator not in ("median", "mean"):
        raise ValueError(f"estimator must be 'median' or 'mean'; got {estimator!r}")
    counts = None
    for i, (image, frame_boxes) in enumerate(zip(images, boxes, strict=True)):
        image = check_image(np.asarray(image), f"indicator_band: image {i}")
        h, w = image.shape
        for left, top, width, height in np.asarray(frame_boxes).reshape(-1, 4):
            c0 = max(int(np.ceil(left)), 0)
            r0 = max(int(np.ceil(top)), 0)
            c1 = min(int(np.ceil(left + width)), w)
            r1 = min(int(np.ceil(top + height)), h)
            if c1 <= c0 or r1 <= r0:
                continue
            c = np.bincount(
                image[r0:r1, c0:c1].ravel(), minlength=int(np.iinfo(image.dtype).max) + 1
            )
            if counts is None:
                counts = c
            else:  # 8- and 16-bit frames together: the longer histogram
                if len(c) > len(counts):
                    counts, c = c, counts
                counts[: len(c)] += c
    if counts is None or counts.sum() == 0:
        raise ValueError(
            "y holds no indicator box covering any pixel: cannot learn the intensity "
            "band. Every training set (and every cross-validation training fold) "
            "needs labelled indicators; or set band='fixed' with the camera's band "
            "(keypoints__band='fixed', keypoints__low, keypoints__high in "
            "make_indicator_pipeline)"
        )
    values = np.arange(len(counts), dtype=np.float64)
    n = counts.sum()
    if estimator == "mean":
        centre = float(counts @ values) / n
        sd = np.sqrt(max(float(counts @ (values - centre) ** 2) / n, 0.0))
    else:
        centre, mad = _grouped_median_mad(counts)
        sd = 1.4826 * mad
    return (round(float(centre - n_sigma * sd), 6), round(float(centre + n_sigma * sd), 6))


def _grouped_median_mad(counts):
    """Median and median absolute deviation of integer grey levels, each level ``v``
    spread uniformly over ``[v - 0.5, v + 0.5]`` (grouped data), so that neither is
    quantized to whole grey levels."""
    counts = counts.astype(np.float64)
    n = counts.sum()
    cum = np.cumsum(counts)
    k = int(np.searchsorted(cum, n / 2))  # the level holding the median
    below = cum[k] - counts[k]
    median = k - 0.5 + (n / 2 - below) / counts[k]
    if cum[k] == n / 2:  # exactly half at or below level k: mid-gap to the next level
        nxt = k + 1 + int(np.flatnonzero(counts[k + 1 :] > 0)[0])
        median = (k + 0.5 + nxt - 0.5) / 2
    lo_edges = np.arange(len(counts)) - 0.5

    def mass_within(d):  # share of the pixels within median +/- d
        overlap = np.clip(
            np.minimum(lo_edges + 1, median + d) - np.maximum(lo_edges, median - d), 0, 1
        )
        return float(counts @ overlap) / n

    lo, hi = 0.0, float(len(counts))
    for _ in range(60):  # bisection: mass_within is non-decreasing in d
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if mass_within(mid) < 0.5 else (lo, mid)
    return float(median), (lo + hi) / 2


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
        On simulated tours: about [155, 191] against [130, 209].
    row_stride : int, default=7
        Grid spacing down the frame (px).
    col_stride : int, default=6
        Grid spacing across the frame (px).
    row_offset : int, default=0
        Row of the first grid point.
    col_offset : int, default=0
        Column of the first grid point.

    Attributes
    ----------
    low_, high_ : float
        The band in use (``low``/``high``, or the learned one).
    n_frames_fit_ : int
        Number of frames seen by ``fit``.
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
    }

    _payload_reads = ()
    _payload_adds = (KEYPOINTS, KEYPOINT_BAND)

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

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.two_d_array = False
        tags.transformer_tags.preserves_dtype = []
        if self.band == "learned":
            tags.target_tags.required = True
        return tags

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y=None):
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
        records, boxes = check_frames(X, y)
        self.pixel_dtype_ = _pixel_dtype(records)
        if self.band == "learned":
            if boxes is None:
                raise ValueError(
                    "IntensityKeypointSampler(band='learned') requires y: per frame, "
                    "the (k, 4) indicator boxes to learn the band from"
                )
            images = [
                _check_depth(check_image(r.image, where(r, i)), i, r, self.pixel_dtype_)
                for i, r in enumerate(records) if len(boxes[i])
            ]
            self.low_, self.high_ = indicator_band(
                images, [b for b in boxes if len(b)], self.n_sigma,
                estimator=self.band_estimator,
            )
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
        return self.fit(records, y).transform(records)

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
        kw = dict(
            row_stride=self.row_stride,
            col_stride=self.col_stride,
            row_offset=self.row_offset,
            col_offset=self.col_offset,
        )
        band = (self.low_, self.high_)
        fitted = getattr(self, "pixel_dtype_", None)  # None: fitted before it existed
        out = []
        for i, r in enumerate(records):
            r = decode_once(r)  # the later stages of this pass read the same array
            image = check_image(r.image, where(r, i))
            if fitted is not None:
                _check_depth(image, i, r, fitted, band)
            out.append(
                r.evolve(**{
                    KEYPOINTS: sample_keypoints(image, self.low_, self.high_, **kw),
                    KEYPOINT_BAND: band,
                })
            )
        return FrameSequence(out)
