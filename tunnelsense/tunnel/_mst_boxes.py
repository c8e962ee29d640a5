"""Keypoint clusters' rectangles (section 3.3): from the keypoints, or refined on the image.

:func:`cluster_boxes` is the paper's smallest rectangle of a cluster's keypoints;
:func:`region_boxes` grows it to the in-band image region connected to them;
:func:`cluster_windows` is the per-cluster window loop that :func:`region_boxes` and
:func:`~tunnelsense.tunnel._contrast.contrast_region_boxes` share.  The partition itself
is in :mod:`tunnelsense.tunnel._mst`.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["cluster_boxes", "cluster_windows", "region_boxes"]


def cluster_boxes(rows, cols, labels, n_clusters=None) -> np.ndarray:
    """Smallest bounding rectangle of every cluster, as ``(left, top, width, height)``.

    Boxes span whole pixels: a cluster of keypoints in columns ``c0..c1`` and rows
    ``r0..r1`` gets ``(c0, r0, c1 - c0 + 1, r1 - r0 + 1)``, so a cluster of one keypoint
    is the 1 x 1 px box of that pixel.

    Examples
    --------
    >>> import numpy as np
    >>> cluster_boxes(np.array([7, 14, 70]), np.array([6, 12, 6]), np.array([0, 0, 1]))
    array([[ 6.,  7.,  7.,  8.],
           [ 6., 70.,  1.,  1.]])
    """
    rows = np.asarray(rows, dtype=np.float64)
    cols = np.asarray(cols, dtype=np.float64)
    labels = np.asarray(labels, dtype=np.intp)
    if n_clusters is None:
        n_clusters = int(labels.max()) + 1 if len(labels) else 0
    if n_clusters == 0:
        return np.empty((0, 4), dtype=np.float64)
    order = np.argsort(labels, kind="stable")
    starts = np.searchsorted(labels[order], np.arange(int(n_clusters)))
    r, c = rows[order], cols[order]
    top, left = np.minimum.reduceat(r, starts), np.minimum.reduceat(c, starts)
    bottom, right = np.maximum.reduceat(r, starts), np.maximum.reduceat(c, starts)
    return np.column_stack([left, top, right - left + 1, bottom - top + 1])


def region_boxes(image, rows, cols, labels, boxes, band, reach=(14, 12)) -> np.ndarray:
    """Refine keypoint-cluster rectangles to the in-band image region around them.

    A cluster's keypoints lie on the 7 x 6 px grid, so their bounding rectangle is
    quantized to the grid: it jumps by a grid step as the object grows or moves, and a
    cluster of one keypoint is a 1 x 1 px box.  The object itself is the region of
    pixels whose intensity lies in the keypoint band: this function takes, inside the
    cluster's rectangle grown by ``reach`` px (rows, columns), the 8-connected
    components of the pixels within ``band`` that hold a keypoint of the cluster, and
    returns their bounding rectangle.  Keypoints whose pixel is not in the band (after
    a band change) keep their own 1 x 1 px box in the union.

    Parameters
    ----------
    image : ndarray of shape (height, width), uint8 or uint16
    rows, cols : ndarray of shape (n,)
        Keypoint positions.
    labels : ndarray of shape (n,)
        Cluster of every keypoint (``0 .. m - 1``).
    boxes : ndarray of shape (m, 4)
        The clusters' keypoint rectangles (:func:`cluster_boxes`).
    band : (float, float)
        Inclusive intensity band ``[low, high]`` (the keypoint band).
    reach : (int, int), default=(14, 12)
        How far (rows, columns; px) the region may extend beyond the keypoints'
        rectangle: two grid steps.

    Returns
    -------
    boxes : ndarray of shape (m, 4), float64
        ``(left, top, width, height)`` in whole pixels; each contains the input box.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.full((40, 40), 100, np.uint8)
    >>> img[10:26, 17:23] = 175          # a 16 x 6 px sign
    >>> rows, cols = np.array([14, 21]), np.array([18, 18])
    >>> box = cluster_boxes(rows, cols, np.array([0, 0]))
    >>> box
    array([[18., 14.,  1.,  8.]])
    >>> region_boxes(img, rows, cols, np.array([0, 0]), box, (160, 190))
    array([[17., 10.,  6., 16.]])
    """
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    out = boxes.copy()
    lo, hi = float(band[0]), float(band[1])
    for k, window, (r0, c0), kr, kc in cluster_windows(image, rows, cols, labels,
                                                        boxes, reach):
        left, top, bw, bh = boxes[k]
        mask = ((window >= lo) & (window <= hi)).view(np.uint8)
        _, comp = cv2.connectedComponents(mask, connectivity=8)
        seeds = np.unique(comp[kr, kc])
        seeds = seeds[seeds > 0]
        if len(seeds) == 0:
            continue
        ys, xs = np.nonzero(np.isin(comp, seeds) if len(seeds) > 1 else comp == seeds[0])
        y0 = min(int(ys.min()) + r0, int(top))
        x0 = min(int(xs.min()) + c0, int(left))
        y1 = max(int(ys.max()) + r0 + 1, int(top + bh))
        x1 = max(int(xs.max()) + c0 + 1, int(left + bw))
        out[k] = (x0, y0, x1 - x0, y1 - y0)
    return out


def cluster_windows(image, rows, cols, labels, boxes, reach=(14, 12)):
    """Each cluster's window: its keypoints' rectangle grown by ``reach`` px, clipped
    to the image, with the cluster's keypoints in the window's coordinates.

    The loop that :func:`region_boxes` and
    :func:`~tunnelsense.tunnel._contrast.contrast_region_boxes` share.

    Parameters
    ----------
    image : ndarray of shape (height, width)
    rows, cols : ndarray of shape (n,)
        Keypoint positions.
    labels : ndarray of shape (n,)
        Cluster of every keypoint (``0 .. m - 1``).
    boxes : ndarray of shape (m, 4)
        The clusters' keypoint rectangles ``(left, top, width, height)``.
    reach : (int, int), default=(14, 12)
        Rows and columns (px) added on each side.

    Yields
    ------
    k : int
        The cluster.
    window : ndarray
        ``image[r0:r1, c0:c1]`` (a view).
    origin : (int, int)
        ``(r0, c0)``.
    rows, cols : ndarray
        The cluster's keypoints, relative to ``origin``.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.zeros((40, 40), np.uint8)
    >>> [(k, w.shape, o, r.tolist(), c.tolist()) for k, w, o, r, c in cluster_windows(
    ...     img, np.array([14, 21]), np.array([18, 18]), np.array([0, 0]),
    ...     np.array([[18., 14., 1., 8.]]))]
    [(0, (36, 25), (0, 6), [14, 21], [12, 12])]
    """
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    if len(boxes) == 0:
        return
    h, w = image.shape
    rr, rc = int(reach[0]), int(reach[1])
    rows = np.asarray(rows, dtype=np.intp)
    cols = np.asarray(cols, dtype=np.intp)
    labels = np.asarray(labels, dtype=np.intp)
    for k, (left, top, bw, bh) in enumerate(boxes.tolist()):
        r0 = max(int(top) - rr, 0)
        c0 = max(int(left) - rc, 0)
        r1 = min(int(top + bh) + rr, h)
        c1 = min(int(left + bw) + rc, w)
        member = labels == k
        yield k, image[r0:r1, c0:c1], (r0, c0), rows[member] - r0, cols[member] - c0
