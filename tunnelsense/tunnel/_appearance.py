"""Keypoint cluster verification by appearance (section 3.4): :class:`WeightedAdaBoost`.

Each keypoint cluster's rectangle is a detection hypothesis; it is described by the
normalized 32-bin intensity histogram of the image inside the (grown) rectangle and
labelled by an AdaBoost machine of decision stumps, each deciding on one histogram
bin.  Positive training examples start with ``positive_weight`` (7) times the weight
of the negatives, so that the machine errs on the side of keeping indicators; the
motion check (sections 3.5-3.7) removes what appearance cannot.  The stumps and the
tabular core :class:`~tunnelsense.tunnel._stumps.WeightedAdaBoostCore` are in
:mod:`tunnelsense.tunnel._stumps`.
"""

from __future__ import annotations

import numbers

import numpy as np
from sklearn.utils import check_random_state

from tunnelsense._payload import (
    APPEARANCE,
    APPEARANCE_SCORE,
    CLUSTER_BOXES,
    CLUSTER_HISTOGRAMS,
    boxes_of,
    frame_image,
    inside_boxes,
)
from tunnelsense._records import FrameSequence, check_frames
from tunnelsense.tunnel._common import (
    FrameModeMixin,
    bin_lut,
    check_intensity_range,
    is_record_input,
    require_boxes,
)
from tunnelsense.tunnel._contrast import core_boxes
from tunnelsense.tunnel._invariant import (
    _crop_bounds,
    _features,
    box_patches,
    n_invariant_features,
    perturb_patch,
)
from tunnelsense.tunnel._stumps import (
    WeightedAdaBoostCore,
    fit_stump,
    samme,
    stump_decision,
)
from tunnelsense.utils._sklearn_compat import Interval, StrOptions, _fit_context

__all__ = [
    "WeightedAdaBoost",
    "box_histograms",
    "centres_in_boxes",
    "fit_stump",
    "samme",
    "stump_decision",
]


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
#: sets to 0.
_SHAPE_COLUMNS = (_INVARIANT_BINS + 3, _INVARIANT_BINS + 4)


def _invariant_rows(patches, hws, features="invariant"):
    """``_features(patches, hws, _INVARIANT_BINS)``; for ``"invariant-any-shape"``
    with the two aspect-ratio columns set to 0 (a stump cannot split on them)."""
    out = _features(patches, hws, _INVARIANT_BINS)
    if features == "invariant-any-shape":
        out[:, list(_SHAPE_COLUMNS)] = 0.0
    return out


def _chunked_features(patches, hws, chunk=128, features="invariant"):
    """:func:`_invariant_rows` in calls of ``chunk`` patches (its per-patch tables of
    256 grey levels stay in cache)."""
    out = np.empty((len(patches), n_invariant_features(_INVARIANT_BINS)))
    for start in range(0, len(patches), chunk):
        out[start:start + chunk] = _invariant_rows(patches[start:start + chunk],
                                                   hws[start:start + chunk], features)
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


class WeightedAdaBoost(FrameModeMixin, WeightedAdaBoostCore):
    """AdaBoost of histogram-bin stumps with positives weighted up (section 3.4).

    Stage 4 of the FIR indicator detector.  The class takes frame records or 2-D
    arrays:

    * frame records with ``payload["cluster_boxes"]`` from :class:`MSTClusterer`
      (``y``: per frame the ``(k, 4)`` indicator boxes).  The histogram of every
      cluster's rectangle (grown by ``margin``) is computed from the frame's image.
      ``fit`` labels a cluster positive when its rectangle's centre lies inside an
      indicator box of ``y`` (:func:`centres_in_boxes`), every other cluster
      negative, and fits the tabular machine.  ``transform`` returns the same frames,
      each evolved with ``payload["appearance"]`` ((m,) bool, the label of every
      cluster), ``payload["appearance_score"]`` ((m,) float64, the SAMME decision
      function in [-2, 2], > 0: positive) and ``payload["cluster_histograms"]``
      ((m, bins) float64, read by :class:`TrajectoryLinker` as appearance);
    * 2-D arrays of histograms with class labels: the tabular classifier
      (``predict``, ``decision_function``; ``transform`` gives the decision
      function as columns).

    Parameters
    ----------
    n_estimators : int, default=50
        Number of stumps (boosting rounds).
    learning_rate : float, default=1.0
        Shrinks each stump's weight.
    positive_weight : float, default=7.0
        Initial weight of a positive example relative to a negative one (the paper's
        7); 1 gives the plain, evenly weighted AdaBoost.
    pos_label : int, float, bool, str or None, default=None
        The positive class; ``None`` is the greatest class label (``1`` or ``True``
        for indicator labels).  Frame records always use ``True``.
    bins : int, default=32
        Frame records: histogram bins (the paper's 32).
    intensity_range : (int, int) or None, default=None
        Frame records: pixel values ``[lo, hi)`` spanned by the bins; ``None`` is
        the dtype's full range (``[0, 256)`` for 8-bit frames).
    margin : float, default=0.25
        Frame records: each cluster rectangle is grown on every side by this
        fraction of its height before its histogram is taken, so that it shows the
        indicator whole with a rim of the dark wall around it, in the same
        proportion at any distance.  ``0`` is the paper's bare rectangle.
    features : {"histogram", "invariant", "invariant-any-shape"}, \
            default="histogram"
        Frame records: what the stumps decide on.  ``"histogram"`` is the paper's
        normalized intensity histogram of ``bins`` bins.  ``"invariant"`` is
        the invariant features (16 bins of the
        median-filtered patch normalized by its own 10th and 90th percentiles, and
        six shape and contrast figures): a camera with another gain, offset or
        noise level moves a raw histogram's bins, and stumps learnt on one camera's
        bins then fail on another's, while these features stay put.
        ``"invariant-any-shape"``: the same without the two proportions (the log
        aspect ratios of the bright region and of the rectangle, set to 0), so a
        sign of another design (square instead of upright) is judged on its
        intensities, contrast and fill alone.  An option: a training tour shows one
        design, and its proportions are otherwise a strong cue.
        ``payload["cluster_histograms"]`` holds the raw histogram either way.
    augment : int, default=0
        Frame records: every training cluster is also described ``augment`` times
        as another camera would have seen it
        (gain 0.8-1.25,
        offset +-15, extra noise sigma 0-4.5 with a correlation length 0-1.2 px,
        blur 0-0.8 px, scale 0.75-1.25, the range of plausible FIR cameras and
        mountings), so that the machine learns what does not depend on them.
        ``0`` trains on the recorded clusters only (the paper).
    random_state : int, RandomState instance or None, default=None
        Frame records: seed of the augmentation draws.
    core : sequence of float or None, default=None
        Frame records: fractions of a cluster's contrast above the rim of its
        grown rectangle at which its bright cores are also scored
        (:func:`~tunnelsense.tunnel._contrast.core_boxes`); a cluster's score is
        the best of its rectangle's and its cores'.  A sign in a lamp's halo is a
        compact bright rectangle on a smooth gradient: the cluster's rectangle
        spans part of the halo, its core at a higher fraction the sign alone.
        Where a core scores better, it replaces the cluster's rectangle in
        ``payload["cluster_boxes"]`` (the box the trajectory and the detection
        report).  ``None`` scores the rectangle only (training always does).

    Attributes
    ----------
    classes_ : ndarray of shape (n_classes,)
    n_features_in_ : int
    stump_features_, stump_thresholds_ : ndarray of shape (n_stumps,)
        Bin and threshold of every stump (``x[bin] <= threshold`` goes left).
    stump_classes_ : ndarray of shape (n_stumps, 2)
        Index into ``classes_`` predicted left and right of every stump.
    stump_weights_ : ndarray of shape (n_stumps,)
        Weight of every stump.
    stump_errors_ : ndarray of shape (n_stumps,)
        Weighted training error of every stump.
    n_clusters_fit_ : int
        Frame records: number of clusters (positive + negative) trained on.
    n_positive_fit_ : int
        Frame records: number of positive clusters trained on.

    Notes
    -----
    The paper trains on indicators against ordinary lamps only, leaving vehicles and
    their shadows to the motion check.  ``y`` holds indicator boxes only, so every
    non-indicator cluster (lamp, vehicle, shadow) is a negative here; vehicles look
    like indicators, which makes the negative class harder, and the positive
    weighting keeps the recall on indicators.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.tunnel import WeightedAdaBoost
    >>> rng = np.random.default_rng(0)
    >>> X = rng.dirichlet(np.ones(8), 300)
    >>> y = (X[:, 2] > 0.2).astype(int)
    >>> clf = WeightedAdaBoost(n_estimators=20).fit(X, y)
    >>> int(clf.stump_features_[0])
    2
    >>> float((clf.predict(X) == y).mean()) > 0.95
    True
    """

    _parameter_constraints: dict = {
        **WeightedAdaBoostCore._parameter_constraints,
        "bins": [Interval(numbers.Integral, 2, None, closed="left")],
        "intensity_range": [tuple, list, None],
        "margin": [Interval(numbers.Real, 0, None, closed="left")],
        "features": [StrOptions({"histogram", "invariant", "invariant-any-shape"})],
        "augment": [Interval(numbers.Integral, 0, None, closed="left")],
        "random_state": ["random_state"],
        "core": [tuple, list, None],
    }
    _tabular_methods = ("predict", "decision_function")
    _frames_instead = "transform, which stores payload['appearance']"
    _payload_reads = (CLUSTER_BOXES,)
    _payload_adds = (APPEARANCE, APPEARANCE_SCORE, CLUSTER_HISTOGRAMS)

    def __init__(
        self,
        *,
        n_estimators=50,
        learning_rate=1.0,
        positive_weight=7.0,
        pos_label=None,
        bins=32,
        intensity_range=None,
        margin=0.25,
        features="histogram",
        augment=0,
        random_state=None,
        core=None,
    ):
        self.n_estimators = n_estimators
        self.learning_rate = learning_rate
        self.positive_weight = positive_weight
        self.pos_label = pos_label
        self.bins = bins
        self.intensity_range = intensity_range
        self.margin = margin
        self.features = features
        self.augment = augment
        self.random_state = random_state
        self.core = core

    def fit(self, X, y=None, sample_weight=None):
        """Train the machine on histograms, or on the clusters of labelled frames.

        Parameters
        ----------
        X : sequence of FrameRecord, or array-like of shape (n_samples, n_bins)
        y : sequence of array-like of shape (k_i, 4), or array-like of shape (n_samples,)
            For frames: per frame, the indicator boxes.  For arrays: class labels.
        sample_weight : array-like of shape (n_samples,), default=None
            For arrays: weights multiplied into the initial weights.

        Returns
        -------
        self : WeightedAdaBoost
        """
        return super().fit(X, y, sample_weight=sample_weight)

    def _check_range(self):
        check_intensity_range(self.intensity_range)
        if self.core is not None:
            core = np.asarray(self.core, dtype=object)
            if (core.ndim != 1 or len(core) == 0
                    or not all(isinstance(f, numbers.Real) and 0 < f < 1 for f in core)):
                raise ValueError(
                    "core must be None or a non-empty sequence of fractions in "
                    f"(0, 1), got {self.core!r}"
                )

    def _n_features(self):
        if self.features != "histogram":
            return n_invariant_features(_INVARIANT_BINS)
        return int(self.bins)

    def _frame_histograms(self, records):
        """Per frame: record, boxes, raw histograms and the stumps' features."""
        margin = float(self.margin)
        for i, r in enumerate(records):
            boxes = boxes_of(r, i, "WeightedAdaBoost")
            if len(boxes) == 0:
                yield r, boxes, np.empty((0, self.bins)), np.empty((0, self._n_features()))
                continue
            image = frame_image(r, i)
            lut = bin_lut(image.dtype, self.bins, self.intensity_range)
            # the same patches for the histograms and the invariant features
            # (box_histograms and invariant_features, one crop for both)
            rects = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
            patches = box_patches(image, rects, margin)
            H = _patch_histograms(patches, self.bins, lut)
            if self.features != "histogram":
                F = _invariant_rows(patches, rects[:, [3, 2]].tolist(), self.features)
            else:
                F = H
            yield r, boxes, H, F

    def _core_scores(self, record, index, score):
        """Each cluster's score and box, or those of the best of its bright cores
        (:func:`core_boxes` at the fractions ``core``) when its score is larger."""
        boxes = np.asarray(boxes_of(record, index, "WeightedAdaBoost"),
                           dtype=np.float64).reshape(-1, 4)
        image = frame_image(record, index)
        cores = core_boxes(image, boxes, margin=float(self.margin), fractions=self.core)
        owner = np.repeat(np.arange(len(boxes)), cores.shape[1])
        rects = cores.reshape(-1, 4)
        other = (rects != boxes[owner]).any(axis=1)
        if not other.any():
            return score, boxes
        owner, rects = owner[other], rects[other]
        patches = box_patches(image, rects, float(self.margin))
        if self.features != "histogram":
            F = _invariant_rows(patches, rects[:, [3, 2]].tolist(), self.features)
        else:
            F = _patch_histograms(patches, self.bins,
                                  bin_lut(image.dtype, self.bins, self.intensity_range))
        score, boxes = score.copy(), boxes.copy()
        for o, rect, s in zip(owner.tolist(), rects, self._decision(F).tolist(),
                              strict=True):
            if s > score[o]:
                score[o], boxes[o] = s, rect
        return score, boxes

    def _augmented(self, record, index, boxes, rng):
        """Features of the frame's clusters as ``augment`` other cameras see them."""
        image = frame_image(record, index)
        lut = bin_lut(image.dtype, self.bins, self.intensity_range)
        bounds = np.column_stack(
            _crop_bounds(boxes, image.shape, float(self.margin))).tolist()
        patches = [image[r0:r1, c0:c1] for c0, r0, c1, r1 in bounds]
        # every copy drawn first (the draws in the same order as copy by copy),
        # then the features of all of them at once: each row is its patch's alone
        seen = [perturb_patch(patch, rng, (box[3], box[2]))
                for _ in range(int(self.augment))
                for patch, box in zip(patches, boxes.tolist(), strict=True)]
        if self.features != "histogram":
            rows = _invariant_rows([q for q, _ in seen], [hw for _, hw in seen],
                                   self.features)
        else:
            rows = []
            for q, _ in seen:
                counts = np.bincount(lut[q].ravel(), minlength=self.bins)
                rows.append(counts / counts.sum())
        rows = np.array(rows).reshape(int(self.augment), len(boxes), -1)
        return list(rows)

    def _described_frames(self, records, rng):
        """Per frame ``(record, boxes, histograms, features, augmented)`` as
        :meth:`_frame_histograms` and :meth:`_augmented` give them (``augmented``:
        the features of the ``augment`` copies, an empty list without), with the
        invariant features of all frames' patches computed at once (each row is its
        patch's alone: the same values, without a call per frame)."""
        if self.features == "histogram":
            out = []
            for i, (r, b, h, f) in enumerate(self._frame_histograms(records)):
                augmented = (self._augmented(r, i, b, rng) if self.augment and len(b)
                             else [])
                out.append((r, b, h, f, augmented))
            return out
        margin = float(self.margin)
        n_aug = int(self.augment)
        frames, patches, hws, seen = [], [], [], []
        for i, r in enumerate(records):
            b = boxes_of(r, i, "WeightedAdaBoost")
            if len(b) == 0:
                frames.append((r, b, np.empty((0, self.bins)), 0))
                continue
            image = frame_image(r, i)
            lut = bin_lut(image.dtype, self.bins, self.intensity_range)
            rects = np.asarray(b, dtype=np.float64).reshape(-1, 4)
            crops = box_patches(image, rects, margin)
            frames.append((r, b, _patch_histograms(crops, self.bins, lut), len(crops)))
            patches.extend(crops)
            hws.extend(rects[:, [3, 2]].tolist())
            # the copies drawn frame by frame, in _augmented's order
            if n_aug:
                seen.extend(perturb_patch(patch, rng, (box[3], box[2]))
                            for _ in range(n_aug)
                            for patch, box in zip(crops, b.tolist(), strict=True))
        F = _chunked_features(patches, hws, features=self.features)
        G = _chunked_features([q for q, _ in seen], [hw for _, hw in seen],
                              features=self.features)
        out, at_f, at_g = [], 0, 0
        for r, b, h, m in frames:
            f = F[at_f:at_f + m]
            g = G[at_g:at_g + n_aug * m].reshape(n_aug, m, G.shape[1]) if m else []
            at_f, at_g = at_f + m, at_g + n_aug * m
            out.append((r, b, h, f, list(g)))
        return out

    def fit_transform(self, X, y=None, **fit_params):
        """Fit, then transform the same ``X`` (frame records or a 2-D array).

        On frame records the features computed for the fit are scored as they are,
        not computed a second time: the result equals ``fit(X, y).transform(X)``.

        Returns
        -------
        X_new : FrameSequence or ndarray
        """
        if not is_record_input(X):
            return super().fit_transform(X, y, **fit_params)
        described = []
        self._fit_frames(X, y, _described=described, **fit_params)
        if self.features != "histogram" and self.core is not None:
            # the clusters' features as the fit computed them, their cores' in one
            # call: the same values as transform's _scored_with_cores
            return FrameSequence(self._scored_with_cores(
                [r for r, _, _ in described], described))
        return FrameSequence(self._scored(described))

    @_fit_context(prefer_skip_nested_validation=True)
    def _fit_frames(self, X, y=None, sample_weight=None, _described=None):
        """Fit on frame records; ``_described`` (a list), when given, receives
        ``(record, histograms, features)`` of every frame (without augmentation)."""
        self._check_range()
        records, boxes = check_frames(X, y)
        require_boxes(boxes, "WeightedAdaBoost", "that label keypoint clusters positive")
        if sample_weight is not None:
            raise ValueError("sample_weight is only supported for 2-D array input")
        rng = np.random.default_rng(
            check_random_state(self.random_state).randint(0, 2**31 - 1)
        )
        H, labels = [], []
        frames = zip(self._described_frames(records, rng), boxes, strict=True)
        for (r, b, h, f, augmented), gt in frames:
            if _described is not None:
                _described.append((r, h, f))
            lab = centres_in_boxes(b, gt)
            H.append(f)
            labels.append(lab)
            for g in augmented:
                H.append(g)
                labels.append(lab)
        H = np.concatenate(H) if H else np.empty((0, self._n_features()))
        labels = np.concatenate(labels) if labels else np.empty(0, bool)
        n_pos = int(labels.sum())
        if n_pos == 0 or n_pos == len(labels):
            raise ValueError(
                "WeightedAdaBoost needs positive and negative keypoint clusters: "
                f"y marks {n_pos} of the {len(labels)} clusters of X as indicators"
            )
        self._fit_arrays(H, labels, None, True)
        self.n_features_in_ = self._n_features()
        self.n_clusters_fit_ = len(labels)
        self.n_positive_fit_ = n_pos
        return self

    def _transform_frames(self, records):
        if not np.array_equal(self.classes_, [False, True]):
            raise ValueError(
                "this WeightedAdaBoost was fitted on 2-D arrays with classes "
                f"{self.classes_.tolist()}; label frame records with a machine "
                "fitted on frame records (classes [False, True])"
            )
        if self.features != "histogram" and self.core is not None:
            return self._scored_with_cores(records)
        return self._scored((r, H, F) for r, _, H, F in self._frame_histograms(records))

    def _scored_with_cores(self, records, described=None):
        """:meth:`_scored` of frames with ``core``: the invariant features of every
        frame's clusters' patches and of their distinct bright cores' patches in one
        call, scored in one call (each row is its patch's alone: the same values as
        a call per frame and per kind of patch).  ``described`` (from ``fit``), per
        frame ``(record, histograms, features)`` of its clusters, which are then
        not computed again: only the cores' features are."""
        margin = float(self.margin)
        frames, patches, hws, given = [], [], [], []
        for i, r in enumerate(records):
            boxes = boxes_of(r, i, "WeightedAdaBoost")
            if len(boxes) == 0:
                frames.append((r, None, None, None, None))
                continue
            image = frame_image(r, i)
            rects = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
            if described is None:
                crops = box_patches(image, rects, margin)
                H = _patch_histograms(crops, self.bins, bin_lut(
                    image.dtype, self.bins, self.intensity_range))
                patches += crops
                hws.append(rects[:, [3, 2]])
            else:
                _, H, F = described[i]
                given.append(F)
            cores = core_boxes(image, rects, margin=margin, fractions=self.core)
            owner = np.repeat(np.arange(len(rects)), cores.shape[1])
            core_rects = cores.reshape(-1, 4)
            other = (core_rects != rects[owner]).any(axis=1)
            owner, core_rects = owner[other], core_rects[other]
            frames.append((r, rects, H, owner, core_rects))
            patches += box_patches(image, core_rects, margin)
            hws.append(core_rects[:, [3, 2]])
        # the cores of a whole training tour in chunks (their tables stay small)
        rows = _invariant_rows if described is None else _chunked_features
        decision = (self._decision(rows(
            patches, np.concatenate(hws).tolist(), features=self.features))
                    if patches else np.empty(0))
        if described is not None:
            # clusters' rows first, then the cores', frame by frame, as below
            decision = _interleaved(
                self._decision(np.concatenate(given)) if given else np.empty(0),
                decision, [(len(f[1]), len(f[3])) for f in frames if f[1] is not None])
        out, at = [], 0
        for r, rects, H, owner, core_rects in frames:
            if rects is None:
                out.extend(self._scored([(r, np.empty((0, self.bins)),
                                          np.empty((0, self._n_features())))]))
                continue
            m, k = len(rects), len(owner)
            score, boxes = decision[at:at + m], rects
            if k:
                score, boxes = score.copy(), rects.copy()
                for o, rect, s in zip(owner.tolist(), core_rects,
                                      decision[at + m:at + m + k].tolist(), strict=True):
                    if s > score[o]:
                        score[o], boxes[o] = s, rect
            at += m + k
            out.append(r.evolve(**{
                APPEARANCE: score > 0,
                APPEARANCE_SCORE: score,
                CLUSTER_HISTOGRAMS: H,
                CLUSTER_BOXES: boxes,
            }))
        return out

    def _scored(self, described):
        """The records evolved with the machine's labels of their clusters."""
        out = []
        for i, (r, H, F) in enumerate(described):
            score = self._decision(F) if len(F) else np.empty(0)
            cored = {}
            if self.core is not None and len(F):
                score, cored[CLUSTER_BOXES] = self._core_scores(r, i, score)
            out.append(
                r.evolve(**{
                    APPEARANCE: score > 0,
                    APPEARANCE_SCORE: score,
                    CLUSTER_HISTOGRAMS: H,
                    **cored,
                })
            )
        return out
