"""GridSearchCV of the indicator pipeline runs unchanged on a Dask cluster."""

import joblib
import pytest
from sklearn.model_selection import GridSearchCV, GroupKFold

from tunnelsense import make_indicator_pipeline, to_xy
from tunnelsense._cli import main
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.io import describe_model, load_model, open_tour, write_tour
from tunnelsense.metrics import make_tunnel_scorer

distributed = pytest.importorskip("distributed")  # the optional 'distributed' extra

pytestmark = pytest.mark.slow


GRID = {"motion__min_r": [0.5, 0.97]}
#: few k-means steps: the test is where the fits run, not how good they are
FAST = {"verifier__n_steps": 10, "verifier__max_full_samples": 1}


@pytest.fixture(scope="module")
def tours(tmp_path_factory):
    root = tmp_path_factory.mktemp("dask")
    folders = [
        write_tour(make_tunnel_tour(100, random_state=seed, first_indicator_m=30.0,
                                    name=f"tour-{seed}"), root / f"tour-{seed}")
        for seed in (0, 1, 2)
    ]
    return folders


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as c:  # any free port
        yield c


def _search():
    return GridSearchCV(make_indicator_pipeline(random_state=0, **FAST), GRID,
                        cv=GroupKFold(n_splits=3), scoring=make_tunnel_scorer(),
                        error_score="raise")


def test_grid_search_on_a_local_dask_cluster_equals_the_local_run(tours, cluster):
    # frames are read lazily from the files, so only paths travel to the workers
    X, y, groups = to_xy([open_tour(f) for f in tours])
    local = _search().fit(X, y, groups=groups)
    with distributed.Client(cluster), joblib.parallel_config(backend="dask"):
        remote = _search().fit(X, y, groups=groups)
    assert remote.best_params_ == local.best_params_
    assert list(remote.cv_results_["mean_test_score"]) == list(
        local.cv_results_["mean_test_score"]
    )


def test_train_search_on_a_dask_scheduler(cluster, tmp_path, capsys):
    tours = [  # short tours: k-means of few rows is exact and quick
        str(write_tour(make_tunnel_tour(60, random_state=seed, first_indicator_m=20.0,
                                        name=f"short-{seed}"), tmp_path / f"s{seed}"))
        for seed in (5, 6)
    ]
    model = tmp_path / "m.skops"
    argv = ["train", "tunnel", *tours, "--model", str(model), "--search"]
    assert main([*argv, "--dask-scheduler", cluster.scheduler_address]) == 0
    # the progress names each stage and counts the search's fits as they end
    # (its bars stay in this process: they never travel to the workers)
    err = capsys.readouterr().err.replace("\r", "\n")
    assert "decoding frames: 100%" in err
    # 8 settings x 2 folds, a prefix fit per fold and the refit: 19 fits
    fits = "grid search (8 settings x 2 folds), fits"
    assert f"{fits}: 100%" in err and "19/19" in err
    done = [int(line.split("|")[2].split("/")[0]) for line in err.splitlines()
            if line.startswith(fits) and "|" in line]
    assert done == sorted(done) and done[-1] == 19 and len(set(done)) > 2
    local = tmp_path / "local.skops"
    assert main([*argv[:4], "--model", str(local), "--search", "--quiet",
                 "--jobs", "1"]) == 0
    assert capsys.readouterr().err == ""
    card, local_card = (describe_model(p)["summary"]["search"] for p in (model, local))
    assert card["best_parameters"] == local_card["best_parameters"]
    assert card["best_score"] == local_card["best_score"]
    a, b = load_model(model), load_model(local)
    assert a.get_params()["motion__min_r"] == b.get_params()["motion__min_r"]
    assert a.get_params()["appearance__positive_weight"] == b.get_params()[
        "appearance__positive_weight"]
