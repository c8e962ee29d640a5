"""Keypoint verification (section 3.2): a mixture of patch-histogram centres.

The paper describes each keypoint by the normalized intensity histogram of the patch
around it; our default descriptor appends the histogram of a larger context patch
(:func:`keypoint_descriptors`).  Training clusters the descriptors of positive
keypoints (inside indicator boxes, k=40) and of negative ones (k=400) with k-means,
scores every positive centre by its mean Euclidean distance to the negative centres
(the paper's ``Eu``, eq. 3) and keeps the ``n_centers`` best (the paper's 10).  A
keypoint is verified when its descriptor lies within ``max_distance`` (the paper's
0.14 for its histograms) of its nearest kept centre.  Our defaults keep every
positive centre and add a nearest-centre test with both mixtures the paper's model
already holds: the descriptor must also be at most ``margin`` farther from its
nearest kept centre than from its nearest negative centre
(``context_size=None, n_centers=10, margin=None, max_distance=0.14`` is the paper's
rule).
"""

from __future__ import annotations

import numbers

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin, _fit_context
from sklearn.cluster import KMeans, MiniBatchKMeans
from sklearn.utils import check_random_state
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.validation import check_is_fitted, column_or_1d, validate_data
from threadpoolctl import threadpool_limits

from tunnelsense._records import FrameSequence, check_frames
from tunnelsense.tunnel._common import (
    bin_lut,
    frame_image,
    is_record_input,
    keypoints_of,
    points_in_boxes,
)

__all__ = [
    "KMeansHistogramVerifier",
    "fit_kmeans",
    "keypoint_descriptors",
    "patch_histograms",
    "rank_positive_centers",
    "verify_histograms",
]


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
    ph, pw = _patch_shape(patch_size)
    if context_size is None:
        return _histograms(_patches(image, rows, cols, ph, pw), bins, lut)
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
    out = np.empty((len(context), 2 * bins), dtype=np.float32)
    out[:, :bins] = _histograms(patch, bins, lut)
    out[:, bins:] = _histograms(context, bins, lut)
    out[:, bins:] *= np.float32(context_weight)
    return out


def _patch_shape(patch_size, name="patch_size"):
    if isinstance(patch_size, numbers.Integral):
        ph = pw = int(patch_size)
    else:
        ph, pw = (int(v) for v in patch_size)
    if ph < 1 or pw < 1:
        raise ValueError(f"{name} must be positive; got {patch_size!r}")
    return ph, pw


def fit_kmeans(
    X, n_clusters, *, batch_size=4096, n_steps=300, max_full_samples=20_000,
    random_state=None, sample_indices=None, n_jobs=None,
) -> np.ndarray:
    """k-means centres of ``X``, exact for small sets, mini-batch for large ones.

    * at most ``n_clusters`` distinct rows (looked for when ``n_samples`` is at most
      ``max(max_full_samples, 4 * n_clusters)``): the distinct rows are the centres.
    * ``n_samples <= max_full_samples``: :class:`~sklearn.cluster.KMeans` (Lloyd,
      k-means++, one init).
    * otherwise: :class:`~sklearn.cluster.MiniBatchKMeans` fed by ``partial_fit``
      with ``n_steps`` batches of ``batch_size`` rows drawn uniformly at random
      (``MiniBatchKMeans.fit`` draws each batch with a weighted choice over all rows,
      which is pathologically slow at millions of rows), the first batch (at least
      ``3 * n_clusters`` rows) seeding k-means++.  Memory beyond ``X`` stays at a
      few batches.

    k-means runs on ``n_jobs`` OpenMP threads, one by default: on a loaded machine
    scikit-learn's OpenMP threads spin-wait (a 512-row ``partial_fit`` took 165 ms
    with two threads beside other jobs, 1 ms with one).

    Parameters
    ----------
    X : ndarray of shape (n_rows, n_features)
        The rows (histograms).
    n_clusters : int
        k.
    batch_size, n_steps, max_full_samples : int
        See above.
    random_state : int, RandomState instance or None, default=None
        Seeds the initialisation and the batches.
    sample_indices : ndarray of int or None, default=None
        Cluster only these rows of ``X`` (``None``: all), without copying them out of
        a large ``X``: the result equals ``fit_kmeans(X[sample_indices], ...)``.
    n_jobs : int or None, default=None
        OpenMP threads (``None``: one); other numbers change the centres only by
        floating-point rounding.

    Returns
    -------
    centers : ndarray of shape (n_centers, n_features), float64
        ``n_centers = min(n_clusters, number of distinct rows)``.
    """
    with threadpool_limits(limits=int(n_jobs or 1), user_api="openmp"):
        return _fit_kmeans(X, n_clusters, batch_size, n_steps, max_full_samples,
                           check_random_state(random_state), sample_indices)


def _fit_kmeans(X, n_clusters, batch_size, n_steps, max_full_samples, rng,
                sample_indices=None):
    if sample_indices is not None:
        sample_indices = np.asarray(sample_indices, dtype=np.intp)
    n = len(X) if sample_indices is None else len(sample_indices)
    if n <= max(max_full_samples, 4 * n_clusters):
        if sample_indices is not None:  # a small set: copy it
            X, sample_indices = X[sample_indices], None
        distinct = np.unique(X, axis=0)
        if len(distinct) <= n_clusters:
            return distinct.astype(np.float64)
    if n <= max_full_samples:
        km = KMeans(n_clusters, n_init=1, random_state=rng.randint(2**31 - 1))
        return km.fit(X).cluster_centers_.astype(np.float64)
    batch = max(int(batch_size), 3 * n_clusters)
    km = MiniBatchKMeans(
        n_clusters,
        batch_size=batch,
        random_state=rng.randint(2**31 - 1),
        n_init=1,
        reassignment_ratio=0.01,
    )
    first = max(batch, 3 * n_clusters)

    def take(idx):
        return X[idx] if sample_indices is None else X[sample_indices[idx]]

    km.partial_fit(take(np.sort(rng.choice(n, min(first, n), replace=False))))
    for _ in range(int(n_steps) - 1):
        km.partial_fit(take(np.sort(rng.randint(0, n, batch))))
    return km.cluster_centers_.astype(np.float64)


def rank_positive_centers(positive_centers, negative_centers):
    """The paper's ``Eu`` (eq. 3): mean distance of each positive centre to the negative ones."""
    p = np.asarray(positive_centers, dtype=np.float64)
    q = np.asarray(negative_centers, dtype=np.float64)
    d2 = (p * p).sum(1)[:, None] - 2 * p @ q.T + (q * q).sum(1)[None, :]
    return np.sqrt(np.maximum(d2, 0)).mean(axis=1)


def _nearest_distance(H, centers, centers_sq):
    """Distance from each histogram row to its nearest centre, shape (n,)."""
    H = np.asarray(H, dtype=np.float64)
    if not len(centers):
        return np.full(len(H), np.inf)
    d2 = (H * H).sum(1)[:, None] - 2 * H @ centers.T + centers_sq[None, :]
    return np.sqrt(np.maximum(d2.min(axis=1), 0))


def verify_histograms(H, centers, negative_centers, *, max_distance, margin=None):
    """The verification rule: which histograms are verified, shape (n,) bool.

    A histogram ``h`` is verified when ``d_pos(h) <= max_distance`` (the paper's
    rule: ``d_pos`` is the distance to the nearest kept positive centre) and, unless
    ``margin`` is None, ``d_pos(h) <= d_neg(h) + margin`` (``d_neg``: the distance to
    the nearest negative centre).

    Examples
    --------
    >>> import numpy as np
    >>> P, N = np.array([[1.0, 0, 0]]), np.array([[0.0, 1, 0], [0.5, 0.5, 0]])
    >>> H = np.array([[0.9, 0.1, 0], [0.6, 0.4, 0]])
    >>> verify_histograms(H, P, N, max_distance=0.6).tolist()
    [True, True]
    >>> verify_histograms(H, P, N, max_distance=0.6, margin=0.0).tolist()
    [True, False]
    """
    centers = np.asarray(centers, dtype=np.float64)
    neg = np.asarray(negative_centers, dtype=np.float64)
    return _verify(
        H, centers, (centers * centers).sum(1), neg, (neg * neg).sum(1),
        max_distance, margin,
    )


def _verify(H, centers, centers_sq, negative, negative_sq, max_distance, margin):
    H = np.asarray(H, dtype=np.float64)
    d_pos = _nearest_distance(H, centers, centers_sq)
    keep = d_pos <= max_distance
    if margin is not None and keep.any():
        # only the rows the paper's test kept need the 400 negative centres
        rows = np.flatnonzero(keep)
        d_neg = _nearest_distance(H[rows], negative, negative_sq)
        keep[rows] = d_pos[rows] <= d_neg + margin
    return keep


class KMeansHistogramVerifier(TransformerMixin, BaseEstimator):
    """Verify keypoints by their patch histograms: k-means centres of positives.

    Stage 2 of the FIR indicator detector (section 3.2 of the paper).  One class, two
    modes, chosen by the input:

    * **frame mode** (``X`` a :class:`~tunnelsense.FrameSequence` or any sequence of
      :class:`~tunnelsense.FrameRecord` whose ``payload["keypoints"]`` was set by
      :class:`IntensityKeypointSampler`).  ``fit(X, y)`` takes per frame the ``(k, 4)``
      indicator boxes ``(left, top, width, height)``; a keypoint is positive when it
      lies inside a box (``left <= col < left + width``, same for rows).
      ``transform`` returns a :class:`~tunnelsense.FrameSequence` of the same frames,
      each evolved with

      - ``payload["keypoints"]``: the verified keypoints, shape (n_kept, 3), int32,
        ``(row, col, intensity)`` in raster order;
      - ``payload["sampled_keypoints"]``: all the keypoints the sampler found.

    * **tabular mode** (``X`` a 2-D array of histograms, one row per keypoint;
      ``y`` equal to ``pos_label`` (1, or ``True``) for positive keypoints, any other
      value for negatives).  ``transform`` gives the distances to the
      kept centres, shape ``(n, n_centers_)`` (as :meth:`sklearn.cluster.KMeans.transform`
      does); ``predict`` gives 1 for verified rows and 0 for rejected ones.  It is not
      a :class:`~sklearn.base.ClassifierMixin`: it models the positive class only (a
      mixture of its centres and one radius), so accuracy on arbitrary labelled blobs
      is not what it promises.  The tabular mode passes ``parametrize_with_checks``
      as a transformer.

    A verifier fitted in frame mode also verifies raw histograms (tabular
    ``transform`` / ``predict``).

    Parameters
    ----------
    patch_size : int or (int, int), default=(7, 3)
        Patch around each keypoint whose histogram is the paper's descriptor,
        ``(height, width)`` in px (an int for a square), centred on the keypoint and
        clipped to the frame by repeating edge pixels.  The default is one grid step
        down (7 px) by half a grid step across (3 px): an indicator is taller than
        wide (the reason for the paper's 6 x 7 grid), and the plate of the smallest
        indicators that matter (14 px tall, about 6 px wide, with soft 1-px edges)
        is only about 4 px wide, so the patch of a keypoint in the middle of a small
        plate is pure plate.  With the paper's rule (10 centres, no context), square
        patches of 5, 7, 9, 11 and 13 px kept a verified keypoint on 79 %, 64 %,
        55 %, 47 % and 44 % of the indicators taller than 14 px of a simulated light
        tour, against 91 % for 7 x 3 (``docs/tunnel-stages.md``).
    context_size : int, (int, int) or None, default=(25, 13)
        A second, larger patch on the same keypoint whose histogram (same bins),
        multiplied by ``context_weight``, follows the patch histogram in the
        descriptor (:func:`keypoint_descriptors`); ``None`` gives the paper's
        descriptor, the patch histogram alone.  A small patch cannot tell a plate
        from an extended warm surface of the same intensity (road warmed behind a
        vehicle, a vehicle's body: the paper's noisy objects that "cannot be
        distinguished by appearance"); 25 x 13 px holds a 14-20 px indicator (about
        6 px wide) with the wall around it, so a plate keypoint's context mixes the
        plate with the cooler wall while an extended surface's is plateau.  On
        simulated tours not used for fitting the context raised the negatives
        removed from 68.5-88.6 % to 91.6-99.0 % (four development seeds, 98.6-99.3 %
        of the indicators kept) and, on two fresh seeds, from 80.1 % and 78.8 % to
        95.9 % and 99.2 % (99.3 % and 97.7 % kept; ``docs/tunnel-stages.md``).
    context_weight : float, default=1.5
        Factor of the context histogram (its rows sum to ``context_weight``), i.e.
        its weight in the Euclidean distances.  Weights 1 and 2 were measured too:
        1 removes fewer negatives, 2 needs a larger ``max_distance`` for the same
        kept indicators.
    bins : int, default=32
        Number of equal-width intensity bins over ``intensity_range`` (the paper's
        32-bin histograms: 8 grey levels a bin for 8-bit frames, about two standard
        deviations of an indicator plate's pixel noise).  16 bins removed fewer
        negative keypoints on simulated tours.
    binning : {"hard", "linear"}, default="hard"
        ``"hard"``: each pixel counts in its bin.  ``"linear"``: each pixel's unit
        weight is shared between the two nearest bin centres, which makes the
        histogram change smoothly with brightness (it did not help on simulated
        tours; kept as an option).
    intensity_range : (int, int) or None, default=None
        Pixel values ``[lo, hi)`` the bins span; ``None`` is the dtype's full range
        (``[0, 256)`` for 8-bit frames).  Set it for 16-bit frames, whose useful
        range is usually a small part of ``[0, 65536)``.  For 8-bit frames a band
        around the indicator intensities was measured too: ``(128, 224)`` with
        ``bins=16`` and ``max_distance=0.25`` gained about a point of each figure on
        one development seed, lost 1.4 points of removed negatives on the other, and
        met both targets (96.0 % / 83.3 %) on a fresh seed where the default kept
        94.9 % (``docs/tunnel-stages.md``); narrower bands removed fewer negatives.
    n_positive_clusters : int, default=40
        k of k-means on the positive histograms.
    n_negative_clusters : int, default=400
        k of k-means on the negative histograms.
    n_centers : int or None, default=None
        Number of positive centres kept (those farthest, on average, from the
        negative centres: the paper's ``Eu`` ranking keeps 10); ``None`` keeps them
        all.  The 10 farthest are pure-plate histograms; the keypoints of a 14-20 px
        indicator (about one grid step wide) have a column of wall in their patch,
        and the centres of such mixed histograms rank last.  With ``margin`` set, the
        negative centres decide against wall-like histograms, so every positive
        centre can be kept (keeping the best 30 of 40 lost 2-3 % of the indicators,
        ``docs/tunnel-stages.md``).
    max_distance : float, default=0.4
        A descriptor is verified only when its Euclidean distance to the nearest
        kept centre is at most this.  The paper's 0.14 is for its own histograms; the
        scale of the distance depends on the patch, the bins and the context (with a
        7 x 3 patch one pixel moving to another bin moves the histogram by
        ``sqrt(2) / 21 = 0.067``).  With the default context, 0.4 kept 98.6-99.3 % of
        the indicators on the development tours; 0.32 removed 0.5-2.8 points more
        negatives but kept 2.0-9.6 points fewer indicators.  For the paper's
        descriptor and rule (``context_size=None``, ``n_centers=10``,
        ``margin=None``), 0.32 was the point of the trade-off curve where 95.5 % of
        the indicators taller than 14 px kept a verified keypoint while 82.2 % of
        the negative keypoints were removed (development tours).
    margin : float or None, default=0.04
        Nearest-centre test with both mixtures: a histogram is verified only when
        its distance to the nearest kept positive centre exceeds its distance to the
        nearest negative centre by at most ``margin`` (a positive margin favours the
        positive class, which has 10 times fewer centres).  ``None`` drops the test
        (the paper's rule).  On the paper's descriptor (``context_size=None``), all
        40 centres, ``max_distance=0.32`` and ``margin=0.04`` kept 96.2 % of the
        indicators and removed 88.6 % of the negatives on the development tours,
        against 95.5 % / 82.2 % for the paper's rule at its best ``max_distance``
        (``docs/tunnel-stages.md``).
    batch_size : int, default=4096
        Rows per mini-batch of the large-set k-means (see ``max_full_samples``).
    n_steps : int, default=300
        Mini-batches drawn (uniformly, with replacement) for a large-set k-means.
    max_full_samples : int, default=20000
        A set of at most this many histograms is clustered with full Lloyd
        :class:`~sklearn.cluster.KMeans`; larger sets with mini-batch k-means fed
        by ``partial_fit``.  Memory beyond the histograms themselves stays at a few
        batches; histograms are kept as float32 when given so.
    pos_label : int, float, bool or str, default=1
        Tabular mode: the value of ``y`` that marks a positive histogram.
    random_state : int, RandomState instance or None, default=None
        Seeds k-means (initialisation and batches).
    n_jobs : int or None, default=None
        Threads of k-means (``None``: one; scikit-learn's threads spin-wait on a
        loaded machine, so more pay only with cores to spare).  Other numbers give
        the same centres up to floating-point rounding (the threads sum in another
        order).

    Attributes
    ----------
    positive_centers_ : ndarray of shape (n_positive_centers, n_features)
        k-means centres of the positive descriptors.
    negative_centers_ : ndarray of shape (n_negative_centers, n_features)
        k-means centres of the negative descriptors.
    center_scores_ : ndarray of shape (n_positive_centers,)
        ``Eu`` of every positive centre: its mean distance to the negative centres.
    centers_ : ndarray of shape (n_centers, n_features)
        The kept positive centres, best (largest ``Eu``) first.
    n_centers_ : int
        Number of kept centres (``n_centers``, all when None, or fewer when there are
        fewer distinct positive histograms).
    n_positive_, n_negative_ : int
        Numbers of positive and negative histograms used in ``fit``.
    n_features_in_ : int
        Descriptor length (frame mode: ``bins``, or ``2 * bins`` with the context).

    Examples
    --------
    Tabular mode, on histograms:

    >>> import numpy as np
    >>> from tunnelsense.tunnel import KMeansHistogramVerifier
    >>> rng = np.random.default_rng(0)
    >>> pos = rng.dirichlet(np.r_[np.ones(4), 50 * np.ones(2), np.ones(2)], 200)
    >>> neg = rng.dirichlet(np.r_[50 * np.ones(2), np.ones(6)], 2000)
    >>> X, y = np.vstack([pos, neg]), np.r_[np.ones(200), np.zeros(2000)]
    >>> v = KMeansHistogramVerifier(random_state=0).fit(X, y)
    >>> v.centers_.shape
    (40, 8)
    >>> float(v.predict(pos).mean()) > 0.9, float(v.predict(neg).mean()) < 0.01
    (True, True)
    """

    _parameter_constraints: dict = {
        "patch_size": [Interval(numbers.Integral, 1, None, closed="left"), tuple],
        "context_size": [Interval(numbers.Integral, 1, None, closed="left"), tuple, None],
        "context_weight": [Interval(numbers.Real, 0, None, closed="neither")],
        "bins": [Interval(numbers.Integral, 1, None, closed="left")],
        "intensity_range": [tuple, list, None],
        "binning": [StrOptions({"hard", "linear"})],
        "n_positive_clusters": [Interval(numbers.Integral, 1, None, closed="left")],
        "n_negative_clusters": [Interval(numbers.Integral, 1, None, closed="left")],
        "n_centers": [Interval(numbers.Integral, 1, None, closed="left"), None],
        "max_distance": [Interval(numbers.Real, 0, None, closed="left")],
        "margin": [Interval(numbers.Real, None, None, closed="neither"), None],
        "batch_size": [Interval(numbers.Integral, 1, None, closed="left")],
        "n_steps": [Interval(numbers.Integral, 1, None, closed="left")],
        "max_full_samples": [Interval(numbers.Integral, 1, None, closed="left")],
        "pos_label": [numbers.Real, str, "boolean"],
        "random_state": ["random_state"],
        "n_jobs": [Interval(numbers.Integral, 1, None, closed="left"), None],
    }

    def __init__(
        self,
        *,
        patch_size=(7, 3),
        context_size=(25, 13),
        context_weight=1.5,
        bins=32,
        intensity_range=None,
        binning="hard",
        n_positive_clusters=40,
        n_negative_clusters=400,
        n_centers=None,
        max_distance=0.4,
        margin=0.04,
        batch_size=4096,
        n_steps=300,
        max_full_samples=20_000,
        pos_label=1,
        random_state=None,
        n_jobs=None,
    ):
        self.patch_size = patch_size
        self.context_size = context_size
        self.context_weight = context_weight
        self.bins = bins
        self.intensity_range = intensity_range
        self.binning = binning
        self.n_positive_clusters = n_positive_clusters
        self.n_negative_clusters = n_negative_clusters
        self.n_centers = n_centers
        self.max_distance = max_distance
        self.margin = margin
        self.batch_size = batch_size
        self.n_steps = n_steps
        self.max_full_samples = max_full_samples
        self.pos_label = pos_label
        self.random_state = random_state
        self.n_jobs = n_jobs

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.required = True
        return tags

    # ------------------------------------------------------------------ helpers
    def _check_range(self):
        for name in ("patch_size", "context_size"):
            ps = getattr(self, name)
            if ps is None or isinstance(ps, numbers.Integral):
                continue
            if len(ps) != 2 or not all(
                isinstance(v, numbers.Integral) and v >= 1 for v in ps
            ):
                raise ValueError(
                    f"{name} must be a positive int or a pair (height, width) of "
                    f"positive ints{' or None' if name == 'context_size' else ''}; "
                    f"got {ps!r}"
                )
        if self.intensity_range is None:
            return
        r = tuple(self.intensity_range)
        if len(r) != 2 or not r[0] < r[1]:
            raise ValueError(
                "intensity_range must be None or a pair (lo, hi) with lo < hi; "
                f"got {self.intensity_range!r}"
            )

    def _frame_histograms(self, records, luts, index_offset=0):
        """Yield (record, keypoints, histograms) per frame."""
        for i, r in enumerate(records):
            kp = keypoints_of(r, i + index_offset, "KMeansHistogramVerifier")
            image = frame_image(r, i + index_offset)
            lut = bin_lut(image.dtype, self.bins, self.intensity_range, self.binning)
            H = keypoint_descriptors(
                image, kp[:, 0], kp[:, 1], patch_size=self.patch_size,
                context_size=self.context_size, context_weight=self.context_weight,
                bins=self.bins, lut=lut,
            )
            yield r, kp, H

    @property
    def _n_descriptor(self):
        return self.bins * (1 if self.context_size is None else 2)

    def _fit_centers(self, positive, negative, positive_rows=None, negative_rows=None):
        """k-means of both sets; ``*_rows`` (index arrays) select them from one
        array given as both ``positive`` and ``negative`` (no copy of the data)."""
        n_pos = len(positive) if positive_rows is None else len(positive_rows)
        n_neg = len(negative) if negative_rows is None else len(negative_rows)
        if n_pos == 0 or n_neg == 0:
            which = "positive" if n_pos == 0 else "negative"
            raise ValueError(
                f"KMeansHistogramVerifier needs positive and negative histograms; y "
                f"has only 1 class (no {which} sample among {n_pos + n_neg})"
            )
        rng = check_random_state(self.random_state)
        kw = dict(
            batch_size=self.batch_size,
            n_steps=self.n_steps,
            max_full_samples=self.max_full_samples,
            n_jobs=self.n_jobs,
        )
        self.positive_centers_ = fit_kmeans(
            positive, self.n_positive_clusters, random_state=rng,
            sample_indices=positive_rows, **kw
        )
        self.negative_centers_ = fit_kmeans(
            negative, self.n_negative_clusters, random_state=rng,
            sample_indices=negative_rows, **kw
        )
        self.center_scores_ = rank_positive_centers(
            self.positive_centers_, self.negative_centers_
        )
        order = np.argsort(-self.center_scores_, kind="stable")[: self.n_centers]
        self.centers_ = self.positive_centers_[order]
        self.n_centers_ = len(self.centers_)
        self._centers_sq = (self.centers_ * self.centers_).sum(1)
        self._negative_sq = (self.negative_centers_ * self.negative_centers_).sum(1)
        self.n_positive_, self.n_negative_ = n_pos, n_neg

    # ------------------------------------------------------------------ API
    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y=None):
        """Learn the positive centres from labelled keypoints or histograms.

        Parameters
        ----------
        X : sequence of FrameRecord, or array-like of shape (n_samples, n_bins)
            Frame records with ``payload["keypoints"]`` (frame mode), or histograms
            (tabular mode).
        y : sequence of array-like of shape (k_i, 4), or array-like of shape (n_samples,)
            Frame mode: per frame, the indicator boxes ``(left, top, width, height)``.
            Tabular mode: ``pos_label`` for positive histograms.

        Returns
        -------
        self : KMeansHistogramVerifier
        """
        self._check_range()
        if is_record_input(X):
            records, boxes = check_frames(X, y)
            if boxes is None:
                raise ValueError(
                    "KMeansHistogramVerifier requires y: per frame, the (k, 4) "
                    "indicator boxes that label keypoints positive"
                )
            pos, neg = [], []
            for (_, kp, H), b in zip(self._frame_histograms(records, {}), boxes, strict=True):
                inside = points_in_boxes(kp[:, 0], kp[:, 1], b)
                pos.append(H[inside])
                neg.append(H[~inside])
            empty = np.empty((0, self._n_descriptor), np.float32)
            self._fit_centers(np.concatenate(pos or [empty]), np.concatenate(neg or [empty]))
            self.n_features_in_ = int(self._n_descriptor)
            self.n_frames_fit_ = len(records)
            return self
        X, y = validate_data(
            self, X, y, dtype=[np.float64, np.float32], y_numeric=False
        )
        y = column_or_1d(y)
        positive = y == self.pos_label
        self._fit_centers(X, X, np.flatnonzero(positive), np.flatnonzero(~positive))
        return self

    def distances(self, X):
        """Distance from every histogram to its nearest kept centre (tabular mode).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_bins)

        Returns
        -------
        distances : ndarray of shape (n_samples,)
        """
        check_is_fitted(self)
        X = validate_data(self, X, dtype=[np.float64, np.float32], reset=False)
        return _nearest_distance(X, self.centers_, self._centers_sq)

    def _verified(self, H):
        """Boolean mask of the verified rows of ``H`` (see :func:`verify_histograms`)."""
        margin = None if self.margin is None else float(self.margin)
        return _verify(
            H, self.centers_, self._centers_sq, self.negative_centers_,
            self._negative_sq, float(self.max_distance), margin,
        )

    def predict(self, X):
        """1 for verified histograms, else 0.

        A histogram is verified when it lies within ``max_distance`` of its nearest
        kept centre and, unless ``margin`` is None, is at most ``margin`` farther
        from it than from the nearest negative centre.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_bins)

        Returns
        -------
        verified : ndarray of shape (n_samples,), int
        """
        check_is_fitted(self)
        X = validate_data(self, X, dtype=[np.float64, np.float32], reset=False)
        return self._verified(X).astype(np.int64)

    def transform(self, X):
        """Keep the verified keypoints of every frame, or measure centre distances.

        Parameters
        ----------
        X : sequence of FrameRecord, or array-like of shape (n_samples, n_bins)

        Returns
        -------
        X_new : FrameSequence or ndarray of shape (n_samples, n_centers)
            Frame mode: the evolved records (see the class docstring).  Tabular mode:
            the distance of every histogram to every kept centre.
        """
        check_is_fitted(self)
        if is_record_input(X):
            records, _ = check_frames(X)
            if self._n_descriptor != self.n_features_in_:
                raise ValueError(
                    f"KMeansHistogramVerifier was fitted on descriptors of "
                    f"{self.n_features_in_} values, but its settings (bins={self.bins}, "
                    f"context_size={self.context_size!r}) describe keypoints by "
                    f"{self._n_descriptor}; fit it again after changing bins or "
                    "context_size"
                )
            out = []
            for r, kp, H in self._frame_histograms(records, {}):
                keep = self._verified(H)
                out.append(r.evolve(keypoints=kp[keep], sampled_keypoints=kp))
            return FrameSequence(out)
        X = validate_data(self, X, dtype=[np.float64, np.float32], reset=False)
        X = np.asarray(X, dtype=np.float64)
        d2 = (
            (X * X).sum(1)[:, None] - 2 * X @ self.centers_.T + self._centers_sq[None, :]
        )
        return np.sqrt(np.maximum(d2, 0))
