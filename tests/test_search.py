"""PrefixGridSearch: GridSearchCV's result with the unvaried steps fitted once a fold."""

import numpy as np
import pytest
from sklearn.model_selection import GridSearchCV, GroupKFold

from tunnelsense import make_indicator_pipeline, to_xy
from tunnelsense._search import PrefixGridSearch
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.metrics import make_tunnel_scorer

GRID = {"appearance__positive_weight": [1.0, 7.0], "motion__min_r": [0.9, 0.99]}


@pytest.mark.slow
def test_prefix_search_equals_grid_search_cv():
    tours = [make_tunnel_tour(150, scenario=s, random_state=i, first_indicator_m=25.0)
             for i, s in enumerate(["light", "heavy"])]
    X, y, groups = to_xy(tours)
    kw = dict(cv=GroupKFold(n_splits=2), scoring=make_tunnel_scorer())
    ticks = []
    ours = PrefixGridSearch(make_indicator_pipeline(random_state=0), GRID,
                            progress=lambda d, t: ticks.append((d, t)), **kw).fit(X, y, groups)
    theirs = GridSearchCV(make_indicator_pipeline(random_state=0), GRID,
                          error_score="raise", **kw).fit(X, y, groups=groups)
    np.testing.assert_allclose(ours.cv_results_["mean_test_score"],
                               theirs.cv_results_["mean_test_score"], rtol=0, atol=1e-12)
    assert ours.best_params_ == theirs.best_params_
    # keypoints..clusters fitted once per fold and once for the refit, not per candidate
    assert ours.n_prefix_fits_ == 3
    # the progress counts every fit: 2 prefix + 2 x 4 candidates + the refit
    assert ticks[-1] == (11, 11) and [d for d, _ in ticks] == list(range(1, 12))
    got = ours.best_estimator_.predict(X)
    want = theirs.best_estimator_.predict(X)
    assert [r.payload["detections"].tolist() for r in got] == [
        r.payload["detections"].tolist() for r in want]


def test_prefix_search_refuses_a_grid_over_unknown_steps():
    search = PrefixGridSearch(make_indicator_pipeline(), {"nope__x": [1]},
                              cv=GroupKFold(2), scoring=make_tunnel_scorer())
    with pytest.raises(ValueError, match="nope"):
        search.fit([], [], [])


def test_train_search_fits_each_kmeans_once_per_fold(monkeypatch):
    # fit_indicator_detector(search=True) (train tunnel --search): the grid varies
    # only later steps, so the verifier's two k-means (positives, negatives) run
    # once per fold and once for the refit, never once per candidate
    from sklearn.model_selection import ParameterGrid

    import tunnelsense.tunnel._kmeans as kmeans
    from tunnelsense.tunnel import fit_indicator_detector
    from tunnelsense.tunnel._search_grid import SEARCH_GRID

    fits = []
    real = kmeans.fit_kmeans

    def counting(X, n_clusters, **kw):
        fits.append(n_clusters)
        return real(X, n_clusters, **kw)

    monkeypatch.setattr(kmeans, "fit_kmeans", counting)
    tours = [make_tunnel_tour(60, scenario=s, random_state=i, first_indicator_m=20.0)
             for i, s in enumerate(["light", "heavy"])]
    model, summary = fit_indicator_detector(tours, search=True, random_state=0)
    assert len(ParameterGrid(SEARCH_GRID)) > 1  # candidates that could refit it
    n_folds = 2
    assert fits == [40, 400] * (n_folds + 1)
    assert set(summary["search"]["best_parameters"]) == set(SEARCH_GRID)
