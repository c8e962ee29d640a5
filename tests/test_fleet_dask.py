"""A fleet of 20 tours on a 2-worker Dask LocalCluster, resumed after a stop."""

import filecmp

import pytest

from tunnelsense import make_indicator_pipeline, to_xy
from tunnelsense._cli import main
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.fleet import detect_tours, tour_outputs
from tunnelsense.io import save_model, write_tour
from tunnelsense.tunnel import detect_to_files

distributed = pytest.importorskip("distributed")  # the optional 'distributed' extra

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as c:  # any free port
        yield c


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    root = tmp_path_factory.mktemp("dask-fleet")
    tour = make_tunnel_tour(120, random_state=0, first_indicator_m=20.0)
    X, y, _ = to_xy(tour)
    model = make_indicator_pipeline(random_state=0).fit(X, y)
    tours = [write_tour(make_tunnel_tour(8, random_state=seed, first_indicator_m=12.0,
                                         name=f"t{seed:02d}"), root / f"t{seed:02d}")
             for seed in range(20)]
    single = root / "single"
    single.mkdir()
    for t in tours:
        detect_to_files(model, t, single / f"{t.name}.txt")
    return model, tours, single


def _check(out, single, tours):
    for tour in tours:
        for path in tour_outputs("tunnel", tour, out):
            assert filecmp.cmp(path, single / path.name, shallow=False), path


def test_twenty_tours_on_a_local_cluster_equal_one_by_one_runs(fleet, cluster,
                                                                tmp_path):
    model, tours, single = fleet
    done = detect_tours(model, tours, tmp_path / "out",
                        dask_scheduler=cluster.scheduler_address)
    assert [d["skipped"] for d in done] == [False] * 20
    _check(tmp_path / "out", single, tours)


def test_a_stopped_cluster_run_resumes(fleet, cluster, tmp_path):
    model, tours, single = fleet
    out = tmp_path / "out"
    detect_tours(model, tours[:7], out)  # the tours a stopped run had finished
    stamps = {p: p.stat().st_mtime_ns for t in tours[:7]
              for p in tour_outputs("tunnel", t, out)}
    path = save_model(model, tmp_path / "tunnel.skops")
    assert main(["detect", "tunnel", "--model", str(path), *map(str, tours),
                 "--out", str(out), "--dask-scheduler", cluster.scheduler_address,
                 "--quiet"]) == 0
    assert {p: p.stat().st_mtime_ns for p in stamps} == stamps  # not redone
    _check(out, single, tours)


def test_a_killed_dask_worker_does_not_stop_the_fleet(fleet, cluster, tmp_path):
    """A tour whose worker dies (SIGKILL) every time the cluster tries it ends as
    KilledWorker: its error record names it, the other tours finish, and a new run
    detects it."""
    from tunnelsense.fleet._runners import _KILL_WORKER

    model, tours, single = fleet
    out = tmp_path / "out"
    done = detect_tours(model, tours[:5], out, dask_scheduler=cluster.scheduler_address,
                        options={_KILL_WORKER: (tours[1].name,)})
    assert [d["error"] is None for d in done] == [True, False, True, True, True], [
        d["error"] for d in done]
    assert done[1]["source"] == tours[1] and "KilledWorker" in done[1]["error"]
    _check(out, single, [t for t in tours[:5] if t != tours[1]])
    again = detect_tours(model, tours[:5], out, dask_scheduler=cluster.scheduler_address)
    assert [d["skipped"] for d in again] == [True, False, True, True, True]
    _check(out, single, tours[:5])
