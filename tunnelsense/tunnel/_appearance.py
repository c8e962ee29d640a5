"""Keypoint cluster verification by appearance (section 3.4): :class:`WeightedAdaBoost`.

Each keypoint cluster's rectangle is a detection hypothesis; it is described by the
normalized 32-bin intensity histogram of the image inside the (grown) rectangle and
labelled by an AdaBoost machine of decision stumps, each deciding on one histogram
bin.  Positive training examples start with ``positive_weight`` (7) times the weight
of the negatives, so that the machine errs on the side of keeping indicators; the
motion check (sections 3.5-3.7) removes what appearance cannot.  The stumps and the
tabular core :class:`~tunnelsense.tunnel._stumps.WeightedAdaBoostCore` are in
:mod:`tunnelsense.tunnel._stumps`, the rectangles' features in
:mod:`tunnelsense.tunnel._appearance_features` and the frame records' description and
scoring in :mod:`tunnelsense.tunnel._appearance_frames`.
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
)
from tunnelsense._records import FrameSequence, check_frames
from tunnelsense.tunnel._appearance_features import (
    _INVARIANT_BINS,
    box_histograms,
    centres_in_boxes,
)
from tunnelsense.tunnel._appearance_frames import AppearanceFramesMixin
from tunnelsense.tunnel._common import (
    FrameModeMixin,
    check_intensity_range,
    is_record_input,
    require_boxes,
)
from tunnelsense.tunnel._invariant import n_invariant_features
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


class WeightedAdaBoost(FrameModeMixin, AppearanceFramesMixin, WeightedAdaBoostCore):
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
    widest_sign : float or None, default=None
        Frame records, ``features="invariant"``: the widest proportions (width /
        height, >= 1) a sign may have.  The two log aspect ratios (height / width)
        are clipped from above at ``-log(widest_sign)``: an upright sign, a square
        one and one up to ``widest_sign`` times wider than high all give the stumps
        the same figures, so that they cannot learn the one design of the training
        tour, while a wider shape (a far lamp's wide sliver, a landscape exit
        panel) keeps its own.  Emergency-telephone signs are upright or square;
        the margin above 1 allows for a small sign's box being a grid step wider
        than it is.  ``None`` leaves the proportions as they are (the stumps learn
        the training design's).
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
        "widest_sign": [Interval(numbers.Real, 1, None, closed="left"), None],
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
        widest_sign=None,
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
        self.widest_sign = widest_sign
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
