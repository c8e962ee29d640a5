"""Keypoints on local contrast (section 3.1, a radiometry-free variant): the math.

The clusters' rectangles drawn from the contrast (:func:`contrast_region_boxes`,
:func:`core_boxes`) are in :mod:`tunnelsense.tunnel._contrast_boxes`.

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

import numpy as np

from tunnelsense.tunnel._contrast_boxes import (  # noqa: F401 (re-exported)
    _at_least,
    contrast_region_boxes,
    core_boxes,
)
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
