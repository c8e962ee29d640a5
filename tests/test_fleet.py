"""Fleets: many tours detected at once, per-tour results equal to one-by-one runs."""

import filecmp
import hashlib
import os
import shutil

import pytest

from tunnelsense import make_indicator_pipeline, make_parking_pipeline, to_xy
from tunnelsense.datasets import make_street_scans, make_tunnel_tour
from tunnelsense.fleet import detect_one, detect_tours, read_tour_list, tour_outputs
from tunnelsense.fleet._runners import _KILL_WORKER
from tunnelsense.io import write_run, write_tour
from tunnelsense.street import write_objects
from tunnelsense.tunnel import detect_to_files


@pytest.fixture(scope="module")
def tunnel_model():
    tour = make_tunnel_tour(120, random_state=0, first_indicator_m=20.0)
    X, y, _ = to_xy(tour)
    return make_indicator_pipeline(random_state=0).fit(X, y)


@pytest.fixture(scope="module")
def tours(tmp_path_factory):
    root = tmp_path_factory.mktemp("fleet")
    return [write_tour(make_tunnel_tour(8, random_state=seed, first_indicator_m=12.0,
                                        name=f"t{seed:02d}"), root / f"t{seed:02d}")
            for seed in range(20)]


@pytest.fixture(scope="module")
def one_by_one(tunnel_model, tours, tmp_path_factory):
    """Each tour's results as a single ``detect_to_files`` writes them."""
    root = tmp_path_factory.mktemp("single")
    for tour in tours:
        detect_to_files(tunnel_model, tour, root / f"{tour.name}.txt")
    return root


def _visible(folder):
    return sorted(p.name for p in folder.iterdir() if not p.name.startswith("."))


def _same_as_one_by_one(out, reference, tours):
    for tour in tours:
        for path in tour_outputs("tunnel", tour, out):
            assert filecmp.cmp(path, reference / path.name, shallow=False), path


def test_a_local_fleet_equals_one_by_one_runs(tunnel_model, tours, one_by_one,
                                              tmp_path):
    seen = []
    done = detect_tours(tunnel_model, tours[:6], tmp_path / "out",
                        progress=lambda n, total: seen.append((n, total)))
    assert [d["skipped"] for d in done] == [False] * 6
    assert seen[0] == (0, 6) and seen[-1] == (6, 6)
    _same_as_one_by_one(tmp_path / "out", one_by_one, tours[:6])
    assert _visible(tmp_path / "out") == sorted(
        p.name for t in tours[:6] for p in tour_outputs("tunnel", t, tmp_path))


def test_a_stopped_fleet_resumes_without_redoing_finished_tours(
        tunnel_model, tours, one_by_one, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    finished = tours[:3]
    for tour in finished:  # as a run killed after three tours left them
        for path in tour_outputs("tunnel", tour, out):
            path.write_text("kept: finished before\n")
        results = tour_outputs("tunnel", tour, out)[0]
        digest = hashlib.sha256(results.read_bytes()).hexdigest()
        (out / f".finished-{results.name}").write_text(digest + "\n")
    partial = out / f".partial-{tours[3].name}.txt"  # and the fourth under way
    partial.mkdir()
    (partial / f"{tours[3].name}.txt").write_text("1,2,3\n")
    done = detect_tours(tunnel_model, tours[:6], out)
    assert [d["skipped"] for d in done] == [True] * 3 + [False] * 3
    for tour in finished:
        for path in tour_outputs("tunnel", tour, out):
            assert path.read_text() == "kept: finished before\n"
    _same_as_one_by_one(out, one_by_one, tours[3:6])
    assert not partial.exists()


def test_a_fleet_never_replaces_a_file_it_did_not_finish(tunnel_model, tours,
                                                         tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    results, clusters = tour_outputs("tunnel", tours[0], out)
    # no results file: the tour is not done; a companion that differs from the one
    # this run writes is not this fleet's (an identical one would be taken)
    clusters.write_text("someone else's\n")
    with pytest.raises(FileExistsError, match="not replaced"):
        detect_one(tunnel_model, "tunnel", tours[0], out)
    assert clusters.read_text() == "someone else's\n"
    assert not results.exists()
    assert [p.name for p in out.iterdir()] == [clusters.name]  # no partial left


def test_a_results_file_no_fleet_finished_is_reported_not_skipped(
        tunnel_model, tours, one_by_one, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    results = tour_outputs("tunnel", tours[0], out)[0]
    results.write_text("1,1,0,0,4,8,0.9,-1,-1,-1\n")  # a single run stopped midway
    first = detect_tours(tunnel_model, tours[:2], out)
    assert not first[0]["skipped"] and "no fleet finished it" in first[0]["error"]
    assert results.read_text() == "1,1,0,0,4,8,0.9,-1,-1,-1\n"
    assert first[1]["error"] is None
    again = detect_tours(tunnel_model, tours[:2], out)  # the finished one: skipped
    assert [d["skipped"] for d in again] == [False, True]
    detect_tours(tunnel_model, tours[:1], out, overwrite=True)
    assert [d["skipped"] for d in detect_tours(tunnel_model, tours[:2], out)] == [
        True, True]
    _same_as_one_by_one(out, one_by_one, tours[:2])


def test_a_tour_killed_before_its_results_file_was_linked_resumes(
        tunnel_model, tours, one_by_one, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    clusters = tour_outputs("tunnel", tours[0], out)[1]
    # killed between the two links: the companion is there, the results file not
    shutil.copyfile(one_by_one / clusters.name, clusters)
    (done,) = detect_tours(tunnel_model, tours[:1], out)
    assert not done["skipped"]
    _same_as_one_by_one(out, one_by_one, tours[:1])
    assert len(_visible(out)) == 2


def test_a_finished_tour_is_on_disk_before_it_is_linked(tunnel_model, tours,
                                                       tmp_path, monkeypatch):
    synced = []
    real = os.fsync

    def fsync(fd):
        synced.append(os.fstat(fd).st_ino)
        real(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    out = tmp_path / "out"
    out.mkdir()
    detect_one(tunnel_model, "tunnel", tours[0], out)
    for path in (*tour_outputs("tunnel", tours[0], out), out):
        assert path.stat().st_ino in synced, path


def test_overwrite_detects_finished_tours_again(tunnel_model, tours, one_by_one,
                                                tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    for path in tour_outputs("tunnel", tours[0], out):
        path.write_text("old\n")
    (done,) = detect_tours(tunnel_model, tours[:1], out, overwrite=True)
    assert not done["skipped"]
    _same_as_one_by_one(out, one_by_one, tours[:1])


def test_street_fleet_equals_one_by_one_runs(tmp_path):
    from tunnelsense.io import open_run_stream

    X, y, _ = to_xy(make_street_scans(600, random_state=0))
    model = make_parking_pipeline().fit(X, y)
    runs = [write_run(make_street_scans(300, random_state=s, name=f"r{s}"),
                      tmp_path / f"r{s}") for s in (1, 2, 3)]
    detect_tours(model, runs, tmp_path / "out", kind="street")
    for run in runs:
        write_objects(model, open_run_stream(run), tmp_path / f"{run.name}-single.csv")
        assert filecmp.cmp(tmp_path / "out" / f"{run.name}.csv",
                           tmp_path / f"{run.name}-single.csv", shallow=False)


def test_bad_fleets_are_refused(tunnel_model, tours, tmp_path):
    with pytest.raises(ValueError, match="would both write"):
        detect_tours(tunnel_model, [tours[0], tmp_path / "x" / tours[0].name],
                     tmp_path / "out")
    with pytest.raises(FileNotFoundError, match="no such tour"):
        detect_tours(tunnel_model, [tmp_path / "missing"], tmp_path / "out")
    with pytest.raises(ValueError, match="kind"):
        detect_tours(tunnel_model, tours[:1], tmp_path / "out", kind="video")
    with pytest.raises(ValueError, match="n_jobs"):
        detect_tours(tunnel_model, tours[:1], tmp_path / "out", n_jobs=0)
    (tmp_path / "file").write_text("")
    with pytest.raises(ValueError, match="not a folder"):
        detect_tours(tunnel_model, tours[:1], tmp_path / "file")
    empty = tmp_path / "list.txt"
    empty.write_text("# nothing\n\n")
    with pytest.raises(ValueError, match="names no tour"):
        read_tour_list(empty)


@pytest.fixture(scope="module")
def bad_tour(tmp_path_factory):
    """A tour whose second frame is not a picture: its detection fails midway."""
    tour = write_tour(make_tunnel_tour(8, random_state=30, name="t30"),
                      tmp_path_factory.mktemp("bad") / "b30")
    (tour / "img1" / "000002.png").write_bytes(b"not a picture")
    return tour


def test_a_tour_that_fails_does_not_stop_the_others(tunnel_model, tours, bad_tour,
                                                    one_by_one, tmp_path):
    out = tmp_path / "out"
    done = detect_tours(tunnel_model, [tours[0], bad_tour, tours[1]], out)
    assert [d["error"] is None for d in done] == [True, False, True]
    assert done[1]["source"] == bad_tour and done[1]["error"]
    _same_as_one_by_one(out, one_by_one, [tours[0], tours[1]])
    assert not any(p.exists() for p in tour_outputs("tunnel", bad_tour, out))
    assert _visible(out) == sorted(
        p.name for t in tours[:2] for p in tour_outputs("tunnel", t, out))


def test_a_detection_that_fails_before_its_first_frame_leaves_no_results_file(
        tunnel_model, tours, tmp_path):
    """A results file under its final name marks a finished tour: one that cannot
    start (here --draw names a file, not a folder) must not leave an empty one."""
    (tmp_path / "pictures").write_text("a file\n")
    out = tmp_path / "t.txt"
    with pytest.raises(OSError):
        detect_to_files(tunnel_model, tours[0], out, draw=tmp_path / "pictures")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pictures"]


def test_tour_names_keep_a_folder_s_dots_and_name_the_current_folder(tmp_path,
                                                                     monkeypatch):
    for day in ("2024.03.01", "2024.03.02"):
        (tmp_path / day).mkdir()
    (tmp_path / "r7.bag").write_bytes(b"")
    names = [tour_outputs("tunnel", tmp_path / d, "out")[0].name
             for d in ("2024.03.01", "2024.03.02")]
    assert names == ["2024.03.01.txt", "2024.03.02.txt"]
    assert tour_outputs("street", tmp_path / "r7.bag", "out")[0].name == "r7.csv"
    monkeypatch.chdir(tmp_path / "2024.03.01")
    assert tour_outputs("tunnel", ".", "out")[0].name == "2024.03.01.txt"
    with pytest.raises(ValueError, match="needs a name"):
        tour_outputs("tunnel", "/", "out")


def _killing(name):
    """Fleet options under which the worker process detecting tour ``name`` dies
    (SIGKILL, as a segmentation fault or the out-of-memory killer ends it)."""
    return {_KILL_WORKER: (name,)}


def test_a_worker_killed_hard_does_not_stop_the_fleet(tunnel_model, tours, one_by_one,
                                                      tmp_path):
    out = tmp_path / "out"
    fleet = tours[:6]
    done = detect_tours(tunnel_model, fleet, out, n_jobs=2,
                        options=_killing(fleet[2].name))
    assert [d["error"] is None for d in done] == [True, True, False, True, True, True]
    assert done[2]["source"] == fleet[2]
    assert "worker process detecting it died" in done[2]["error"]
    assert "TerminatedWorkerError" in done[2]["error"]
    others = [t for t in fleet if t != fleet[2]]
    _same_as_one_by_one(out, one_by_one, others)
    assert not any(p.exists() for p in tour_outputs("tunnel", fleet[2], out))
    # a new run detects the dead tour and skips the finished ones, in new workers
    again = detect_tours(tunnel_model, fleet, out, n_jobs=2)
    assert [d["skipped"] for d in again] == [True, True, False, True, True, True]
    assert all(d["error"] is None for d in again)
    _same_as_one_by_one(out, one_by_one, fleet)


def test_joblib_parallel_works_after_a_fleet_in_the_same_process(tunnel_model, tours,
                                                                 tmp_path):
    """The fleet's worker processes are its own: joblib's process pool (a grid
    search's) still works after a fleet ran in the same process (it failed, an
    internal error, when the fleet had taken loky's shared executor)."""
    from joblib import Parallel, delayed

    done = detect_tours(tunnel_model, tours[:2], tmp_path / "out", n_jobs=2)
    assert all(d["error"] is None for d in done)
    assert Parallel(n_jobs=2, backend="loky")(
        delayed(abs)(-k) for k in range(3)) == [0, 1, 2]
