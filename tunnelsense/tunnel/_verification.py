"""Keypoint verification (section 3.2): the frame stage :class:`KMeansHistogramVerifier`.

The descriptors are in :mod:`tunnelsense.tunnel._descriptors`, the k-means rule and
its tabular core :class:`~tunnelsense.tunnel._kmeans.KMeansHistogramCore` in
:mod:`tunnelsense.tunnel._kmeans`.
"""

from __future__ import annotations

import numbers

import numpy as np
from sklearn.utils import check_random_state

from tunnelsense._payload import (
    KEYPOINTS,
    SAMPLED_KEYPOINTS,
    frame_image,
    keypoints_of,
)
from tunnelsense._records import FrameSequence, check_frames
from tunnelsense.tunnel._common import (
    FrameModeMixin,
    bin_lut,
    check_intensity_range,
    is_record_input,
    points_in_boxes,
    require_boxes,
)
from tunnelsense.tunnel._descriptors import (
    compose_lut,
    descriptors_under_luts,
    keypoint_descriptors,
    patch_histograms,
    surround_histograms,
)
from tunnelsense.tunnel._intensity import (
    background_level,
    normalize_frame,
    normalize_lut,
)
from tunnelsense.tunnel._kmeans import (
    KMeansHistogramCore,
    blas_threads,
    fit_kmeans,
    rank_positive_centers,
    verify_histograms,
)
from tunnelsense.utils._sklearn_compat import Interval, StrOptions, _fit_context

__all__ = [
    "KMeansHistogramVerifier",
    "augment_factors",
    "contrast_copy",
    "fit_kmeans",
    "keypoint_descriptors",
    "patch_histograms",
    "rank_positive_centers",
    "verify_histograms",
]


def augment_factors(rng, bounds, draw="uniform"):
    """The contrast factors of one training frame's augmented copies.

    ``"uniform"``: one factor drawn uniformly from ``bounds``; ``"log-uniform"``: one
    factor whose logarithm is uniform between the logarithms of ``bounds``;
    ``"reciprocal"``: a factor ``f`` drawn uniformly from ``bounds`` and its reciprocal
    ``1 / f``, so a copy with less and one with more contrast (symmetric in log
    about 1).

    Examples
    --------
    >>> import numpy as np
    >>> f = augment_factors(np.random.default_rng(0), (0.5, 1.0), "reciprocal")
    >>> len(f), bool(np.isclose(f[0] * f[1], 1.0))
    (2, True)
    """
    lo, hi = bounds
    if draw == "log-uniform":
        return [float(np.exp(rng.uniform(np.log(lo), np.log(hi))))]
    f = float(rng.uniform(lo, hi))
    if draw == "reciprocal":
        return [f, 1.0 / f]
    return [f]


def contrast_copy(image, factor):
    """The frame with its contrast about its background level scaled by ``factor``:
    ``I' = level + factor * (I - level)`` (``level`` from
    :func:`~tunnelsense.tunnel._intensity.background_levels`), rounded and clipped.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.full((60, 80), 100, np.uint8)
    >>> img[10:30, 10:20] = 180
    >>> int(contrast_copy(img, 0.5)[15, 15])
    140
    """
    level = background_level(image)
    return normalize_frame(image, level, 1.0, level, float(factor))


class KMeansHistogramVerifier(FrameModeMixin, KMeansHistogramCore):
    """Verify keypoints by their patch histograms: k-means centres of positives.

    Stage 2 of the FIR indicator detector (section 3.2 of the paper).  Each keypoint
    is described by :func:`keypoint_descriptors`: the normalized histogram of the
    patch around it, followed (unless ``context_size`` is None) by the weighted
    histogram of a larger context patch.  The descriptors of positive keypoints
    (inside an indicator box: ``left <= col < left + width``, same for rows) and of
    negative ones are clustered by k-means; a keypoint is kept when its descriptor
    is near a kept positive centre (:func:`verify_histograms`).

    The class takes frame records or 2-D arrays:

    * frame records (``payload["keypoints"]`` from :class:`IntensityKeypointSampler`;
      ``y`` per frame the ``(k, 4)`` indicator boxes): ``transform`` returns the same
      frames, each evolved with ``payload["keypoints"]``, the verified keypoints
      (shape (n_kept, 3), int32, raster order), and ``payload["sampled_keypoints"]``,
      all the keypoints the sampler found;
    * 2-D arrays of descriptors (``y`` equal to ``pos_label`` for positives): the
      tabular verifier (``predict``: 1 for verified rows; ``transform``:
      distances to the kept centres).  A verifier fitted on frames also verifies raw descriptors.

    Parameters
    ----------
    patch_size : int or (int, int), default=(7, 3)
        Patch around each keypoint whose histogram is the paper's descriptor,
        ``(height, width)`` in px (an int for a square): one grid step down by half a
        grid step across, so that the patch of a keypoint on a small plate is plate.
    context_size : int, (int, int) or None, default=(25, 13)
        A larger patch whose histogram, times ``context_weight``, follows the patch
        histogram in the descriptor; ``None`` gives the paper's descriptor.  The
        context tells a plate (plate and cooler wall) from an extended warm surface
        of the same intensity (road warmed behind a vehicle, a vehicle's body).
    context_weight : float, default=1.5
        Factor of the context histogram (its rows sum to ``context_weight``).
    bins : int, default=32
        Equal-width intensity bins over ``intensity_range`` (the paper's 32).
    binning : {"hard", "linear"}, default="hard"
        ``"hard"``: each pixel counts in its bin.  ``"linear"``: each pixel's weight is
        shared between the two nearest bin centres.
    intensity_range : (int, int) or None, default=None
        Pixel values ``[lo, hi)`` the bins span; ``None`` is the dtype's full range.
        Set it for 16-bit frames, whose useful range is a small part of
        ``[0, 65536)``.
    n_positive_clusters : int, default=40
        k of k-means on the positive descriptors.
    n_negative_clusters : int, default=400
        k of k-means on the negative descriptors.
    n_centers : int or None, default=None
        Number of positive centres kept, those farthest on average from the negative
        centres (the paper's ``Eu`` ranking keeps 10); ``None`` keeps them all.
    max_distance : float, default=0.4
        A descriptor is verified only when its Euclidean distance to the nearest
        kept centre is at most this (the paper's 0.14 is for its own histograms; the
        scale depends on the patch, the bins and the context).
    margin : float or None, default=0.04
        A descriptor is verified only when its distance to the nearest kept centre
        exceeds its distance to the nearest negative centre by at most ``margin``;
        ``None`` drops the test (the paper's rule).
    batch_size : int, default=4096
        Rows per mini-batch of the large-set k-means (see ``max_full_samples``).
    n_steps : int, default=100
        Mini-batches drawn (uniformly, with replacement) for a large-set k-means
        (100 batches of 4,096 rows: within 1 % of the inertia of 300 batches on
        histograms, at a third of the cost).
    max_full_samples : int, default=20000
        A set of at most this many descriptors is clustered with full Lloyd
        k-means, a larger one with mini-batch k-means (:func:`fit_kmeans`).
    pos_label : int, float, bool or str, default=1
        For 2-D arrays: the value of ``y`` that marks a positive descriptor.
    random_state : int, RandomState instance or None, default=None
        Seeds k-means (initialisation and batches).
    n_jobs : int or None, default=None
        Threads of k-means (``None``: one).
    augment_contrast : (float, float) or None, default=None
        Training-time augmentation (frame records): every training frame is also
        described with its contrast about its background level scaled by a factor
        drawn uniformly from this range (:func:`contrast_copy`), at the same
        keypoints, so that a sign seen with less contrast (warmer air) or through
        another gain is verified.  ``None``: the paper's training set.
        :func:`~tunnelsense.tunnel.make_indicator_pipeline` uses ``(0.45, 1.0)``
        with ``augment_draw="reciprocal"``.
    augment_draw : {"uniform", "log-uniform", "reciprocal"}, default="uniform"
        How the factors of ``augment_contrast`` are drawn (:func:`augment_factors`):
        ``"uniform"``, one copy per frame with a factor uniform in the range;
        ``"log-uniform"``, one copy with a factor uniform in log; ``"reciprocal"``,
        two copies, at a factor ``f`` uniform in the range and at ``1 / f``: a sign
        with less contrast (warmer air) and one with more (colder air) are verified
        alike (:func:`~tunnelsense.tunnel.make_indicator_pipeline`'s choice).
    normalize : {"none", "surround"}, default="none"
        Frame records: ``"none"``, the histogram of the patch's grey levels (the
        paper's).  ``"surround"``: the histogram of the patch's values normalized by
        its own surround (:func:`surround_histograms`: the keypoint's contrast above
        the 10th percentile of a ``context_size`` window, ``(25, 13)`` when
        ``context_size`` is None), invariant to gain, offset and the sign's
        contrast; the descriptor is that histogram alone.

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
        Number of kept centres.
    n_positive_, n_negative_ : int
        Numbers of positive and negative descriptors used in ``fit``.
    quantum_ : float
        The grid (a power of two) the descriptors and centres are rounded to, so
        that every distance is exact and every decision the same on every CPU.
    n_features_in_ : int
        Descriptor length (for frames: ``bins``, or ``2 * bins`` with the context).
    n_frames_fit_ : int
        Number of frames seen by ``fit`` (frame records only).

    See Also
    --------
    keypoint_descriptors, verify_histograms, fit_kmeans

    Notes
    -----
    The paper's rule is ``context_size=None, n_centers=10, margin=None`` with its
    ``max_distance=0.14``.  The defaults add the context histogram and keep every
    positive centre, with the ``margin`` test between both mixtures the paper's
    model already holds; what each choice gained on simulated tours is in
    ``docs/tunnel-measurements.md``.

    Examples
    --------
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
        **KMeansHistogramCore._parameter_constraints,
        "patch_size": [Interval(numbers.Integral, 1, None, closed="left"), tuple],
        "context_size": [Interval(numbers.Integral, 1, None, closed="left"), tuple, None],
        "context_weight": [Interval(numbers.Real, 0, None, closed="neither")],
        "bins": [Interval(numbers.Integral, 1, None, closed="left")],
        "intensity_range": [tuple, list, None],
        "binning": [StrOptions({"hard", "linear"})],
        "augment_contrast": [tuple, list, None],
        "augment_draw": [StrOptions({"uniform", "log-uniform", "reciprocal"})],
        "normalize": [StrOptions({"none", "surround"})],
    }
    _tabular_methods = ("predict", "distances")
    _payload_reads = (KEYPOINTS,)
    _payload_adds = (KEYPOINTS, SAMPLED_KEYPOINTS)

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
        n_steps=100,
        max_full_samples=20_000,
        pos_label=1,
        random_state=None,
        n_jobs=None,
        augment_contrast=None,
        augment_draw="uniform",
        normalize="none",
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
        self.augment_contrast = augment_contrast
        self.augment_draw = augment_draw
        self.normalize = normalize

    def _check_settings(self):
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
        check_intensity_range(self.intensity_range)

    def _frame_histograms(self, records, rng=None):
        """Yield (record, keypoints, descriptors) per frame; with ``rng``, the
        descriptors of a contrast-augmented copy of the frame are stacked below."""
        for i, r in enumerate(records):
            kp = keypoints_of(r, i, "KMeansHistogramVerifier")
            image = frame_image(r, i)
            lut = bin_lut(image.dtype, self.bins, self.intensity_range, self.binning)
            factors = () if rng is None else augment_factors(
                rng, self.augment_contrast, self.augment_draw)
            if self.normalize == "none":
                # a contrast copy is a pointwise map of grey levels: composed into
                # the bin table, it describes the copy without building it
                # (descriptors equal to those of contrast_copy's frames)
                luts = [lut]
                if len(factors):
                    level = background_level(image)
                    luts += [compose_lut(lut, normalize_lut(image.dtype, level, 1.0,
                                                            level, float(f)))
                             for f in factors]
                H = descriptors_under_luts(
                    image, kp[:, 0], kp[:, 1], luts, patch_size=self.patch_size,
                    context_size=self.context_size, context_weight=self.context_weight,
                    bins=self.bins)
                yield r, kp, H
                continue
            images = [image, *(contrast_copy(image, f) for f in factors)]
            if self.normalize == "surround":
                surround = (25, 13) if self.context_size is None else self.context_size
                H = np.concatenate([
                    surround_histograms(im, kp[:, 0], kp[:, 1],
                                        patch_size=self.patch_size,
                                        surround_size=surround, bins=self.bins)
                    for im in images
                ])
                yield r, kp, H
                continue
            raise ValueError(f"normalize must be 'none' or 'surround'; got {self.normalize!r}")

    @property
    def _n_descriptor(self):
        if self.normalize == "surround":
            return self.bins
        return self.bins * (1 if self.context_size is None else 2)

    def fit_transform(self, X, y=None, **fit_params):
        """Fit, then transform the same ``X`` (frame records or a 2-D array).

        On frame records the descriptors computed for the fit are verified as they
        are, not computed a second time: the result equals ``fit(X, y).transform(X)``.

        Returns
        -------
        X_new : FrameSequence or ndarray
        """
        if not is_record_input(X):
            return super().fit_transform(X, y, **fit_params)
        described = {}
        self._fit_frames(X, y, _described=described, **fit_params)
        P, N = described["positive"], described["negative"]
        # each frame's rows of the fit: its positives, then its negatives, each
        # followed by those of its augmented copies; the frame's own rows (not the
        # copies') are verified, all frames at once (each row's decision is its own)
        rows_p, rows_n, at_p, at_n = [], [], 0, 0
        for _, kp, inside, copies in described["frames"]:
            n_in = int(inside.sum())
            rows_p.append(np.arange(at_p, at_p + n_in))
            rows_n.append(np.arange(at_n, at_n + len(kp) - n_in))
            at_p += copies * n_in
            at_n += copies * (len(kp) - n_in)
        keep_p = self._verified_rows(P, np.concatenate(rows_p or [np.empty(0, np.intp)]))
        keep_n = self._verified_rows(N, np.concatenate(rows_n or [np.empty(0, np.intp)]))
        out, at_p, at_n = [], 0, 0
        for r, kp, inside, _ in described["frames"]:
            n_in = int(inside.sum())
            keep = np.empty(len(kp), bool)
            keep[inside] = keep_p[at_p:at_p + n_in]
            keep[~inside] = keep_n[at_n:at_n + len(kp) - n_in]
            at_p, at_n = at_p + n_in, at_n + len(kp) - n_in
            out.append(r.evolve(**{KEYPOINTS: kp[keep], SAMPLED_KEYPOINTS: kp}))
        return FrameSequence(out)

    def _verified_rows(self, H, rows, chunk=8192):
        """:meth:`_verified` of the rows ``rows`` of ``H``, in chunks."""
        keep = np.empty(len(rows), bool)
        with blas_threads(self.n_jobs):
            for start in range(0, len(rows), chunk):
                keep[start:start + chunk] = self._verified(H[rows[start:start + chunk]])
        return keep

    @_fit_context(prefer_skip_nested_validation=True)
    def _fit_frames(self, X, y=None, _described=None):
        """Fit on frame records; ``_described`` (a dict), when given, receives the
        descriptors of the fit (``"positive"``, ``"negative"``) and per frame
        ``(record, keypoints, inside, copies)`` (``"frames"``), which locate its rows
        in them."""
        self._check_settings()
        records, boxes = check_frames(X, y)
        require_boxes(boxes, "KMeansHistogramVerifier", "that label keypoints positive")
        rng = None
        if self.augment_contrast is not None:
            lo, hi = self.augment_contrast
            if not 0 < lo <= hi:
                raise ValueError(
                    "augment_contrast must be a pair (low, high) with 0 < low <= high; "
                    f"got {self.augment_contrast!r}"
                )
            rng = np.random.default_rng(
                check_random_state(self.random_state).randint(0, 2**31 - 1))
        pos, neg, frames_of = [], [], []
        frames = zip(self._frame_histograms(records, rng), boxes, strict=True)
        for (r, kp, H), b in frames:
            inside = points_in_boxes(kp[:, 0], kp[:, 1], b)
            copies = len(H) // len(kp) if len(kp) else 1
            frames_of.append((r, kp, inside, copies))
            if len(kp):  # the augmented copy's rows follow the frame's
                inside = np.tile(inside, copies)
            pos.append(H[inside])
            neg.append(H[~inside])
        empty = np.empty((0, self._n_descriptor), np.float32)
        P = np.concatenate(pos or [empty])
        del pos
        N = np.concatenate(neg or [empty])
        del neg
        # one BLAS thread (n_jobs): spinning BLAS threads make the distances several
        # times slower on a busy machine, and the centres do not depend on it
        with blas_threads(self.n_jobs):
            self._fit_centers(P, N)
        if _described is not None:
            _described.update(positive=P, negative=N, frames=frames_of)
        self.n_features_in_ = int(self._n_descriptor)
        self.n_frames_fit_ = len(records)
        return self

    def _transform_frames(self, records):
        if self._n_descriptor != self.n_features_in_:
            raise ValueError(
                f"KMeansHistogramVerifier was fitted on descriptors of "
                f"{self.n_features_in_} values, but its settings (bins={self.bins}, "
                f"context_size={self.context_size!r}) describe keypoints by "
                f"{self._n_descriptor}; fit it again after changing bins or "
                "context_size"
            )
        out = []
        with blas_threads(self.n_jobs):
            for r, kp, H in self._frame_histograms(records):
                keep = self._verified(H)
                out.append(r.evolve(**{KEYPOINTS: kp[keep], SAMPLED_KEYPOINTS: kp}))
        return out
