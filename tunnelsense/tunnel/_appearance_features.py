"""Features of keypoint clusters' rectangles for :class:`WeightedAdaBoost`.

The normalized intensity histogram of the image inside each (grown) rectangle, the
invariant features of :mod:`tunnelsense.tunnel._invariant` as the stumps read them,
and the rule that labels a cluster positive (its centre inside an indicator box).
"""

from __future__ import annotations

import numpy as np

from tunnelsense._payload import inside_boxes
from tunnelsense.tunnel._common import bin_lut
from tunnelsense.tunnel._invariant import _features, box_patches, n_invariant_features

__all__ = ["box_histograms", "centres_in_boxes", "clip_proportions", "match_centres"]


def centres_in_boxes(boxes, gt_boxes) -> np.ndarray:
    """Whether the centre of each box lies inside any of ``gt_boxes``.

    The centre of ``(left, top, width, height)`` is ``(left + width / 2, top +
    height / 2)``; it is inside ``(l, t, w, h)`` when ``l <= x < l + w`` and
    ``t <= y < t + h``.  This is the rule that labels a keypoint cluster positive for
    training and matches it to an indicator in :mod:`tunnelsense.metrics`: a cluster's
    rectangle spans only the keypoints of the grid, so it is smaller than the indicator
    it lies on and intersection-over-union would punish it for the grid's coarseness.

    Examples
    --------
    >>> import numpy as np
    >>> centres_in_boxes(np.array([[0, 0, 4, 4], [20, 0, 2, 2.]]), np.array([[0, 0, 10, 10.]]))
    array([ True, False])
    """
    return match_centres(boxes, gt_boxes) >= 0


def match_centres(boxes, gt_boxes) -> np.ndarray:
    """Index of the first of ``gt_boxes`` holding each box's centre, or -1."""
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    inside = inside_boxes(boxes[:, 0] + boxes[:, 2] / 2, boxes[:, 1] + boxes[:, 3] / 2,
                          gt_boxes)
    if inside.size == 0:
        return np.full(len(boxes), -1, dtype=np.intp)
    return np.where(inside.any(1), inside.argmax(1), -1)


def box_histograms(
    image, boxes, *, bins=32, intensity_range=None, margin=0.0, lut=None
) -> np.ndarray:
    """Normalized intensity histograms of the image inside rectangles.

    Parameters
    ----------
    image : ndarray of shape (height, width), uint8 or uint16
    boxes : ndarray of shape (m, 4)
        ``(left, top, width, height)`` in whole pixels (columns ``left`` to
        ``left + width - 1``), as :class:`MSTClusterer` gives them.
    bins : int, default=32
        Equal-width bins over ``intensity_range``.
    intensity_range : (int, int) or None, default=None
        Values ``[lo, hi)`` spanned by the bins (values outside go to the end bins);
        ``None``: the dtype's full range.
    margin : float, default=0.0
        Grow each rectangle by this fraction of its height on every side before
        taking the histogram (clipped to the image); see :class:`WeightedAdaBoost`.
    lut : ndarray or None, default=None
        Precomputed value-to-bin table.

    Returns
    -------
    histograms : ndarray of shape (m, bins), float64
        Each row sums to 1.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.zeros((10, 10), np.uint8)
    >>> img[2:4, 2:4] = 255
    >>> box_histograms(img, np.array([[2, 2, 2, 4.]]), bins=2)
    array([[0.5, 0.5]])
    """
    if lut is None:
        lut = bin_lut(image.dtype, bins, intensity_range)
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    if len(boxes) == 0:
        return np.empty((0, bins))
    return _patch_histograms(box_patches(image, boxes, margin), bins, lut)


def _patch_histograms(patches, bins, lut):
    """Normalized histograms of non-empty patches through ``lut``, one row each:
    every patch's pixels at once, one bincount of (patch, bin) pairs."""
    pixels = [p.ravel() for p in patches]
    ids = np.repeat(np.arange(len(pixels)), [p.size for p in pixels])
    counts = np.bincount(ids * bins + lut[np.concatenate(pixels)],
                         minlength=len(pixels) * bins).reshape(-1, bins)
    return counts / counts.sum(axis=1, keepdims=True)


#: Bins of the normalized histogram of ``features="invariant"``.
_INVARIANT_BINS = 16


#: Columns of the invariant features that describe the proportions of the bright
#: region and of the rectangle (log aspect ratios), which ``"invariant-any-shape"``
#: sets to 0 and ``widest_sign`` clips.
_SHAPE_COLUMNS = (_INVARIANT_BINS + 3, _INVARIANT_BINS + 4)


def clip_proportions(features, widest):
    """The log aspect ratios (height / width) of :data:`_SHAPE_COLUMNS` clipped from
    above at ``-log(widest)``, in place: every shape from upright to ``widest``
    times wider than high gets the same figure, a wider one keeps its own.

    Examples
    --------
    >>> import numpy as np
    >>> f = np.zeros((3, 22))
    >>> f[:, 19] = f[:, 20] = np.log([2.2, 1.0, 0.5])
    >>> clip_proportions(f, 1.25)[:, 20].round(3).tolist()
    [-0.223, -0.223, -0.693]
    """
    cols = list(_SHAPE_COLUMNS)
    features[:, cols] = np.minimum(features[:, cols], -np.log(widest))
    return features


def _invariant_rows(patches, hws, features="invariant", widest=None):
    """``_features(patches, hws, _INVARIANT_BINS)``; for ``"invariant-any-shape"``
    with the two aspect-ratio columns set to 0 (a stump cannot split on them);
    with ``widest`` (a float) those columns clipped (:func:`clip_proportions`)."""
    out = _features(patches, hws, _INVARIANT_BINS)
    if features == "invariant-any-shape":
        out[:, list(_SHAPE_COLUMNS)] = 0.0
    elif widest is not None:
        clip_proportions(out, widest)
    return out


def _chunked_features(patches, hws, chunk=128, features="invariant", widest=None):
    """:func:`_invariant_rows` in calls of ``chunk`` patches (its per-patch tables of
    256 grey levels stay in cache)."""
    out = np.empty((len(patches), n_invariant_features(_INVARIANT_BINS)))
    for start in range(0, len(patches), chunk):
        out[start:start + chunk] = _invariant_rows(patches[start:start + chunk],
                                                   hws[start:start + chunk], features,
                                                   widest)
    return out


def _interleaved(first, second, counts):
    """``first`` and ``second`` cut into consecutive pieces of ``counts`` ``(m, k)``
    rows each and joined piece by piece: ``first[:m0], second[:k0], first[m0:m0 +
    m1], ...``."""
    ends = np.cumsum(counts, axis=0) if len(counts) else np.zeros((0, 2), np.intp)
    starts = ends - np.asarray(counts, dtype=np.intp).reshape(-1, 2)
    return np.concatenate([
        piece
        for (a0, b0), (a1, b1) in zip(starts.tolist(), ends.tolist(), strict=True)
        for piece in (first[a0:a1], second[b0:b1])
    ] or [np.empty(0)])
