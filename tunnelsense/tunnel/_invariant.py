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

import numpy as np

__all__ = ["AUGMENT_RANGES", "invariant_features", "n_invariant_features",
           "perturb_patch"]

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


def _crop(image, box, margin):
    left, top, bw, bh = box
    h, w = image.shape
    pad = margin * bh
    c0 = min(max(int(round(left - pad)), 0), w - 1)
    r0 = min(max(int(round(top - pad)), 0), h - 1)
    c1 = max(min(int(round(left + bw + pad)), w), c0 + 1)
    r1 = max(min(int(round(top + bh + pad)), h), r0 + 1)
    return image[r0:r1, c0:c1], (c0, r0)


def _percentiles(counts, n):
    """The 10th and 90th percentiles of ``n`` 8-bit values from their counts.

    Equal to ``np.percentile(values, [10, 90])`` (linear interpolation between
    the neighbouring order statistics).
    """
    cdf = np.cumsum(counts)
    out = []
    for q in (_LOW_Q, _HIGH_Q):
        pos = q / 100.0 * (n - 1)
        k = int(np.floor(pos))
        a = float(np.searchsorted(cdf, k, side="right"))
        b = float(np.searchsorted(cdf, min(k + 1, n - 1), side="right"))
        t = pos - k
        # numpy's lerp, term for term (exact equality with np.percentile)
        out.append(b - (b - a) * (1 - t) if t >= 0.5 else a + (b - a) * t)
    return out


def patch_features(patch, box_hw, bins=16) -> np.ndarray:
    """The invariant features of one patch (see :func:`invariant_features`)."""
    import cv2  # noqa: PLC0415

    p = np.ascontiguousarray(patch)
    if p.dtype != np.uint8:
        p = np.clip(p, 0, 255).astype(np.uint8)
    if min(p.shape) >= 3:
        p = cv2.medianBlur(p, 3)
    counts = np.bincount(p.ravel(), minlength=256)
    lo, hi = _percentiles(counts, p.size)
    span = max(hi - lo, 1.0)
    zlut = (np.arange(256, dtype=np.float64) - lo) / span
    z = zlut[p]
    # the histogram of z, one weighted entry per grey level: the same bins as
    # np.histogram over the pixels, at a fraction of the cost
    hist, _ = np.histogram(np.clip(zlut, -0.5, 1.5), bins=bins, range=(-0.5, 1.5),
                           weights=counts)
    hist = hist / max(z.size, 1)
    bright = z > 0.5
    fill = float(bright.mean())
    inner = z[bright]
    spread = float(inner.std()) if inner.size > 1 else 0.0
    ring = np.concatenate([z[0], z[-1], z[:, 0], z[:, -1]])
    ring_level = float(np.median(ring))
    rows = np.flatnonzero(bright.any(1))
    cols = np.flatnonzero(bright.any(0))
    if rows.size and cols.size:
        aspect_bright = np.log((rows[-1] - rows[0] + 1) / (cols[-1] - cols[0] + 1))
    else:
        aspect_bright = 0.0
    bh, bw = box_hw
    aspect = np.log(max(bh, 1.0) / max(bw, 1.0))
    # contrast of the bright region against its surroundings, relative to the level
    # of the surroundings: a gain does not change it, an offset little
    contrast = span / max(lo, 1.0)
    extra = [fill, spread, ring_level, aspect_bright, aspect, contrast]
    return np.concatenate([hist, extra])


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
    out = np.empty((len(boxes), n_invariant_features(bins)))
    for i, box in enumerate(boxes.tolist()):
        patch, _ = _crop(image, box, margin)
        out[i] = patch_features(patch, (box[3], box[2]), bins)
    return out


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
