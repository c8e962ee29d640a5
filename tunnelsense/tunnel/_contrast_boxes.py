"""Keypoints on local contrast (section 3.1, a radiometry-free variant): the boxes.

The rectangles of the clusters of contrast keypoints, drawn from the frame's own grey
levels around each cluster (:mod:`tunnelsense.tunnel._contrast` holds the keypoints'
background, grid and band):

* :func:`contrast_region_boxes` refines a cluster's rectangle to the region brighter
  than half the cluster's own contrast above its surround;
* :func:`core_boxes` gives the bright cores of a rectangle at several fractions of
  its contrast (a sign inside a lamp's halo).
"""

from __future__ import annotations

import functools
import math

import numpy as np

__all__ = ["contrast_region_boxes", "core_boxes"]


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

    from tunnelsense.tunnel._mst_boxes import cluster_windows  # noqa: PLC0415

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
