"""Grid search that fits the steps the grid does not vary once per fold.

:class:`PrefixGridSearch` gives what :class:`~sklearn.model_selection.GridSearchCV`
gives for a :class:`~sklearn.pipeline.Pipeline` -- the same folds, candidates, scores,
best parameters and refitted best estimator -- but the steps before the first one
the grid varies (for the indicator detector: keypoints, verifier and clusters, whose
k-means is most of the cost) are fitted once per fold, not once per candidate and
fold.  That is exact when those steps are deterministic (an integer
``random_state``), which the test suite checks against ``GridSearchCV``.
"""

from __future__ import annotations

import numpy as np
from joblib import Parallel, delayed
from sklearn.base import clone
from sklearn.model_selection import ParameterGrid
from sklearn.pipeline import Pipeline

__all__ = ["PrefixGridSearch"]


def _take(X, indices):
    """Rows of a record sequence or array (a list for sequences, as CV folds are)."""
    if hasattr(X, "shape"):
        return X[indices]
    return [X[int(i)] for i in indices]


def _fit_and_score(suffix, params, X_train, y_train, X_test, y_test, scoring):
    model = clone(suffix).set_params(**params)
    model.fit(X_train, y_train)
    return float(scoring(model, X_test, y_test))


class PrefixGridSearch:
    """Exhaustive search over ``param_grid`` that fits the unvaried prefix once a fold.

    Parameters
    ----------
    pipeline : Pipeline
        The (unfitted) pipeline; its prefix must be deterministic.
    param_grid : dict
        ``step__parameter`` lists, as for ``GridSearchCV``.
    cv : cross-validation splitter
        Called as ``cv.split(X, y, groups)``.
    scoring : callable
        ``scoring(estimator, X, y) -> float``, greater is better.
    n_jobs : int, default=1
        Parallel candidate fits (joblib; a Dask cluster through
        ``joblib.parallel_config(backend="dask")``).
    progress : callable or None, default=None
        ``progress(done, total)`` after each fit (prefix fits count as fits).

    Attributes
    ----------
    best_params_, best_score_, best_estimator_, cv_results_
        As ``GridSearchCV``'s (``cv_results_`` holds ``params``,
        ``split<k>_test_score`` and ``mean_test_score``).
    n_prefix_fits_ : int
        Prefix fits done (one per fold, plus the refit).
    """

    def __init__(self, pipeline, param_grid, *, cv, scoring, n_jobs=1, progress=None):
        self.pipeline = pipeline
        self.param_grid = param_grid
        self.cv = cv
        self.scoring = scoring
        self.n_jobs = n_jobs
        self.progress = progress

    def _split_point(self):
        names = [name for name, _ in self.pipeline.steps]
        varied = {key.split("__", 1)[0] for key in self.param_grid}
        unknown = varied - set(names)
        if unknown:
            raise ValueError(f"param_grid names steps not in the pipeline: {sorted(unknown)}")
        return min(names.index(v) for v in varied)

    def fit(self, X, y, groups=None):
        """Search the grid, then refit the best candidate on all of ``X``.

        Returns
        -------
        self : object
        """
        k = self._split_point()
        prefix_steps, suffix_steps = self.pipeline.steps[:k], self.pipeline.steps[k:]
        candidates = list(ParameterGrid(self.param_grid))
        folds = list(self.cv.split(X, y, groups))
        total = len(folds) * (len(candidates) + bool(prefix_steps)) + 1
        done = 0

        def tick(n=1):
            nonlocal done
            done += n
            if self.progress is not None:
                self.progress(done, total)

        suffix = Pipeline(suffix_steps)
        scores = np.empty((len(candidates), len(folds)))
        self.n_prefix_fits_ = 0
        for f, (train, test) in enumerate(folds):
            X_train, X_test = _take(X, train), _take(X, test)
            y_train, y_test = _take(y, train), _take(y, test)
            if prefix_steps:
                prefix = clone(Pipeline(prefix_steps))
                X_train = prefix.fit_transform(X_train, y_train)
                X_test = prefix.transform(X_test)
                self.n_prefix_fits_ += 1
                tick()
            jobs = (delayed(_fit_and_score)(suffix, params, X_train, y_train,
                                            X_test, y_test, self.scoring)
                    for params in candidates)
            for c, score in enumerate(Parallel(n_jobs=self.n_jobs, return_as="generator")(jobs)):
                scores[c, f] = score
                tick()
        mean = scores.mean(axis=1)
        best = int(np.argmax(mean))  # the first best, as GridSearchCV's rank 1
        self.cv_results_ = {
            "params": candidates,
            "mean_test_score": mean,
            **{f"split{f}_test_score": scores[:, f] for f in range(len(folds))},
        }
        self.best_index_ = best
        self.best_params_ = candidates[best]
        self.best_score_ = float(mean[best])
        self.best_estimator_ = clone(self.pipeline).set_params(**self.best_params_)
        self.best_estimator_.fit(X, y)
        self.n_prefix_fits_ += bool(prefix_steps)
        tick()
        return self
