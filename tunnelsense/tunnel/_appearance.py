"""Keypoint cluster verification by appearance (section 3.4): weighted AdaBoost.

Each keypoint cluster's smallest bounding rectangle is a detection hypothesis; it is
described by the normalized 32-bin intensity histogram of the image inside the
rectangle and labelled by an AdaBoost machine of decision stumps, each deciding on one
histogram bin.  Positive training examples start with ``positive_weight`` (7) times the
weight of the negatives, so that the machine errs on the side of keeping indicators;
the motion check (sections 3.5-3.7) removes what appearance cannot.

Per-frame prediction does not call scikit-learn: the fitted stumps are evaluated as
arrays (feature, threshold, class left / right, weight), comparing in float32 as
scikit-learn's trees do, which gives the same decisions as
:meth:`sklearn.ensemble.AdaBoostClassifier.predict` for microseconds instead of
milliseconds per call.
"""

from __future__ import annotations

import numbers

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin, TransformerMixin, _fit_context
from sklearn.utils._param_validation import Interval
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import (
    _check_sample_weight,
    check_is_fitted,
    validate_data,
)

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
from tunnelsense.tunnel._common import bin_lut, is_record_input

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
    h, w = image.shape
    out = np.empty((len(boxes), bins))
    for i, (left, top, bw, bh) in enumerate(boxes.tolist()):
        pad = margin * bh
        c0 = min(max(int(round(left - pad)), 0), w - 1)
        r0 = min(max(int(round(top - pad)), 0), h - 1)
        c1 = max(min(int(round(left + bw + pad)), w), c0 + 1)
        r1 = max(min(int(round(top + bh + pad)), h), r0 + 1)
        counts = np.bincount(lut[image[r0:r1, c0:c1]].ravel(), minlength=bins)
        out[i] = counts / counts.sum()
    return out


#: Feature values closer than this are one value for a split (scikit-learn's
#: ``FEATURE_THRESHOLD`` in its tree splitter).
FEATURE_THRESHOLD = 1e-7


def fit_stump(values, order, onehot, weights):
    """The best depth-1 Gini split of weighted samples, as scikit-learn finds it.

    Candidate thresholds lie half-way between consecutive distinct values of a feature
    (values closer than :data:`FEATURE_THRESHOLD` count as one), as in
    :class:`~sklearn.tree.DecisionTreeClassifier`; the split maximizes the Gini proxy
    ``sum_k W_lk^2 / W_l + sum_k W_rk^2 / W_r``.  Splits whose proxy is within a
    relative ``1e-10`` of the best are ties, resolved by the lowest feature, then the
    lowest threshold, so that rounding (weights 3 vs. three rows of weight 1) never
    changes the choice.

    Parameters
    ----------
    values : ndarray of shape (n, n_features), float32
        Every column sorted ascending.
    order : ndarray of shape (n, n_features), intp
        The argsort of each column of the samples.
    onehot : ndarray of shape (n, n_classes), float64
        Class membership of each sample.
    weights : ndarray of shape (n,), float64
        Positive sample weights.

    Returns
    -------
    feature : int
    threshold : float
        ``inf`` when no split was made (pure node or constant features).
    left, right : int
        Class index predicted on each side.
    """
    Wk = onehot * weights[:, None]
    total = Wk.sum(0)
    W = total.sum()
    root = int(np.argmax(total))
    if 1.0 - ((total / W) ** 2).sum() <= np.finfo(np.float64).eps:
        return 0, np.inf, root, root
    CL = np.cumsum(Wk[order], axis=0)[:-1]  # (n - 1, F, K): left sums
    WL = CL.sum(-1)
    CR = total - CL
    WR = W - WL
    with np.errstate(divide="ignore", invalid="ignore"):
        proxy = (CL * CL).sum(-1) / WL + (CR * CR).sum(-1) / WR
    v = values.astype(np.float64)
    valid = (v[1:] > v[:-1] + FEATURE_THRESHOLD) & (WL > 0) & (WR > 0)
    if not valid.any():
        return 0, np.inf, root, root
    proxy = np.where(valid, proxy, -np.inf)
    best = proxy.max()
    tie = proxy >= best - 1e-10 * abs(best)
    # lowest feature first, then lowest position
    feats, positions = np.nonzero(tie.T)
    feat, pos = feats[0], positions[0]
    lo, hi = float(v[pos, feat]), float(v[pos + 1, feat])
    threshold = lo / 2.0 + hi / 2.0
    if threshold == hi or np.isinf(threshold):
        threshold = lo
    return (
        int(feat),
        threshold,
        int(np.argmax(CL[pos, feat])),
        int(np.argmax(CR[pos, feat])),
    )


def samme(X, y_index, n_classes, sample_weight, *, n_estimators=50, learning_rate=1.0):
    """Discrete AdaBoost (SAMME) of depth-1 Gini stumps.

    The same algorithm, update and stopping rules as
    :class:`~sklearn.ensemble.AdaBoostClassifier` with
    ``DecisionTreeClassifier(max_depth=1)``; on data without tied splits both fit the
    same stumps.

    Parameters
    ----------
    X : ndarray of shape (n, n_features)
    y_index : ndarray of shape (n,), intp
        Class index of every sample.
    n_classes : int (>= 2)
    sample_weight : ndarray of shape (n,)
        Positive initial weights.

    Returns
    -------
    feature, threshold, left, right : ndarray of shape (n_stumps,)
    weights : ndarray of shape (n_stumps,)
        The stumps' weights (``estimator_weights_``).
    errors : ndarray of shape (n_stumps,)
        Weighted training error of each stump.
    """
    X32 = np.asarray(X, dtype=np.float32)
    order = np.argsort(X32, axis=0, kind="stable")
    values = np.take_along_axis(X32, order, axis=0)
    onehot = (y_index[:, None] == np.arange(n_classes)).astype(np.float64)
    sw = np.asarray(sample_weight, dtype=np.float64)
    sw = sw / sw.sum()
    eps = np.finfo(np.float64).eps
    sw = np.clip(sw, eps, None)
    stumps, weights, errors = [], [], []
    for iboost in range(n_estimators):
        f, t, left, right = fit_stump(values, order, onehot, sw)
        pred = np.where(X32[:, f] <= t, left, right)
        incorrect = pred != y_index
        error = float(np.average(incorrect, weights=sw))
        stumps.append((f, t, left, right))
        if error <= 0:
            weights.append(1.0)
            errors.append(0.0)
            break
        if error >= 1.0 - 1.0 / n_classes:
            stumps.pop()
            if not stumps:
                raise ValueError(
                    "the first stump is worse than random guessing; the ensemble "
                    "cannot be fit"
                )
            break
        alpha = learning_rate * (np.log((1.0 - error) / error) + np.log(n_classes - 1.0))
        weights.append(alpha)
        errors.append(error)
        if iboost == n_estimators - 1:
            break
        sw = np.exp(np.log(sw) + alpha * incorrect)
        total = sw.sum()
        if not np.isfinite(total) or total <= 0:
            break
        sw /= total
    f, t, left, right = (np.asarray(c) for c in zip(*stumps, strict=True))
    return (
        f.astype(np.intp),
        t.astype(np.float64),
        left.astype(np.intp),
        right.astype(np.intp),
        np.asarray(weights, dtype=np.float64),
        np.asarray(errors, dtype=np.float64),
    )


def stump_decision(X, feature, threshold, left, right, weights, n_classes, total):
    """SAMME decision function of stumps, as ``AdaBoostClassifier.decision_function``.

    The sum over stumps runs in the same order and with the same operations as
    scikit-learn's, so the decisions (and their ties) are identical.

    Parameters
    ----------
    X : ndarray of shape (n, n_features)
    feature, threshold, left, right : arrays from :func:`samme`
    weights : ndarray of shape (n_stumps,)
        The stumps' weights.
    n_classes : int
    total : float
        Sum of all estimator weights of the ensemble (the normalizer).

    Returns
    -------
    decision : ndarray of shape (n,) for two classes, else (n, n_classes)
    """
    X32 = np.asarray(X, dtype=np.float32)
    n = len(X32)
    if len(feature) == 0:
        pred = np.zeros((n, n_classes))
    else:
        cls = np.where(X32[:, feature] <= threshold, left, right)  # (n, M)
        hit = cls[:, :, None] == np.arange(n_classes)  # (n, M, K)
        contrib = np.where(hit, weights[:, None], -1 / (n_classes - 1) * weights[:, None])
        pred = np.cumsum(contrib, axis=1)[:, -1, :]
    pred = pred / total
    if n_classes == 2:
        return -pred[:, 0] + pred[:, 1]
    return pred


class WeightedAdaBoost(ClassifierMixin, TransformerMixin, BaseEstimator):
    """AdaBoost of histogram-bin stumps with positives weighted up (section 3.4).

    Stage 4 of the FIR indicator detector.  One class, two modes, chosen by the
    input (as for :class:`KMeansHistogramVerifier`):

    * **tabular mode** (``X`` a 2-D array of histograms, ``y`` class labels): a
      classifier.  ``fit`` runs discrete AdaBoost (SAMME, :func:`samme`) of depth-1
      Gini stumps, each deciding on one bin, with initial sample weights
      ``positive_weight`` for the ``pos_label`` class and 1 for the others (times
      ``sample_weight``): the algorithm of scikit-learn's
      :class:`~sklearn.ensemble.AdaBoostClassifier` with
      ``DecisionTreeClassifier(max_depth=1)``, which fits the same stumps on data
      without tied splits and makes the same decisions, except that tied splits are
      broken by the lowest bin rather than at random, and rows of zero weight are
      left out, so that integer weights equal repeated rows exactly.
      ``predict`` and ``decision_function`` evaluate the stumps as arrays (float32
      comparisons, as scikit-learn's trees); ``transform`` gives the decision
      function as one column (two classes) or one per class.
    * **frame mode** (``X`` frame records with ``payload["cluster_boxes"]`` from
      :class:`MSTClusterer`; ``y`` per frame the ``(k, 4)`` indicator boxes).  The
      histogram of every cluster's rectangle (see ``margin``) is computed from the
      frame's image.  ``fit`` labels a cluster positive when its rectangle's centre lies
      inside an indicator box of ``y`` (:func:`centres_in_boxes`), every other cluster
      negative, and fits the tabular machine.  ``transform`` returns the same frames,
      each evolved with

      - ``payload["appearance"]``: ndarray of shape (m,), bool -- the appearance label
        of every cluster;
      - ``payload["appearance_score"]``: ndarray of shape (m,), float64 -- the
        SAMME decision function in [-2, 2] (> 0: positive), as scikit-learn scales it;
      - ``payload["cluster_histograms"]``: ndarray of shape (m, bins), float64 -- the
        histograms, used by :class:`TrajectoryLinker` as appearance.

    The paper trains on indicators against ordinary lamps only, leaving vehicles and
    their shadows to the motion check.  ``y`` holds indicator boxes only, so lamps and
    vehicles cannot be told apart here: every non-indicator cluster is a negative.
    Vehicles look like indicators (the paper's reason to leave them out), so they make
    the negative class harder; the positive weighting keeps the recall on indicators.

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
        for indicator labels).  Frame mode always uses ``True``.
    bins : int, default=32
        Frame mode: histogram bins (the paper's 32).
    intensity_range : (int, int) or None, default=None
        Frame mode: pixel values ``[lo, hi)`` spanned by the bins; ``None`` is the
        dtype's full range (``[0, 256)`` for 8-bit frames).
    margin : float, default=0.25
        Frame mode: each cluster rectangle is grown on every side by this fraction of
        its height before its histogram is taken.  A keypoint cluster's rectangle spans
        only its grid points, which lie inside the indicator; the grown rectangle
        shows the indicator whole with a rim of the dark wall around it, in the same
        proportion whatever the distance and the camera's focal length.  ``0`` is the
        paper's bare rectangle.

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
        Frame mode: number of clusters (positive + negative) trained on.
    n_positive_fit_ : int
        Frame mode: number of positive clusters trained on.

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
        "n_estimators": [Interval(numbers.Integral, 1, None, closed="left")],
        "learning_rate": [Interval(numbers.Real, 0, None, closed="neither")],
        "positive_weight": [Interval(numbers.Real, 0, None, closed="neither")],
        "pos_label": [numbers.Real, str, "boolean", None],
        "bins": [Interval(numbers.Integral, 2, None, closed="left")],
        "intensity_range": [tuple, list, None],
        "margin": [Interval(numbers.Real, 0, None, closed="left")],
    }

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
    ):
        self.n_estimators = n_estimators
        self.learning_rate = learning_rate
        self.positive_weight = positive_weight
        self.pos_label = pos_label
        self.bins = bins
        self.intensity_range = intensity_range
        self.margin = margin

    # ------------------------------------------------------------------ tabular
    def _fit_arrays(self, X, y, sample_weight, pos_label):
        check_classification_targets(y)
        classes = np.unique(y)
        pos = classes[-1] if pos_label is None else pos_label
        sample_weight = _check_sample_weight(
            sample_weight, X, dtype=np.float64, copy=True, ensure_non_negative=True
        )
        sample_weight[y == pos] *= float(self.positive_weight)
        # Rows of zero weight take no part (as if removed): they must not move the
        # stumps' thresholds, which lie half-way between neighbouring values.
        keep = sample_weight > 0
        if not keep.any():
            raise ValueError("sample_weight must not be all zero")
        if not keep.all():
            X, y, sample_weight = X[keep], y[keep], sample_weight[keep]
        self.classes_ = classes = np.unique(y)
        if len(classes) == 1:
            (
                self.stump_features_,
                self.stump_thresholds_,
                self._left,
                self._right,
                self.stump_weights_,
                self.stump_errors_,
            ) = (np.empty(0, np.intp),) * 4 + (np.empty(0),) * 2
        else:
            (
                self.stump_features_,
                self.stump_thresholds_,
                self._left,
                self._right,
                self.stump_weights_,
                self.stump_errors_,
            ) = samme(
                X,
                np.searchsorted(classes, y),
                len(classes),
                sample_weight,
                n_estimators=self.n_estimators,
                learning_rate=self.learning_rate,
            )
        self.stump_classes_ = np.column_stack([self._left, self._right])
        self._total_weight = float(self.stump_weights_.sum())
        return self

    def _decision(self, X):
        if len(self.classes_) == 1:
            return np.zeros((len(X), 1))
        return stump_decision(
            X,
            self.stump_features_,
            self.stump_thresholds_,
            self._left,
            self._right,
            self.stump_weights_,
            len(self.classes_),
            self._total_weight,
        )

    def _predict_arrays(self, X):
        d = self._decision(X)
        if len(self.classes_) == 1:
            return np.repeat(self.classes_, len(X))
        if len(self.classes_) == 2:
            return self.classes_.take(d > 0, axis=0)
        return self.classes_.take(np.argmax(d, axis=1), axis=0)

    # ------------------------------------------------------------------ frames
    def _check_range(self):
        if self.intensity_range is None:
            return
        r = tuple(self.intensity_range)
        if len(r) != 2 or not r[0] < r[1]:
            raise ValueError(
                "intensity_range must be None or a pair (lo, hi) with lo < hi; "
                f"got {self.intensity_range!r}"
            )

    def _frame_histograms(self, records):
        kw = dict(bins=self.bins, margin=float(self.margin))
        for i, r in enumerate(records):
            boxes = boxes_of(r, i, "WeightedAdaBoost")
            if len(boxes) == 0:
                yield r, boxes, np.empty((0, self.bins))
                continue
            image = frame_image(r, i)
            lut = bin_lut(image.dtype, self.bins, self.intensity_range)
            yield r, boxes, box_histograms(image, boxes, lut=lut, **kw)

    # ------------------------------------------------------------------ API
    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y=None, sample_weight=None):
        """Train the machine on histograms, or on the clusters of labelled frames.

        Parameters
        ----------
        X : sequence of FrameRecord, or array-like of shape (n_samples, n_bins)
        y : sequence of array-like of shape (k_i, 4), or array-like of shape (n_samples,)
            Frame mode: per frame, the indicator boxes.  Tabular mode: class labels.
        sample_weight : array-like of shape (n_samples,), default=None
            Tabular mode: weights multiplied into the initial weights.

        Returns
        -------
        self : WeightedAdaBoost
        """
        if is_record_input(X):
            self._check_range()
            records, boxes = check_frames(X, y)
            if boxes is None:
                raise ValueError(
                    "WeightedAdaBoost requires y: per frame, the (k, 4) indicator "
                    "boxes that label keypoint clusters positive"
                )
            if sample_weight is not None:
                raise ValueError("sample_weight is only supported for 2-D array input")
            H, labels = [], []
            for (_, b, h), gt in zip(self._frame_histograms(records), boxes, strict=True):
                H.append(h)
                labels.append(centres_in_boxes(b, gt))
            H = np.concatenate(H) if H else np.empty((0, self.bins))
            labels = np.concatenate(labels) if labels else np.empty(0, bool)
            n_pos = int(labels.sum())
            if n_pos == 0 or n_pos == len(labels):
                raise ValueError(
                    "WeightedAdaBoost needs positive and negative keypoint clusters: "
                    f"y marks {n_pos} of the {len(labels)} clusters of X as indicators"
                )
            self._fit_arrays(H, labels, None, True)
            self.n_features_in_ = int(self.bins)
            self.n_clusters_fit_ = len(labels)
            self.n_positive_fit_ = n_pos
            return self
        X, y = validate_data(self, X, y, dtype=[np.float64, np.float32])
        return self._fit_arrays(X, y, sample_weight, self.pos_label)

    def fit_transform(self, X, y=None, **fit_params):
        """Fit, then label the clusters of the same frames (frame mode).

        Returns
        -------
        X_new : FrameSequence or ndarray
        """
        return self.fit(X, y, **fit_params).transform(X)

    def decision_function(self, X):
        """The SAMME decision function (tabular mode), as scikit-learn computes it.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_bins)

        Returns
        -------
        decision : ndarray of shape (n_samples,) or (n_samples, n_classes)
            Two classes: > 0 means ``classes_[1]``.
        """
        check_is_fitted(self)
        X = validate_data(self, X, dtype=[np.float64, np.float32], reset=False)
        return self._decision(X)

    def predict(self, X):
        """Class of every histogram (tabular mode).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_bins)

        Returns
        -------
        y : ndarray of shape (n_samples,)
        """
        check_is_fitted(self)
        if is_record_input(X):
            raise TypeError(
                "WeightedAdaBoost.predict takes a 2-D array of histograms; for frame "
                "records use transform, which stores payload['appearance']"
            )
        X = validate_data(self, X, dtype=[np.float64, np.float32], reset=False)
        return self._predict_arrays(X)

    def transform(self, X):
        """Label every keypoint cluster by appearance, or give decision values.

        Parameters
        ----------
        X : sequence of FrameRecord, or array-like of shape (n_samples, n_bins)

        Returns
        -------
        X_new : FrameSequence or ndarray of shape (n_samples, 1 or n_classes)
            Frame mode: the evolved records (see the class docstring).  Tabular mode:
            the decision function as columns.
        """
        check_is_fitted(self)
        if is_record_input(X):
            records, _ = check_frames(X)
            if not np.array_equal(self.classes_, [False, True]):
                raise ValueError(
                    "this WeightedAdaBoost was fitted on 2-D arrays with classes "
                    f"{self.classes_.tolist()}; label frame records with a machine "
                    "fitted on frame records (classes [False, True])"
                )
            out = []
            for r, _, H in self._frame_histograms(records):
                score = self._decision(H) if len(H) else np.empty(0)
                out.append(
                    r.evolve(**{
                        APPEARANCE: score > 0,
                        APPEARANCE_SCORE: score,
                        CLUSTER_HISTOGRAMS: H,
                    })
                )
            return FrameSequence(out)
        X = validate_data(self, X, dtype=[np.float64, np.float32], reset=False)
        return self._decision(X).reshape(len(X), -1)
