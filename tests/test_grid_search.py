"""A grid search over two tours of records through a small two-stage pipeline.

The stages are toys (the real ones live in tunnelsense.tunnel); the test is that
records, ragged per-frame ``y`` and tour groups survive ``GridSearchCV`` with
``GroupKFold``: folds arrive as plain lists, the refit gets the container itself.
"""

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.model_selection import GridSearchCV, GroupKFold
from sklearn.pipeline import Pipeline
from sklearn.utils.validation import check_is_fitted

from tunnelsense import FrameSequence, Tour, check_frames, to_xy


class BandCounter(TransformerMixin, BaseEstimator):
    """Per frame, the number of pixels in [low, high] (payload ``"count"``)."""

    def __init__(self, low=160, high=190):
        self.low = low
        self.high = high

    def fit(self, X, y=None):
        check_frames(X, y)
        self.fitted_ = True
        return self

    def transform(self, X):
        check_is_fitted(self)
        records, _ = check_frames(X)
        return FrameSequence(
            r.evolve(count=int(((r.image >= self.low) & (r.image <= self.high)).sum()))
            for r in records
        )


class PresenceDetector(BaseEstimator):
    """Says a frame shows an indicator when enough pixels were counted."""

    def __init__(self, min_count=1):
        self.min_count = min_count

    def fit(self, X, y):
        self.seen_tours_ = sorted({r.tour for r in check_frames(X, y)[0]})
        return self

    def predict(self, X):
        check_is_fitted(self)
        return np.array(
            [r.payload["count"] >= self.min_count for r in check_frames(X)[0]]
        )

    def score(self, X, y):
        records, y = check_frames(X, y)
        truth = np.array([len(b) > 0 for b in y])
        return float(np.mean(self.predict(records) == truth))


def _tour(name, rng, n=12):
    images = rng.integers(60, 120, (n, 20, 24), dtype=np.uint8)
    rows = []
    for f in range(0, n, 2):  # an indicator-like 4x6 patch in every other frame
        images[f, 5:11, 8:12] = 175
        rows.append([f + 1, 1, 8.0, 5.0, 4.0, 6.0, 1.0, 1, 1.0])
    images[1, 0:2, 0:2] = 170  # a small warm clutter patch (4 px)
    gt = pd.DataFrame(
        rows,
        columns=[
            "frame",
            "id",
            "bb_left",
            "bb_top",
            "bb_width",
            "bb_height",
            "conf",
            "class",
            "visibility",
        ],
    )
    return Tour.from_array(name, images, gt)


def test_grid_search_group_kfold_over_two_tours(global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    X, y, groups = to_xy([_tour("tour-a", rng), _tour("tour-b", rng)])
    pipe = Pipeline([("band", BandCounter()), ("detect", PresenceDetector())])
    search = GridSearchCV(
        pipe,
        {"band__low": [150, 160], "detect__min_count": [1, 10, 1000]},
        cv=GroupKFold(n_splits=2),
        error_score="raise",
    )
    search.fit(X, y, groups=groups)
    # each fold trained on exactly one tour: GroupKFold kept tours apart
    assert search.cv_results_["mean_test_score"].shape == (6,)
    assert search.best_params_["detect__min_count"] == 10
    assert search.best_score_ == 1.0
    # the refit saw both tours, through the container itself
    assert search.best_estimator_[-1].seen_tours_ == ["tour-a", "tour-b"]
    assert search.predict(X).tolist() == [len(b) > 0 for b in y]
