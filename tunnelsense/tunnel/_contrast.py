"""Keypoints on local contrast (section 3.1, a radiometry-free variant): the math.

A lit sign is a small region brighter than the lining around it.  Its grey level
moves with the camera (gain, offset, an automatic gain control) and with the air (a
warmer lining lowers the sign's contrast), but its **local contrast** -- the frame
minus a background estimate -- relative to the frame's own spread of scene grey
levels changes only with the physical contrast:

* :func:`background_cells` averages the frame over a coarse grid of cells (which
  removes the sensor noise) and takes a robust local median of blocks of cells (a
  5 x 5 median: an object of fewer than 13 blocks -- a sign, a lamp -- does not
  move it);
  the frame's background level and spread are the median and the 10-90 % spread of
  the cells (as :func:`~tunnelsense.tunnel._intensity.background_levels` gives
  them);
* :func:`grid_contrast` is the frame minus that background at the points of the
  keypoint grid, in grey levels;
* :func:`contrast_band` learns the band of the indicators' local contrast, in units
  of the frame's spread, by the paper's 3-sigma rule (robustly).

An affine change ``g * I + o`` of the grey levels multiplies the local contrast and
the spread by ``g``: their ratio does not move.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from tunnelsense.tunnel._intensity import cell_means

__all__ = [
    "background_cells",
    "contrast_band",
    "contrast_region_boxes",
    "grid_contrast",
    "sample_contrast_keypoints",
]

#: rows and columns of the background grid for a 480 x 640 frame (8 x 8 px cells);
#: frames of other sizes keep the cell count, so a cell covers the same field of view
CELLS = (60, 80)


def background_cells(image, *, cells=CELLS, coarse=2, median_size=5, small=None):
    """The frame's background on a coarse grid of cells, and its level and spread.

    The frame is averaged over ``cells`` (which removes the sensor noise); the level
    and spread are the median and the 10-90 % spread of those averages (as
    :func:`~tunnelsense.tunnel._intensity.background_levels` gives them).  The
    background is those averages averaged again over ``coarse`` x ``coarse`` blocks
    and median-filtered over ``median_size`` x ``median_size`` blocks: an object
    covering fewer than half of the window (a sign or a lamp up to about 5 x 3
    blocks, 80 x 48 px of a 640 x 480 frame) does not move it.

    Parameters
    ----------
    image : ndarray of shape (height, width), uint8 or uint16
    cells : (int, int), default=(60, 80)
        Rows and columns of the averaging grid (at most the image's).
    coarse : int, default=2
        Cells per block of the background, down and across.
    median_size : int, default=5
        Side of the median over the blocks (3 or 5).
    small : ndarray or None, default=None
        The cell averages (:func:`~tunnelsense.tunnel._intensity.cell_means` of
        ``image`` and ``cells``) when already computed.

    Returns
    -------
    background : ndarray of shape (rows // coarse, cols // coarse), float32
        The median-filtered block averages.
    level, spread : float
        Median and 10-90 % spread of the cell averages.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.tile(np.linspace(80, 120, 640), (480, 1)).astype(np.uint8)
    >>> img[200:260, 320:347] = 200  # a near bright sign, 60 x 27 px
    >>> bg, level, spread = background_cells(img)
    >>> bg.shape, round(float(bg[14, 20]), 1), round(level, 1), round(spread, 1)
    ((30, 40), 102.0, 99.5, 32.1)
    """
    import cv2  # noqa: PLC0415

    if small is None:
        small = cell_means(image, cells)
    ch, cw = small.shape
    lo, mid, hi = _percentiles(small.ravel(), (10.0, 50.0, 90.0))
    bh, bw = max(ch // coarse, 1), max(cw // coarse, 1)
    blocks = cv2.resize(small, (bw, bh), interpolation=cv2.INTER_AREA)
    background = cv2.medianBlur(blocks, median_size)
    return background, float(mid), float(max(hi - lo, 1e-3))


def _percentiles(values, qs):
    """``np.percentile(values, qs)`` (linear interpolation) by one partition."""
    n = len(values)
    pos = np.asarray(qs, dtype=np.float64) / 100.0 * (n - 1)
    k = np.floor(pos).astype(np.intp)
    k1 = np.minimum(k + 1, n - 1)
    part = np.partition(values, np.unique(np.r_[k, k1]))
    a, b = part[k].astype(np.float64), part[k1].astype(np.float64)
    t = pos - k
    return np.where(t >= 0.5, b - (b - a) * (1 - t), a + (b - a) * t)


def grid_contrast(image, background, *, row_stride=7, col_stride=6, row_offset=0,
                  col_offset=0):
    """The local contrast ``I - background`` at the keypoint grid's points.

    Parameters
    ----------
    image : ndarray of shape (height, width)
    background : ndarray of shape (rows, cols)
        The background on a grid of cells covering the frame
        (:func:`background_cells`); each grid point reads its cell.
    row_stride, col_stride, row_offset, col_offset : int
        The keypoint grid (as :func:`~tunnelsense.tunnel._intensity.sample_keypoints`).

    Returns
    -------
    contrast : ndarray of shape (n_rows, n_cols), float32
        One value per grid point, in grey levels.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.full((14, 12), 100, np.uint8)
    >>> img[7, 6] = 160
    >>> grid_contrast(img, np.full((2, 2), 100.0))
    array([[ 0.,  0.],
           [ 0., 60.]], dtype=float32)
    """
    h, w = image.shape
    rows = np.arange(row_offset, h, row_stride)
    cols = np.arange(col_offset, w, col_stride)
    bh, bw = background.shape
    bg = background[(rows * bh // h)[:, None], (cols * bw // w)[None, :]]
    grid = image[row_offset::row_stride, col_offset::col_stride]
    return grid.astype(np.float32) - bg.astype(np.float32)


def sample_contrast_keypoints(image, background, low, high, *, row_stride=7,
                              col_stride=6, row_offset=0, col_offset=0):
    """Grid points whose local contrast ``I - background`` lies in ``[low, high]``.

    Parameters
    ----------
    image : ndarray of shape (height, width), uint8 or uint16
    background : ndarray of shape (rows, cols)
        The background on a grid of cells (:func:`background_cells`).
    low, high : float
        The contrast band, in grey levels, inclusive.
    row_stride, col_stride, row_offset, col_offset : int
        The grid.

    Returns
    -------
    keypoints : ndarray of shape (n, 3), int32
        ``(row, col, intensity)`` of every keypoint, in raster order.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.full((14, 12), 100, np.uint8)
    >>> img[7, 6] = 160
    >>> sample_contrast_keypoints(img, np.full((2, 2), 100.0), 30, 90)
    array([[  7,   6, 160]], dtype=int32)
    """
    kw = dict(row_stride=row_stride, col_stride=col_stride, row_offset=row_offset,
              col_offset=col_offset)
    contrast = grid_contrast(image, background, **kw)
    i, j = np.nonzero((contrast >= low) & (contrast <= high))
    out = np.empty((len(i), 3), dtype=np.int32)
    out[:, 0] = i * row_stride + row_offset
    out[:, 1] = j * col_stride + col_offset
    out[:, 2] = image[out[:, 0], out[:, 1]]
    return out


def contrast_band(images, boxes, n_sigma=3.0, *, unit=None):
    """The band of the indicators' local contrast in units of each frame's spread:
    median +/- ``n_sigma`` x 1.4826 MAD of ``(I - background) / spread`` over the
    pixels inside the boxes (the paper's 3-sigma rule, robustly).

    Parameters
    ----------
    images : iterable of ndarray of shape (height, width)
    boxes : iterable of ndarray of shape (k, 4)
        Per frame, the indicator boxes ``(left, top, width, height)``.
    n_sigma : float, default=3.0
    unit : float, default=None
        The unit of contrast: None, each frame's own spread; a number, that number
        for every frame (frames already mapped to one radiometry).

    Returns
    -------
    low, high : float
        In units of the frame's spread (or of ``unit``).  ``ValueError`` when the boxes cover no pixel.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> img = np.tile(np.linspace(80, 120, 640), (480, 1)) + rng.normal(0, 3, (480, 640))
    >>> img[240:256, 320:326] = rng.normal(170, 3, (16, 6))
    >>> img = img.round().astype(np.uint8)
    >>> box = [np.array([[320, 240, 6, 16.]])]
    >>> [round(v, 2) for v in contrast_band([img], box)]  # contrast 70, spread 32
    [1.89, 2.45]
    >>> gained = (0.7 * img.astype(float) - 20).round().astype(np.uint8)
    >>> [round(v, 2) for v in contrast_band([gained], box)]  # another unit: about the same
    [1.97, 2.37]
    """
    values = []
    for image, frame_boxes in zip(images, boxes, strict=True):
        image = np.asarray(image)
        background, _, spread = background_cells(image)
        h, w = image.shape
        bh, bw = background.shape
        for left, top, width, height in np.asarray(frame_boxes).reshape(-1, 4):
            c0 = max(int(np.ceil(left)), 0)
            r0 = max(int(np.ceil(top)), 0)
            c1 = min(int(np.ceil(left + width)), w)
            r1 = min(int(np.ceil(top + height)), h)
            if c1 <= c0 or r1 <= r0:
                continue
            rows, cols = np.arange(r0, r1), np.arange(c0, c1)
            bg = background[(rows * bh // h)[:, None], (cols * bw // w)[None, :]]
            scale = spread if unit is None else float(unit)
            values.append(((image[r0:r1, c0:c1] - bg) / scale).ravel())
    if not values or not sum(len(v) for v in values):
        raise ValueError(
            "y holds no indicator box covering any pixel: cannot learn the contrast "
            "band. Every training set (and every cross-validation training fold) "
            "needs labelled indicators"
        )
    v = np.concatenate(values)
    centre = float(np.median(v))
    sd = 1.4826 * float(np.median(np.abs(v - centre)))
    return round(centre - n_sigma * sd, 6), round(centre + n_sigma * sd, 6)


def contrast_region_boxes(image, rows, cols, labels, boxes, *, reach=(14, 12),
                          fraction=0.5):
    """Refine keypoint-cluster rectangles to the region brighter than half the
    cluster's own contrast above its surround.

    A grey-level band wide enough for signs of half the training contrast also
    holds the lining next to a sign of full contrast, so a region grown in that band
    swells with the band, and a cluster that also holds dim keypoints (a lining
    joint, a lamp's halo next to a sign) spans them.  Here each cluster sets its own
    threshold: inside the cluster's rectangle grown by ``reach`` px, the surround
    level ``s`` is the median of the pixels outside the keypoints' rectangle, the
    peak ``p`` the brightest grey level at the cluster's keypoints, and the region
    is the 8-connected component of the pixels at or above ``s + fraction * (p -
    s)`` that holds the brightest keypoint (for ``fraction=0.5``, the brightest
    object at half its contrast); dimmer keypoints and other objects of the cluster
    (a lamp beside a far sign) are left out of the box.  An affine change of the grey levels moves ``s``, ``p`` and every
    pixel alike: the region does not move.  A cluster not brighter than its
    surround keeps its keypoints' rectangle.

    Parameters
    ----------
    image : ndarray of shape (height, width), uint8 or uint16
    rows, cols : ndarray of shape (n,)
        Keypoint positions.
    labels : ndarray of shape (n,)
        Cluster of every keypoint (``0 .. m - 1``).
    boxes : ndarray of shape (m, 4)
        The clusters' keypoint rectangles ``(left, top, width, height)``.
    reach : (int, int), default=(14, 12)
        How far (rows, columns; px) the region may extend beyond the keypoints'
        rectangle.
    fraction : float, default=0.5
        The threshold between surround (0) and peak (1).

    Returns
    -------
    boxes : ndarray of shape (m, 4), float64
        ``(left, top, width, height)`` in whole pixels.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.full((40, 40), 100, np.uint8)
    >>> img[10:26, 17:23] = 175          # a 16 x 6 px sign
    >>> img[26:30, 17:23] = 125          # a lit rim below it, a third of its contrast
    >>> rows, cols = np.array([14, 21]), np.array([18, 18])
    >>> box = np.array([[18., 14., 1., 8.]])
    >>> contrast_region_boxes(img, rows, cols, np.array([0, 0]), box)
    array([[17., 10.,  6., 16.]])
    >>> gained = (0.7 * img - 20).astype(np.uint8)  # another gain and offset
    >>> contrast_region_boxes(gained, rows, cols, np.array([0, 0]), box)
    array([[17., 10.,  6., 16.]])
    """
    import cv2  # noqa: PLC0415

    from tunnelsense.tunnel._mst import cluster_windows  # noqa: PLC0415

    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    out = boxes.copy()
    for k, window, (r0, c0), kr, kc in cluster_windows(image, rows, cols, labels,
                                                        boxes, reach):
        left, top, bw, bh = boxes[k]
        ring = _rim(window, int(top) - r0, int(top + bh) - r0, int(left) - c0,
                    int(left + bw) - c0)
        if not ring.size:
            continue
        surround = _median(ring)
        values = window[kr, kc]
        b = int(np.argmax(values))
        peak = float(values[b])
        if peak <= surround:
            continue
        mask = _at_least(window, surround + fraction * (peak - surround))
        # the bounding box of the component holding the brightest keypoint
        _, comp, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        x, y, w, h = stats[comp[kr[b], kc[b]], :4].tolist()
        out[k] = (x + c0, y + r0, w, h)
    return out


def _rim(window, r0, r1, c0, c1):
    """The pixels of ``window`` outside its rows ``r0:r1`` and columns ``c0:c1``
    (bounds >= 0, slices as NumPy clips them), in no particular order: what
    ``window[mask]`` gives of a mask true outside that block, for a median.

    Examples
    --------
    >>> import numpy as np
    >>> sorted(_rim(np.arange(12).reshape(3, 4), 1, 2, 1, 3).tolist())
    [0, 1, 2, 3, 4, 7, 8, 9, 10, 11]
    """
    return np.concatenate((window[:r0].ravel(), window[r1:].ravel(),
                           window[r0:r1, :c0].ravel(), window[r0:r1, c1:].ravel()))


def _at_least(pixels, level):
    """The mask ``pixels >= level`` (a float), as uint8 for OpenCV.

    Integer pixels are compared with the least integer at or above ``level``: the
    same mask, without a floating-point copy of the pixels.

    Examples
    --------
    >>> import numpy as np
    >>> _at_least(np.array([[3, 4, 5]], np.uint8), 3.5)
    array([[0, 1, 1]], dtype=uint8)
    """
    if pixels.dtype.kind not in "ui":
        return (pixels >= level).view(np.uint8)
    low, high = _integer_range(pixels.dtype)
    least = math.ceil(level)
    if least > high:
        return np.zeros(pixels.shape, np.uint8)
    return (pixels >= pixels.dtype.type(max(least, low))).view(np.uint8)


@functools.lru_cache(maxsize=16)
def _integer_range(dtype):
    """The least and greatest values of an integer ``dtype`` (``np.iinfo``, once)."""
    info = np.iinfo(dtype)
    return int(info.min), int(info.max)


def _median(values):
    """``float(np.median(values))`` of a non-empty 1-D array of integers (grey
    levels), by one partition: the middle value, or the mean of the two middle
    ones (exact: the sum of two integers below 2**17 is exact in float64)."""
    n = len(values)
    half = n // 2
    if n % 2:
        return float(np.partition(values, half)[half])
    part = np.partition(values, (half - 1, half))
    return (float(part[half - 1]) + float(part[half])) / 2.0



def core_boxes(image, boxes, *, margin=0.25, fractions=(0.5, 0.7, 0.85)):
    """The bright cores of each rectangle at several fractions of its contrast.

    A lamp's halo is a smooth gradient of grey levels; a sign in it is a compact
    bright rectangle.  A cluster's rectangle grown around both spans the part of the
    halo above half the sign's contrast, and its appearance is then neither a sign's
    nor a lamp's.  Here the surround level ``s`` is the median of the rim of the
    rectangle grown by ``margin`` times its height on every side (the pixels outside
    the rectangle), the peak ``p`` the brightest pixel inside the rectangle, and the
    core at fraction ``f`` the bounding box of the 8-connected component of the
    pixels inside the rectangle at or above ``s + f * (p - s)`` that holds the
    peak: the higher the fraction, the less of the halo.  An affine change of the
    grey levels moves ``s``, ``p`` and every pixel alike: the cores do not move.

    Parameters
    ----------
    image : ndarray of shape (height, width), uint8 or uint16
    boxes : ndarray of shape (m, 4)
        ``(left, top, width, height)`` in whole pixels.
    margin : float, default=0.25
        The rim's width, a fraction of each rectangle's height.
    fractions : sequence of float, default=(0.5, 0.7, 0.85)
        The thresholds between surround (0) and peak (1).

    Returns
    -------
    cores : ndarray of shape (m, len(fractions), 4), float64
        ``(left, top, width, height)`` of every core, inside its rectangle; a
        rectangle without a rim or not brighter than its rim is its own core.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.full((40, 40), 60, np.uint8)
    >>> img[12:20, 8:18] = 130           # a halo above and beside the sign
    >>> img[20:30, 10:16] = 160          # a 10 x 6 px sign
    >>> box = np.array([[8., 12., 10., 18.]])
    >>> core_boxes(img, box, fractions=(0.5, 0.85))
    array([[[ 8., 12., 10., 18.],
            [10., 20.,  6., 10.]]])
    >>> gained = (0.7 * img - 20).astype(np.uint8)  # another gain and offset
    >>> core_boxes(gained, box, fractions=(0.5, 0.85))[0, 1]
    array([10., 20.,  6., 10.])
    """
    import cv2  # noqa: PLC0415

    from tunnelsense.tunnel._invariant import _crop_bounds  # noqa: PLC0415

    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    fractions = [float(f) for f in fractions]
    out = np.repeat(boxes[:, None, :], len(fractions), axis=1)
    if len(boxes) == 0:
        return out
    bounds = np.column_stack(_crop_bounds(boxes, image.shape, margin)).tolist()
    for k, (c0, r0, c1, r1) in enumerate(bounds):
        left, top, bw, bh = (int(v) for v in boxes[k])
        window = image[r0:r1, c0:c1]
        ir0, ir1 = max(top - r0, 0), min(top + bh - r0, window.shape[0])
        ic0, ic1 = max(left - c0, 0), min(left + bw - c0, window.shape[1])
        if ir1 <= ir0 or ic1 <= ic0:
            continue
        ring = _rim(window, ir0, ir1, ic0, ic1)
        if not ring.size:
            continue
        surround = _median(ring)
        inner = window[ir0:ir1, ic0:ic1]
        b = divmod(int(np.argmax(inner)), inner.shape[1])
        peak = float(inner[b])
        if peak <= surround:
            continue
        for j, f in enumerate(fractions):
            mask = _at_least(inner, surround + f * (peak - surround))
            _, comp, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
            x, y, w, h = stats[comp[b], :4].tolist()
            out[k, j] = (x + ic0 + c0, y + ir0 + r0, w, h)
    return out
