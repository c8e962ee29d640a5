"""Keypoint descriptors (section 3.2): histograms of the patches around keypoints.

The paper describes each keypoint by the normalized intensity histogram of the patch
around it; :func:`keypoint_descriptors` can append the histogram of a larger context
patch.  Patches are clipped to the frame by repeating edge pixels.
"""

from __future__ import annotations

import numbers

import numpy as np

from tunnelsense.tunnel._common import bin_lut

__all__ = ["keypoint_descriptors", "patch_histograms", "surround_histograms"]


def patch_histograms(
    image, rows, cols, *, patch_size=(7, 3), bins=32, intensity_range=None,
    binning="hard", lut=None,
) -> np.ndarray:
    """Normalized intensity histograms of the patches centred on keypoints.

    Parameters
    ----------
    image : ndarray of shape (height, width), uint8 or uint16
        The frame.
    rows, cols : ndarray of shape (n,)
        Keypoint positions.
    patch_size : int or (int, int), default=(7, 3)
        ``(height, width)`` of the patch (px), or the side of a square; patches are
        centred on the keypoint (an even side extends one pixel more before it) and
        clipped to the frame by repeating its edge pixels.
    bins : int, default=32
        Number of equal-width bins over ``intensity_range``.
    intensity_range : (int, int) or None, default=None
        Values ``[lo, hi)`` spanned by the bins (values outside go to the end bins);
        ``None`` is the full range of the dtype (``[0, 256)`` for 8 bits,
        ``[0, 65536)`` for 16 bits).
    binning : {"hard", "linear"}, default="hard"
        Count each pixel in its bin, or share it between the two nearest bin centres.
    lut : ndarray, tuple or None, default=None
        Precomputed value-to-bin tables (:func:`bin_lut`); saves their cost per call.

    Returns
    -------
    histograms : ndarray of shape (n, bins), float32
        Each row sums to 1.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.full((20, 20), 200, np.uint8)
    >>> img[:, :10] = 8
    >>> patch_histograms(img, np.array([10]), np.array([10]), patch_size=4, bins=4)
    array([[0.5, 0. , 0. , 0.5]], dtype=float32)
    """
    if lut is None:
        lut = bin_lut(image.dtype, bins, intensity_range, binning)
    values = _patches(image, rows, cols, *_patch_shape(patch_size))
    return _histograms(values, bins, lut)


def _patches(image, rows, cols, ph, pw):
    """Pixel values of the ``ph x pw`` patches on the keypoints, (n, ph, pw)."""
    rows = np.asarray(rows, dtype=np.intp)
    cols = np.asarray(cols, dtype=np.intp)
    h, w = image.shape
    ri = rows[:, None] + (np.arange(ph, dtype=np.intp) - ph // 2)
    ci = cols[:, None] + (np.arange(pw, dtype=np.intp) - pw // 2)
    # clipping repeats the edge pixels; np.clip costs more than this on small arrays
    np.maximum(ri, 0, out=ri)
    np.minimum(ri, h - 1, out=ri)
    np.maximum(ci, 0, out=ci)
    np.minimum(ci, w - 1, out=ci)
    flat = (ri * w)[:, :, None] + ci[:, None, :]
    return np.ravel(image).take(flat)


def _histograms(values, bins, lut):
    """Normalized histograms of patches of pixel values (n, ...) -> (n, bins)."""
    n = len(values)
    if n == 0:  # a frame with no keypoint in the band (dark stretch, tunnel exit)
        return np.zeros((0, bins), dtype=np.float32)
    values = values.reshape(n, -1)
    base = (np.arange(n, dtype=np.intp) * bins)[:, None]
    if isinstance(lut, tuple):
        lower, weight = lut
        q = (lower.take(values) + base).ravel()
        wu = weight.take(values).ravel()
        counts = np.bincount(q, weights=1.0 - wu, minlength=n * bins)
        counts += np.bincount(q + 1, weights=wu, minlength=n * bins + 1)[: n * bins]
    else:
        q = lut.take(values).astype(np.intp, copy=False)
        q += base
        counts = np.bincount(q.ravel(), minlength=n * bins)
    counts = counts.reshape(n, bins)
    return (counts * (1.0 / values.shape[1])).astype(np.float32)


def keypoint_descriptors(
    image, rows, cols, *, patch_size=(7, 3), context_size=(25, 13), context_weight=1.5,
    bins=32, intensity_range=None, binning="hard", lut=None,
) -> np.ndarray:
    """The verifier's keypoint descriptors: patch histogram, then context histogram.

    The normalized histogram of the small patch on each keypoint
    (:func:`patch_histograms` with ``patch_size``), followed, unless ``context_size``
    is None, by the histogram of a larger patch centred on the same keypoint (same
    bins) multiplied by ``context_weight``.  The context tells a bounded plate on a
    cooler wall (an indicator) from an extended warm surface whose small patches look
    the same (road warmed behind a vehicle, a vehicle's body).

    Parameters
    ----------
    image : ndarray of shape (height, width), uint8 or uint16
        The frame.
    rows, cols : ndarray of shape (n,)
        Keypoint positions.
    patch_size : int or (int, int), default=(7, 3)
        ``(height, width)`` of the small patch (px).
    context_size : int, (int, int) or None, default=(25, 13)
        ``(height, width)`` of the context patch (px); None for the small patch's
        histogram alone (the paper's descriptor).
    context_weight : float, default=1.5
        Factor of the context histogram (its rows sum to ``context_weight``).
    bins : int, default=32
        Bins of each histogram.
    intensity_range : (int, int) or None, default=None
        See :func:`patch_histograms`.
    binning : {"hard", "linear"}, default="hard"
        See :func:`patch_histograms`.
    lut : ndarray, tuple or None, default=None
        Precomputed value-to-bin tables (:func:`bin_lut`).

    Returns
    -------
    descriptors : ndarray of shape (n, bins) or (n, 2 * bins), float32

    Examples
    --------
    A keypoint on a 4-px plate in a wall, and one on an extended surface of the
    same intensity: the same patch histogram, different context histograms.

    >>> import numpy as np
    >>> img = np.full((40, 40), 60, np.uint8)
    >>> img[5:25, 8:12] = 176   # a plate
    >>> img[:, 25:] = 176       # an extended warm surface
    >>> d = keypoint_descriptors(img, np.array([15, 15]), np.array([10, 32]),
    ...                          patch_size=(7, 3), context_size=(9, 9),
    ...                          context_weight=1.0, bins=4)
    >>> d.round(2)
    array([[0.  , 0.  , 1.  , 0.  , 0.56, 0.  , 0.44, 0.  ],
           [0.  , 0.  , 1.  , 0.  , 0.  , 0.  , 1.  , 0.  ]], dtype=float32)
    """
    if lut is None:
        lut = bin_lut(np.asarray(image).dtype, bins, intensity_range, binning)
    return descriptors_under_luts(
        image, rows, cols, [lut], patch_size=patch_size, context_size=context_size,
        context_weight=context_weight, bins=bins)


def compose_lut(lut, values):
    """The bin table of pixel values mapped first by ``values`` (an integer table
    over every pixel value, such as a contrast change): ``lut`` read at
    ``values[v]`` for every ``v`` (a pair of tables for linear binning)."""
    if isinstance(lut, tuple):
        return tuple(t.take(values) for t in lut)
    return lut.take(values)


def descriptors_under_luts(image, rows, cols, luts, *, patch_size=(7, 3),
                           context_size=(25, 13), context_weight=1.5, bins=32):
    """:func:`keypoint_descriptors` of the same keypoints under several bin tables,
    stacked in the order of ``luts`` (the patches are gathered once).

    A pointwise change of grey levels (a contrast copy of the frame) composed into
    the bin table (:func:`compose_lut`) gives the descriptors of the changed frame
    without building it: ``descriptors_under_luts(img, r, c, [compose_lut(lut,
    t)])`` equals ``keypoint_descriptors(t[img], r, c, lut=lut)``.
    """
    ph, pw = _patch_shape(patch_size)
    if context_size is None:
        patch = _patches(image, rows, cols, ph, pw)
        return np.concatenate([_histograms(patch, bins, lut) for lut in luts])
    ch, cw = _patch_shape(context_size, "context_size")
    if not (np.isfinite(context_weight) and context_weight > 0):
        raise ValueError(f"context_weight must be positive; got {context_weight!r}")
    top, left = ch // 2 - ph // 2, cw // 2 - pw // 2
    context = _patches(image, rows, cols, ch, cw)
    if top >= 0 and left >= 0 and top + ph <= ch and left + pw <= cw:
        # the patch lies inside the context: one gather serves both
        patch = context[:, top : top + ph, left : left + pw]
    else:
        patch = _patches(image, rows, cols, ph, pw)
    n = len(context)
    out = np.empty((n * len(luts), 2 * bins), dtype=np.float32)
    for i, lut in enumerate(luts):
        part = out[i * n:(i + 1) * n]
        part[:, :bins] = _histograms(patch, bins, lut)
        part[:, bins:] = _histograms(context, bins, lut)
        part[:, bins:] *= np.float32(context_weight)
    return out


def surround_histograms(image, rows, cols, *, patch_size=(7, 3),
                        surround_size=(25, 13), bins=32, quantile=10.0):
    """Histograms of the patches on keypoints, each patch's values normalized by its
    own surround: invariant to the frame's gain and offset and to the sign's contrast.

    Every patch value ``v`` becomes ``(v - s) / (k - s)``, where ``k`` is the
    patch's median and ``s`` the ``quantile``-th percentile of the
    ``surround_size`` window on it (the cooler wall around a small bright plate);
    the histogram has ``bins`` equal bins centred on ``-0.5 + 2 i / bins`` (values
    outside go to the end bins).  A plate of uniform brightness gives one peak near 1 whatever its
    grey level or contrast; a textured surface spreads.

    Parameters
    ----------
    image : ndarray of shape (height, width)
    rows, cols : ndarray of shape (n,)
        Keypoint positions.
    patch_size : int or (int, int), default=(7, 3)
    surround_size : int or (int, int), default=(25, 13)
        ``(height, width)`` of the window giving the surround level (px).
    bins : int, default=32
    quantile : float, default=10
        Percentile of the window taken as the surround level.

    Returns
    -------
    histograms : ndarray of shape (n, bins), float32
        Each row sums to 1.

    Examples
    --------
    A plate at 176 on a wall at 60 and one at 100 on a wall at 80 (a fifth of the
    contrast): the same histogram.

    >>> import numpy as np
    >>> img = np.full((40, 40), 60, np.uint8)
    >>> img[5:25, 8:12] = 176
    >>> img[:, 20:] = 80
    >>> img[5:25, 28:32] = 104
    >>> h = surround_histograms(img, np.array([15, 15]), np.array([10, 30]), bins=4)
    >>> h
    array([[0., 0., 0., 1.],
           [0., 0., 0., 1.]], dtype=float32)
    """
    rows = np.asarray(rows, dtype=np.intp)
    cols = np.asarray(cols, dtype=np.intp)
    n = len(rows)
    if n == 0:
        return np.zeros((0, bins), dtype=np.float32)
    ph, pw = _patch_shape(patch_size)
    sh, sw = _patch_shape(surround_size, "surround_size")
    values = _patches(image, rows, cols, ph, pw).reshape(n, -1).astype(np.float32)
    window = _patches(image, rows, cols, sh, sw).reshape(n, -1)
    j = int(round(quantile / 100.0 * (window.shape[1] - 1)))
    s = np.partition(window, j, axis=1)[:, j].astype(np.float32)
    k = np.median(values, axis=1)
    z = (values - s[:, None]) / np.maximum(k - s, 1.0)[:, None]
    # bins of width 2 / bins centred on -0.5 + i * 2 / bins: 0 and 1 are centres
    idx = np.clip(np.floor((z + 0.5) * (bins / 2.0) + 0.5), 0, bins - 1).astype(np.intp)
    idx += (np.arange(n, dtype=np.intp) * bins)[:, None]
    counts = np.bincount(idx.ravel(), minlength=n * bins).reshape(n, bins)
    return (counts * (1.0 / values.shape[1])).astype(np.float32)


def _patch_shape(patch_size, name="patch_size"):
    if isinstance(patch_size, numbers.Integral):
        ph = pw = int(patch_size)
    else:
        ph, pw = (int(v) for v in patch_size)
    if ph < 1 or pw < 1:
        raise ValueError(f"{name} must be positive; got {patch_size!r}")
    return ph, pw
