"""Appearance features of a keypoint cluster that a change of camera does not move.

A far-infrared camera's gain and offset move every intensity, its sensor noise
widens every intensity histogram and its focal length scales the sign; stumps on the
bins of a raw histogram learn one camera's values.  :func:`invariant_features`
describes the (grown) rectangle of a cluster after a median filter (which removes most
of the temporal noise and keeps the sign's edges) and after normalizing its
intensities by the patch's own low and high levels (which removes gain and offset):
the histogram of the normalized values, and shape and contrast figures of the bright
(in-band) region.  :func:`perturb_patch` renders what another camera would have seen
of a training patch (gain, offset, extra noise, blur, scale), for training-time
augmentation in :class:`~tunnelsense.tunnel.WeightedAdaBoost`.
"""

from __future__ import annotations

import functools

import numpy as np

__all__ = ["AUGMENT_RANGES", "box_patches", "invariant_features",
           "n_invariant_features", "perturb_patch"]

#: Ranges of the camera changes drawn by :func:`perturb_patch`: gain (factor),
#: offset (grey levels), extra noise sigma (grey levels, added in quadrature: 4 takes
#: a sigma-3 sensor to 5), noise correlation (Gaussian sigma in px), optical blur
#: (Gaussian sigma in px) and scale (focal length ratio).
AUGMENT_RANGES = {
    "gain": (0.8, 1.25),
    "offset": (-15.0, 15.0),
    "noise_sigma": (0.0, 4.5),
    "noise_corr_px": (0.0, 1.2),
    "blur_px": (0.0, 0.8),
    "scale": (0.75, 1.25),
}

_LOW_Q, _HIGH_Q = 10.0, 90.0
_EXTRA = 6


def n_invariant_features(bins) -> int:
    """Number of columns :func:`invariant_features` gives for ``bins`` bins."""
    return int(bins) + _EXTRA


def _crop_bounds(boxes, shape, margin):
    """Columns ``c0:c1`` and rows ``r0:r1`` of each box grown by ``margin`` times its
    height on every side, clipped to an image of ``shape`` (at least one pixel).

    Returns four (m,) int arrays ``c0, r0, c1, r1``.
    """
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    h, w = shape
    left, top, bw, bh = boxes.T
    pad = margin * bh
    # np.rint rounds half to even, as Python's round() does
    c0 = np.clip(np.rint(left - pad), 0, w - 1).astype(np.intp)
    r0 = np.clip(np.rint(top - pad), 0, h - 1).astype(np.intp)
    c1 = np.maximum(np.minimum(np.rint(left + bw + pad), w).astype(np.intp), c0 + 1)
    r1 = np.maximum(np.minimum(np.rint(top + bh + pad), h).astype(np.intp), r0 + 1)
    return c0, r0, c1, r1


def _crop(image, box, margin):
    c0, r0, c1, r1 = (int(v[0]) for v in _crop_bounds(box, image.shape, margin))
    return image[r0:r1, c0:c1], (c0, r0)


def _at_most(cdf, k):
    """Per row ``i`` and query ``k[..., i]``, how many entries of the non-decreasing
    row ``cdf[i]`` (integers >= 0) are ``<= k[..., i]`` (integers >= 0): as ``(cdf <=
    k[..., None]).sum(axis=-1)``, by one binary search in the rows laid end to end,
    each shifted above every entry and query of the row before it."""
    m, width = cdf.shape
    k = np.asarray(k, dtype=np.int64)
    step = max(int(cdf[:, -1].max()), int(k.max())) + 1
    shift = np.arange(m, dtype=np.int64) * step
    found = np.searchsorted((cdf + shift[:, None]).ravel(), k + shift, side="right")
    return found - np.arange(m) * width


def _percentiles(counts, n):
    """The 10th and 90th percentiles of ``n[i]`` 8-bit values from their counts.

    ``counts`` is (m, 256), one row of grey-level counts per patch.  Equal to
    ``np.percentile(values, [10, 90])`` of every row (linear interpolation between
    the neighbouring order statistics).
    """
    cdf = np.cumsum(counts, axis=1)
    # both percentiles at once: rows (q, patch)
    pos = np.array([_LOW_Q / 100.0, _HIGH_Q / 100.0])[:, None] * (n - 1)
    k = np.floor(pos)
    # order statistic k is the number of grey levels whose cumulative count is
    # <= k (np.searchsorted(cdf, k, side="right"), row by row)
    a, b = _at_most(cdf, np.stack([k, np.minimum(k + 1, n - 1)]))
    a, b = a.astype(np.float64), b.astype(np.float64)
    t = pos - k
    # numpy's lerp, term for term (exact equality with np.percentile)
    lo, hi = np.where(t >= 0.5, b - (b - a) * (1 - t), a + (b - a) * t)
    return lo, hi


@functools.lru_cache(maxsize=8)
def _edges(bins):
    return np.linspace(-0.5, 1.5, bins + 1)


def _level_histograms(zlut, counts, bins):
    """Per row, the histogram over [-0.5, 1.5] of the values ``zlut[i, g]`` taken
    ``counts[i, g]`` times: np.histogram's bins (its index arithmetic and edge
    corrections, term for term), in one weighted bincount for all rows."""
    m = len(zlut)
    edges = _edges(bins)
    a = np.clip(zlut, -0.5, 1.5)
    idx = ((a - -0.5) / 2.0 * bins).astype(np.intp)
    idx[idx == bins] -= 1
    idx[a < edges[idx]] -= 1
    idx[(a >= edges[idx + 1]) & (idx != bins - 1)] += 1
    rows = np.arange(m)[:, None] * bins
    hist = np.bincount((rows + idx).ravel(), weights=counts.ravel(), minlength=m * bins)
    return hist.astype(np.int64).reshape(m, bins)


def _order_statistic(counts, j):
    """Per row, the grey level of order statistic ``j[..., i]`` of values counted in
    ``counts`` (row ``i``)."""
    return _at_most(np.cumsum(counts, axis=1), j)


def _median_3x3(patches):
    """Every patch after OpenCV's 3 x 3 median filter, all in one call.

    A patch less than 3 px high or wide is left as it is; a patch of another dtype
    than uint8 is clipped to [0, 255] first.  The filter replicates a patch's edge
    beyond it; here every patch, with a one-pixel border that replicates its edge,
    is placed beside the others on one canvas (at least 128 px wide: OpenCV filters
    narrow images pixel by pixel, far more slowly), so the filter at any pixel of a
    patch sees exactly what it sees on the patch alone.

    Returns
    -------
    filtered : list of ndarray, uint8
        The filtered patches (views of one canvas).
    """
    import cv2  # noqa: PLC0415

    hs = [p.shape[0] for p in patches]
    ws = [p.shape[1] for p in patches]
    x = np.cumsum([0] + [w + 2 for w in ws]).tolist()
    canvas = np.zeros((max(hs) + 2, max(x[-1], 128)), np.uint8)
    for p, h, w, c in zip(patches, hs, ws, x[:-1], strict=True):
        if p.dtype != np.uint8:
            p = np.clip(p, 0, 255).astype(np.uint8)
        canvas[1:h + 1, c + 1:c + w + 1] = p
    # the border: left and right columns, then the top and bottom rows (corners too)
    left = np.array(x[:-1], dtype=np.intp)
    right = left + np.array(ws, dtype=np.intp) + 1
    canvas[:, left] = canvas[:, left + 1]
    canvas[:, right] = canvas[:, right - 1]
    canvas[0] = canvas[1]
    cols = np.arange(x[-1])
    bottom = np.repeat(np.array(hs, dtype=np.intp) + 1, np.array(ws, dtype=np.intp) + 2)
    canvas[bottom, cols] = canvas[bottom - 1, cols]
    filtered = cv2.medianBlur(canvas, 3)
    return [(filtered if min(h, w) >= 3 else canvas)[1:h + 1, c + 1:c + w + 1]
            for h, w, c in zip(hs, ws, x[:-1], strict=True)]


def _features(patches, box_hws, bins):
    """The invariant features of raw patches, one row each (see :func:`invariant_features`).

    The median filter runs on all patches at once (:func:`_median_3x3`); the
    histograms, percentiles, border medians, bright extents and spreads are
    computed for all patches at once from their concatenated pixels (the spread
    equals each patch's ``ndarray.std`` of its bright values to rounding).
    """
    m = len(patches)
    out = np.empty((m, n_invariant_features(bins)))
    if m == 0:
        return out
    filtered = _median_3x3(patches)
    rings = [np.concatenate([p[0], p[-1], p[:, 0], p[:, -1]]) for p in filtered]
    widths = np.array([p.shape[1] for p in filtered], dtype=np.intp)
    n = np.array([p.size for p in filtered], dtype=np.intp)
    starts = np.cumsum(n) - n
    # every pixel's (patch, grey level): its cell in the patches' tables of 256
    key = np.repeat(np.arange(m) * 256, n) + np.concatenate([p.ravel() for p in filtered])
    counts = np.bincount(key, minlength=m * 256).reshape(m, 256)
    lo, hi = _percentiles(counts, n)
    span = np.maximum(hi - lo, 1.0)
    zlut = (np.arange(256, dtype=np.float64) - lo[:, None]) / span[:, None]
    out[:, :bins] = _level_histograms(zlut, counts, bins) / np.maximum(n, 1)[:, None]

    # the bright pixels (z > 0.5), in the patches' order, and their z
    where = np.flatnonzero((zlut > 0.5).ravel()[key])
    bright_ids = np.repeat(np.arange(m), n)[where]
    z_bright = zlut.ravel()[key[where]]
    n_bright = np.bincount(bright_ids, minlength=m)
    out[:, bins] = n_bright / n  # fill
    # the median of the border's z: z grows with the grey level, so the border's
    # middle grey level(s) give it
    n_ring = np.array([r.size for r in rings], dtype=np.intp)
    ring = np.repeat(np.arange(m) * 256, n_ring) + np.concatenate(rings)
    ring_counts = np.bincount(ring, minlength=m * 256).reshape(m, 256)
    half = n_ring // 2
    upper, lower = zlut[np.arange(m), _order_statistic(
        ring_counts, np.stack([half, np.maximum(half - 1, 0)]))]
    out[:, bins + 2] = np.where(n_ring % 2 == 1, upper, (lower + upper) / 2)
    # extent of the bright region: rows of a patch's first and last bright pixel
    # (row-major order), least and greatest column over its bright pixels
    ends = np.cumsum(n_bright)
    has = n_bright > 0
    local = where - starts[bright_ids]
    width = widths[bright_ids]
    row, col = local // width, local % width
    r0 = r1 = c0 = c1 = np.zeros(m, np.intp)
    if has.any():
        first = (ends - n_bright)[has]
        r0, r1 = np.zeros(m, np.intp), np.zeros(m, np.intp)
        c0, c1 = np.zeros(m, np.intp), np.zeros(m, np.intp)
        r0[has], r1[has] = row[first], row[ends[has] - 1]
        c0[has] = np.minimum.reduceat(col, first)
        c1[has] = np.maximum.reduceat(col, first)
    # contrast of the bright region against its surroundings, relative to the level
    # of the surroundings: a gain does not change it, an offset little
    out[:, bins + 5] = span / np.maximum(lo, 1.0)
    # spread: the standard deviation of z over the bright pixels (two passes: the
    # mean, then the mean squared deviation from it)
    nb = np.maximum(n_bright, 1)
    mean = np.bincount(bright_ids, weights=z_bright, minlength=m) / nb
    dev = z_bright - mean[bright_ids]
    spread = np.sqrt(np.bincount(bright_ids, weights=dev * dev, minlength=m) / nb)
    out[:, bins + 1] = np.where(n_bright > 1, spread, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        aspect = np.log((r1 - r0 + 1) / (c1 - c0 + 1))
    out[:, bins + 3] = np.where(has, aspect, 0.0)
    hw = np.maximum(np.asarray(box_hws, dtype=np.float64).reshape(m, 2), 1.0)
    out[:, bins + 4] = np.log(hw[:, 0] / hw[:, 1])
    return out


def patch_features(patch, box_hw, bins=16) -> np.ndarray:
    """The invariant features of one patch (see :func:`invariant_features`)."""
    return _features([patch], [box_hw], bins)[0]


def invariant_features(image, boxes, *, bins=16, margin=0.25) -> np.ndarray:
    """Camera-invariant appearance features of the image inside rectangles.

    Each rectangle, grown on every side by ``margin`` times its height, is median
    filtered (3 x 3) and its values ``I`` normalized to ``z = (I - q10) / (q90 -
    q10)`` by the patch's own 10th and 90th percentiles (the dark rim of wall and the
    lit sign).  The features are the histogram of ``z`` over ``[-0.5, 1.5)`` in
    ``bins`` bins (summing to 1), then six figures: the fraction of pixels with ``z >
    0.5`` (fill), the spread of ``z`` over them, the median ``z`` of the patch's
    border, the log aspect ratio (height / width) of the bright region's extent and
    of the rectangle, and the contrast ``(q90 - q10) / q10``.  A gain, an offset and
    a moderate change of noise or focal length leave them nearly unchanged.

    Parameters
    ----------
    image : ndarray of shape (height, width), uint8
    boxes : ndarray of shape (m, 4)
        ``(left, top, width, height)``.
    bins : int, default=16
    margin : float, default=0.25

    Returns
    -------
    features : ndarray of shape (m, bins + 6), float64

    Examples
    --------
    >>> import numpy as np
    >>> img = np.full((40, 40), 100, np.uint8)
    >>> img[10:30, 15:24] = 175
    >>> a = invariant_features(img, np.array([[15, 10, 9, 20.]]))
    >>> b = invariant_features((1.2 * img).astype(np.uint8), np.array([[15, 10, 9, 20.]]))
    >>> a.shape, bool(np.allclose(a[:, :16], b[:, :16]))
    ((1, 22), True)
    """
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    return _features(box_patches(image, boxes, margin), boxes[:, [3, 2]].tolist(), bins)


def box_patches(image, boxes, margin):
    """The image inside each box grown by ``margin`` times its height (views,
    clipped to the image, at least one pixel; see :func:`_crop_bounds`).

    Examples
    --------
    >>> import numpy as np
    >>> [p.shape for p in box_patches(np.zeros((40, 40)), np.array([[15, 10, 9, 20.]]),
    ...                               0.25)]
    [(30, 19)]
    """
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    bounds = np.column_stack(_crop_bounds(boxes, image.shape, margin)).tolist()
    return [image[r0:r1, c0:c1] for c0, r0, c1, r1 in bounds]


def perturb_patch(patch, rng, box_hw, ranges=None):
    """A patch as another camera would have seen it, and the box's new size.

    Draws a gain, an offset, extra sensor noise (optionally spatially correlated),
    optical blur and a scale from ``ranges`` (default :data:`AUGMENT_RANGES`) and
    applies them to the 8-bit ``patch``.

    Parameters
    ----------
    patch : ndarray of shape (h, w), uint8
    rng : numpy.random.Generator
    box_hw : (float, float)
        Height and width of the cluster rectangle inside the patch.
    ranges : dict or None, default=None

    Returns
    -------
    patch : ndarray, uint8
    box_hw : (float, float)

    Examples
    --------
    >>> import numpy as np
    >>> p = np.full((20, 10), 170, np.uint8)
    >>> q, hw = perturb_patch(p, np.random.default_rng(0), (16.0, 7.0))
    >>> q.dtype, len(hw)
    (dtype('uint8'), 2)
    """
    import cv2  # noqa: PLC0415

    r = AUGMENT_RANGES if ranges is None else ranges
    u = lambda key: rng.uniform(*r[key])  # noqa: E731
    gain, offset, sigma, corr, blur, scale = (
        u("gain"), u("offset"), u("noise_sigma"), u("noise_corr_px"), u("blur_px"),
        u("scale"),
    )
    p = patch.astype(np.float32)
    h, w = p.shape
    nh, nw = max(int(round(h * scale)), 2), max(int(round(w * scale)), 2)
    if (nh, nw) != (h, w):
        p = cv2.resize(p, (nw, nh), interpolation=cv2.INTER_AREA if scale < 1
                       else cv2.INTER_LINEAR)
    if blur > 0.05:
        p = cv2.GaussianBlur(p, (0, 0), blur)
    p = gain * p + offset
    if sigma > 0:
        noise = rng.standard_normal(p.shape).astype(np.float32)
        if corr > 0.05:
            noise = cv2.GaussianBlur(noise, (0, 0), corr)
            noise /= max(float(noise.std()), 1e-6)
        p += sigma * noise
    out = np.clip(np.rint(p), 0, 255).astype(np.uint8)
    return out, (box_hw[0] * scale, box_hw[1] * scale)
