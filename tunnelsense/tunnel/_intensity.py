"""Keypoint detection (section 3.1), the math: grid sampling and the intensity band.

:func:`sample_keypoints` keeps the grid points whose intensity lies in a band;
:func:`indicator_band` learns the band from labelled frames by the paper's 3-sigma
rule (robustly by default).
"""

from __future__ import annotations

import numpy as np

from tunnelsense._payload import check_image

__all__ = [
    "background_level",
    "background_levels",
    "beyond_tolerance",
    "cell_means",
    "indicator_band",
    "normalize_frame",
    "normalize_lut",
    "resample_frame",
    "sample_keypoints",
]


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
    ``"mean"`` uses the plain mean and standard deviation of all box pixels (see
    ``docs/tunnel-measurements.md`` for the bands each gave).

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


def cell_means(image, cells=(60, 80)):
    """The frame averaged over a ``cells`` grid (``cv2.INTER_AREA``), float32: what
    :func:`background_levels` and
    :func:`~tunnelsense.tunnel._contrast.background_cells` read (a caller that needs
    both computes it once and passes it as ``small``).

    An 8-bit frame cut into whole cells of a power-of-two area (8 x 8 px for 640 x
    480) is averaged from its integral image: every cell's sum is an exact integer,
    and so is its mean in float32 (a sum below 2**24 divided by a power of two), the
    value the area resampling gives; other frames are resampled.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.arange(48, dtype=np.uint8).reshape(6, 8)
    >>> cell_means(img, (3, 2))
    array([[ 5.5,  9.5],
           [21.5, 25.5],
           [37.5, 41.5]], dtype=float32)
    """
    import cv2  # noqa: PLC0415

    h, w = image.shape
    ch, cw = min(cells[0], h), min(cells[1], w)
    bh, bw = h // ch, w // cw
    area = bh * bw
    if (image.dtype == np.uint8 and bh * ch == h and bw * cw == w
            and area & (area - 1) == 0 and 255 * h * w < 2**31):
        corners = cv2.integral(image)[::bh, ::bw]  # int32, exact below 2**31
        sums = corners[1:, 1:] - corners[:-1, 1:] - corners[1:, :-1] + corners[:-1, :-1]
        return sums.astype(np.float32) / np.float32(area)
    return cv2.resize(image.astype(np.float32), (cw, ch), interpolation=cv2.INTER_AREA)


def background_levels(image, *, cells=(60, 80), quantiles=(10.0, 50.0, 90.0),
                      small=None):
    """A frame's robust background level and spread: the grey levels of the scene, not
    of its noise.

    The frame is averaged over a ``cells`` grid (``cv2.INTER_AREA``), which leaves the
    walls, road and arch and removes the sensor noise; the level is the median of the
    cells and the spread the distance between their 10th and 90th percentiles.  Small
    hot or bright objects (lamps, signs, exhausts) hold too few cells to move either.
    An affine change of grey levels ``g * I + o`` (a unit's gain and offset, an
    automatic gain control) changes them to ``g * level + o`` and ``g * spread``.

    Parameters
    ----------
    image : ndarray of shape (height, width), uint8 or uint16
    cells : (int, int), default=(60, 80)
        Rows and columns of the averaging grid (at most the image's).
    quantiles : (float, float, float), default=(10, 50, 90)
        Percentiles giving the low end, the level and the high end.
    small : ndarray or None, default=None
        ``cell_means(image, cells)`` when already computed.

    Returns
    -------
    level, spread : float

    Examples
    --------
    >>> import numpy as np
    >>> img = np.tile(np.linspace(80, 120, 64), (48, 1)).astype(np.uint8)
    >>> a = background_levels(img)
    >>> b = background_levels((1.25 * img + 10).astype(np.uint8))
    >>> [round(v, 1) for v in a], [round(v, 1) for v in b]
    ([99.5, 33.0], [134.0, 42.0])
    """
    if small is None:
        small = cell_means(image, cells)
    lo, mid, hi = np.percentile(small, quantiles)
    return float(mid), float(max(hi - lo, 1e-3))


def background_level(image, *, cells=(60, 80), quantile=50.0):
    """The level of :func:`background_levels` alone (its spread not computed), equal
    to it: the ``quantile`` percentile of the frame's ``cells`` means.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.tile(np.linspace(80, 120, 64), (48, 1)).astype(np.uint8)
    >>> background_level(img) == background_levels(img)[0]
    True
    """
    # a sequence of one quantile, as background_levels asks for its three: NumPy's
    # percentile of a lone number may differ from it in the last bit
    return float(np.percentile(cell_means(image, cells), (quantile,))[0])


def normalize_frame(image, level, spread, ref_level, ref_spread):
    """The frame's grey levels mapped affinely so that its background ``(level,
    spread)`` becomes ``(ref_level, ref_spread)``: ``I' = ref_level + (I - level) *
    ref_spread / spread``, rounded and clipped to the image's type.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.array([[90, 100, 110, 175]], np.uint8)
    >>> normalize_frame(img, 100.0, 20.0, 100.0, 10.0)
    array([[ 95, 100, 105, 138]], dtype=uint8)
    """
    import cv2  # noqa: PLC0415

    if image.dtype == np.uint8:
        return cv2.LUT(image, normalize_lut(image.dtype, level, spread, ref_level,
                                            ref_spread))
    g = ref_spread / spread
    info = np.iinfo(image.dtype)
    out = np.rint(ref_level + (image.astype(np.float64) - level) * g)
    return np.clip(out, info.min, info.max).astype(image.dtype)


def normalize_lut(dtype, level, spread, ref_level, ref_spread):
    """The table of :func:`normalize_frame`: every value of the integer ``dtype``
    mapped as :func:`normalize_frame` maps it (the same IEEE operations on each)."""
    info = np.iinfo(dtype)
    g = ref_spread / spread
    values = np.arange(int(info.max) + 1, dtype=np.float64)
    out = np.clip(np.rint(ref_level + (values - level) * g), info.min, info.max)
    return out.astype(dtype)


def resample_frame(image, shape):
    """The frame resampled to ``shape`` ``(height, width)``: linear interpolation when
    it grows, area averaging when it shrinks."""
    import cv2  # noqa: PLC0415

    h, w = image.shape
    if (h, w) == tuple(shape):
        return image
    grow = shape[0] * shape[1] > h * w
    return cv2.resize(image, (int(shape[1]), int(shape[0])),
                      interpolation=cv2.INTER_LINEAR if grow else cv2.INTER_AREA)


def beyond_tolerance(spread, ref_spread, tolerance):
    """The frame's spread as the gain correction sees it: the ratio to the training
    frames' spread shrunk toward 1 by ``tolerance`` (in log units), so a camera whose
    frames vary as the training camera's do is not rescaled frame by frame."""
    lg = np.log(spread / ref_spread)
    lg = np.sign(lg) * max(abs(lg) - tolerance, 0.0)
    return float(ref_spread * np.exp(lg))
