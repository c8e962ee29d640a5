"""Weighted AdaBoost (section 3.4), the math: decision stumps as arrays.

:func:`samme` is discrete AdaBoost (SAMME) of depth-1 Gini stumps, the algorithm of
scikit-learn's :class:`~sklearn.ensemble.AdaBoostClassifier` with
``DecisionTreeClassifier(max_depth=1)``; :func:`stump_decision` evaluates the fitted
stumps as arrays (feature, threshold, class left / right, weight), comparing in
float32 as scikit-learn's trees do, which gives the same decisions as
:meth:`sklearn.ensemble.AdaBoostClassifier.predict` for microseconds instead of
milliseconds per call.  :class:`WeightedAdaBoostCore` is the tabular classifier.
"""

from __future__ import annotations

import numbers

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin, TransformerMixin
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted

from tunnelsense.utils._sklearn_compat import (
    Interval,
    _check_sample_weight,
    _fit_context,
    validate_data,
)

__all__ = [
    "FEATURE_THRESHOLD",
    "WeightedAdaBoostCore",
    "fit_stump",
    "samme",
    "stump_decision",
]


#: Feature values closer than this are one value for a split (scikit-learn's
#: ``FEATURE_THRESHOLD`` in its tree splitter).
FEATURE_THRESHOLD = 1e-7


def _split_proxy(CL, total, W):
    """The per-class right sums, the left and right weights and the Gini proxy
    ``sum_k L_k^2 / WL + R_k^2 / WR`` at every split, from the per-class left sums
    ``CL`` (a list over classes) and the per-class totals: class by class the same
    running sums, and the same sums over classes (left to right), as on one
    ``(..., K)`` array."""
    CR = [t - c for t, c in zip(total, CL, strict=True)]
    WL, sq_left, sq_right = CL[0].copy(), CL[0] * CL[0], CR[0] * CR[0]
    for cl, cr in zip(CL[1:], CR[1:], strict=True):
        WL += cl
        sq_left += cl * cl
        sq_right += cr * cr
    if len(CL) >= 8:  # numpy sums 8 or more terms pairwise: sum them as it does
        CLa, CRa = np.stack(CL, axis=-1), np.stack(CR, axis=-1)
        WL, sq_left, sq_right = CLa.sum(-1), (CLa * CLa).sum(-1), (CRa * CRa).sum(-1)
    WR = W - WL
    with np.errstate(divide="ignore", invalid="ignore"):
        proxy = sq_left / WL + sq_right / WR
    return CR, WL, WR, proxy


def fit_stump(values, order, onehot, weights, distinct=None):
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
    distinct : ndarray of shape (n - 1, n_features), bool, or None
        Where a split may fall, ``values[1:] > values[:-1] + FEATURE_THRESHOLD`` (in
        float64): computed once by a caller that fits many stumps on ``values``.

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
    # per class, the left sums (n - 1, F) at every split; class by class the same
    # running sums, and the same sums over classes (left to right), as on one
    # (n - 1, F, K) array
    CL = [np.cumsum(Wk[:, k].take(order), axis=0)[:-1] for k in range(Wk.shape[1])]
    CR, WL, WR, proxy = _split_proxy(CL, total, W)
    if distinct is None:
        v = values.astype(np.float64)
        distinct = v[1:] > v[:-1] + FEATURE_THRESHOLD
    valid = distinct & (WL > 0) & (WR > 0)
    if not valid.any():
        return 0, np.inf, root, root
    proxy = np.where(valid, proxy, -np.inf)
    best = proxy.max()
    tie = proxy >= best - 1e-10 * abs(best)
    # lowest feature first, then lowest position
    feats, positions = np.nonzero(tie.T)
    feat, pos = feats[0], positions[0]
    lo, hi = float(values[pos, feat]), float(values[pos + 1, feat])
    threshold = lo / 2.0 + hi / 2.0
    if threshold == hi or np.isinf(threshold):
        threshold = lo
    return (
        int(feat),
        threshold,
        int(np.argmax([c[pos, feat] for c in CL])),
        int(np.argmax([c[pos, feat] for c in CR])),
    )


class _StumpFitter:
    """:func:`fit_stump` for many weightings of the same samples: the sort order
    (feature-major, contiguous) and the candidate split positions are found once,
    and each fit computes the Gini proxy at the candidate positions only.

    Every value is computed by the same operations as :func:`fit_stump`'s (running
    sums in sample order, the same sums over classes), so both return the same
    split; the test suite checks it.
    """

    def __init__(self, values, order, onehot, distinct):
        n, n_features = values.shape
        self.values = values
        self.onehot = onehot
        self.n = n
        # feature by feature, the samples in ascending order of the feature
        self.order_t = np.ascontiguousarray(order.T)
        # candidate splits in (feature, position) order, as np.nonzero(tie.T) lists
        # them; their offsets in the (n_features, n) running sums
        feats, positions = np.nonzero(distinct.T)
        self.feats, self.positions = feats, positions
        self.at = feats * n + positions

    def fit(self, weights):
        onehot = self.onehot
        Wk = onehot * weights[:, None]
        total = Wk.sum(0)
        W = total.sum()
        root = int(np.argmax(total))
        if 1.0 - ((total / W) ** 2).sum() <= np.finfo(np.float64).eps:
            return 0, np.inf, root, root
        if not len(self.at):
            return 0, np.inf, root, root
        CL = [np.cumsum(Wk[:, k].take(self.order_t), axis=1).take(self.at)
              for k in range(Wk.shape[1])]
        CR, WL, WR, proxy = _split_proxy(CL, total, W)
        valid = (WL > 0) & (WR > 0)
        if not valid.any():
            return 0, np.inf, root, root
        proxy = np.where(valid, proxy, -np.inf)
        best = proxy.max()
        first = int(np.argmax(proxy >= best - 1e-10 * abs(best)))
        feat, pos = int(self.feats[first]), int(self.positions[first])
        lo, hi = float(self.values[pos, feat]), float(self.values[pos + 1, feat])
        threshold = lo / 2.0 + hi / 2.0
        if threshold == hi or np.isinf(threshold):
            threshold = lo
        return (
            feat,
            threshold,
            int(np.argmax([c[first] for c in CL])),
            int(np.argmax([c[first] for c in CR])),
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
    v = values.astype(np.float64)
    distinct = v[1:] > v[:-1] + FEATURE_THRESHOLD
    del v
    stump = _StumpFitter(values, order, onehot, distinct)
    for iboost in range(n_estimators):
        f, t, left, right = stump.fit(sw)
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


class WeightedAdaBoostCore(ClassifierMixin, TransformerMixin, BaseEstimator):
    """AdaBoost of decision stumps with the positive class weighted up (section 3.4).

    The tabular core of :class:`~tunnelsense.tunnel.WeightedAdaBoost`.  ``fit`` runs
    discrete AdaBoost (SAMME, :func:`samme`) of depth-1 Gini stumps with initial
    sample weights ``positive_weight`` for the ``pos_label`` class and 1 for the
    others (times ``sample_weight``).  It fits the stumps scikit-learn's
    :class:`~sklearn.ensemble.AdaBoostClassifier` with
    ``DecisionTreeClassifier(max_depth=1)`` fits on data without tied splits, and
    makes the same decisions, except that tied splits are broken by the lowest
    feature rather than at random and rows of zero weight are left out, so that
    integer weights equal repeated rows exactly.  ``predict`` and
    ``decision_function`` evaluate the stumps as arrays (:func:`stump_decision`);
    ``transform`` gives the decision function as one column (two classes) or one
    per class.

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
        The positive class; ``None`` is the greatest class label.

    Attributes
    ----------
    classes_ : ndarray of shape (n_classes,)
    n_features_in_ : int
    stump_features_, stump_thresholds_ : ndarray of shape (n_stumps,)
        Feature and threshold of every stump (``x[feature] <= threshold`` goes left).
    stump_classes_ : ndarray of shape (n_stumps, 2)
        Index into ``classes_`` predicted left and right of every stump.
    stump_weights_ : ndarray of shape (n_stumps,)
        Weight of every stump.
    stump_errors_ : ndarray of shape (n_stumps,)
        Weighted training error of every stump.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.tunnel._stumps import WeightedAdaBoostCore
    >>> rng = np.random.default_rng(0)
    >>> X = rng.dirichlet(np.ones(8), 300)
    >>> y = (X[:, 2] > 0.2).astype(int)
    >>> clf = WeightedAdaBoostCore(n_estimators=20).fit(X, y)
    >>> int(clf.stump_features_[0]), float((clf.predict(X) == y).mean()) > 0.95
    (2, True)
    """

    _parameter_constraints: dict = {
        "n_estimators": [Interval(numbers.Integral, 1, None, closed="left")],
        "learning_rate": [Interval(numbers.Real, 0, None, closed="neither")],
        "positive_weight": [Interval(numbers.Real, 0, None, closed="neither")],
        "pos_label": [numbers.Real, str, "boolean", None],
    }

    def __init__(self, *, n_estimators=50, learning_rate=1.0, positive_weight=7.0,
                 pos_label=None):
        self.n_estimators = n_estimators
        self.learning_rate = learning_rate
        self.positive_weight = positive_weight
        self.pos_label = pos_label

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
            stumps = (np.empty(0, np.intp),) * 4 + (np.empty(0),) * 2
        else:
            stumps = samme(
                X,
                np.searchsorted(classes, y),
                len(classes),
                sample_weight,
                n_estimators=self.n_estimators,
                learning_rate=self.learning_rate,
            )
        (
            self.stump_features_,
            self.stump_thresholds_,
            self._left,
            self._right,
            self.stump_weights_,
            self.stump_errors_,
        ) = stumps
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

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y, sample_weight=None):
        """Train the machine.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        y : array-like of shape (n_samples,)
            Class labels.
        sample_weight : array-like of shape (n_samples,), default=None
            Weights multiplied into the initial weights.

        Returns
        -------
        self : object
        """
        X, y = validate_data(self, X, y, dtype=[np.float64, np.float32])
        return self._fit_arrays(X, y, sample_weight, self.pos_label)

    def decision_function(self, X):
        """The SAMME decision function, as scikit-learn computes it.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)

        Returns
        -------
        decision : ndarray of shape (n_samples,) or (n_samples, n_classes)
            Two classes: > 0 means ``classes_[1]``.
        """
        check_is_fitted(self)
        X = validate_data(self, X, dtype=[np.float64, np.float32], reset=False)
        return self._decision(X)

    def predict(self, X):
        """Class of every row.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)

        Returns
        -------
        y : ndarray of shape (n_samples,)
        """
        check_is_fitted(self)
        X = validate_data(self, X, dtype=[np.float64, np.float32], reset=False)
        return self._predict_arrays(X)

    def transform(self, X):
        """The decision function as columns.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)

        Returns
        -------
        X_new : ndarray of shape (n_samples, 1 or n_classes)
        """
        check_is_fitted(self)
        X = validate_data(self, X, dtype=[np.float64, np.float32], reset=False)
        return self._decision(X).reshape(len(X), -1)
