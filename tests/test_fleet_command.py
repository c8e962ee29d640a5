"""The fleet command (``detect tunnel`` of many tours, worker processes): per-tour
results equal to one-by-one runs, failures reported by tour, termination ends the
workers (see test_fleet.py for the library's fleets)."""

import contextlib
import filecmp
import os
import signal
import subprocess
import sys
import time

import pytest

from tunnelsense import make_indicator_pipeline, to_xy
from tunnelsense._cli import main
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.fleet import detect_tours, tour_outputs
from tunnelsense.fleet._runners import _KILL_WORKER
from tunnelsense.io import save_model, write_tour
from tunnelsense.tunnel import detect_to_files


@pytest.fixture(scope="module")
def tunnel_model():
    tour = make_tunnel_tour(120, random_state=0, first_indicator_m=20.0)
    X, y, _ = to_xy(tour)
    return make_indicator_pipeline(random_state=0).fit(X, y)


@pytest.fixture(scope="module")
def tours(tmp_path_factory):
    """The first 4 of test_fleet.py's tours (these tests use no more)."""
    root = tmp_path_factory.mktemp("fleet")
    return [write_tour(make_tunnel_tour(8, random_state=seed, first_indicator_m=12.0,
                                        name=f"t{seed:02d}"), root / f"t{seed:02d}")
            for seed in range(4)]


@pytest.fixture(scope="module")
def one_by_one(tunnel_model, tours, tmp_path_factory):
    """Each tour's results as a single ``detect_to_files`` writes them."""
    root = tmp_path_factory.mktemp("single")
    for tour in tours:
        detect_to_files(tunnel_model, tour, root / f"{tour.name}.txt")
    return root


def _same_as_one_by_one(out, reference, tours):
    for tour in tours:
        for path in tour_outputs("tunnel", tour, out):
            assert filecmp.cmp(path, reference / path.name, shallow=False), path


@pytest.fixture(scope="module")
def bad_tour(tmp_path_factory):
    """A tour whose second frame is not a picture: its detection fails midway."""
    tour = write_tour(make_tunnel_tour(8, random_state=30, name="t30"),
                      tmp_path_factory.mktemp("bad") / "b30")
    (tour / "img1" / "000002.png").write_bytes(b"not a picture")
    return tour


def _killing(name):
    """Fleet options under which the worker process detecting tour ``name`` dies
    (SIGKILL, as a segmentation fault or the out-of-memory killer ends it)."""
    return {_KILL_WORKER: (name,)}


def test_fleet_command_with_two_processes_finishes(tunnel_model, tours, one_by_one,
                                                   tmp_path):
    """--jobs 2 runs worker processes; a worker that hangs (as loky's restart of a
    worker whose memory grew with lazy imports once did) fails here, by timeout."""
    model = save_model(tunnel_model, tmp_path / "tunnel.skops")
    listed = tmp_path / "tours.txt"
    listed.write_text("".join(f"{t}\n" for t in tours[1:4]))
    command = [sys.executable, "-m", "tunnelsense._cli", "detect", "tunnel", "--model",
               str(model), str(tours[0]), "--tours-from", str(listed), "--out",
               str(tmp_path / "out"), "--jobs", "2", "--quiet"]
    done = _run_command(command)
    assert done.returncode == 0, done.stderr
    assert "4 tours into" in done.stdout and "4 detected, 0 skipped" in done.stdout
    _same_as_one_by_one(tmp_path / "out", one_by_one, tours[:4])
    again = _run_command(command)
    assert "0 detected, 4 skipped" in again.stdout, again.stderr


def _run_command(command):
    """Run the command in its own process group, all of it killed on a timeout."""
    child = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True, start_new_session=True)
    try:
        stdout, stderr = child.communicate(timeout=600)
    except subprocess.TimeoutExpired:
        os.killpg(child.pid, signal.SIGKILL)
        child.communicate()
        raise
    return subprocess.CompletedProcess(command, child.returncode, stdout, stderr)


def test_fleet_command_reports_each_failed_tour_by_its_path(
        tunnel_model, tours, bad_tour, one_by_one, tmp_path):
    model = save_model(tunnel_model, tmp_path / "tunnel.skops")
    command = [sys.executable, "-m", "tunnelsense._cli", "detect", "tunnel", "--model",
               str(model), str(tours[0]), str(bad_tour), str(tours[1]), str(tours[2]),
               "--out", str(tmp_path / "out"), "--jobs", "2", "--quiet"]
    done = _run_command(command)
    assert done.returncode == 1, done.stderr
    assert "3 detected, 0 skipped, 1 failed" in done.stdout, done.stdout
    errors = done.stderr.strip().splitlines()
    assert len(errors) == 1 and errors[0].startswith(f"tunnelsense: error: {bad_tour}:")
    _same_as_one_by_one(tmp_path / "out", one_by_one, tours[:3])
    assert not list((tmp_path / "out").glob(".partial-*"))
    again = _run_command(command)
    assert again.returncode == 1
    assert "0 detected, 3 skipped, 1 failed" in again.stdout, again.stdout


def test_a_terminated_fleet_command_ends_its_workers(tunnel_model, tmp_path):
    """SIGTERM to the command alone (as a job scheduler sends it) ends its worker
    processes too; they were left running, orphaned, holding its output pipes."""
    tours = [write_tour(make_tunnel_tour(200, random_state=s, name=f"long{s}"),
                        tmp_path / f"long{s}") for s in (1, 2)]
    model = save_model(tunnel_model, tmp_path / "tunnel.skops")
    out = tmp_path / "out"
    command = [sys.executable, "-m", "tunnelsense._cli", "detect", "tunnel", "--model",
               str(model), *map(str, tours), "--out", str(out), "--jobs", "2",
               "--quiet"]
    with open(tmp_path / "stderr", "w") as stderr:
        child = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=stderr,
                                 start_new_session=True)
    try:
        while child.poll() is None and not list(out.glob(".partial-*")):
            time.sleep(0.02)  # until a worker is detecting a tour
        assert child.poll() is None, (tmp_path / "stderr").read_text()
        child.send_signal(signal.SIGTERM)
        assert child.wait(timeout=120) == 143
        # loky's resource tracker, a process of its own, may warn on its way out
        # that a semaphore of the killed workers is already gone (a race in loky,
        # seen on some runs): its lines are not the command's
        # (each warning: its header line, then the indented source line)
        lines = (tmp_path / "stderr").read_text().splitlines()
        ours = [s for k, s in enumerate(lines) if "resource_tracker" not in s and not (
            s.startswith(" ") and k and "resource_tracker" in lines[k - 1])]
        assert ours == ["tunnelsense: terminated"], lines
        for _ in range(600):  # the process group empties: no worker left behind
            try:
                os.killpg(child.pid, 0)
            except ProcessLookupError:
                break
            time.sleep(0.1)
        else:
            pytest.fail("worker processes outlived the terminated command")
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(child.pid, signal.SIGKILL)
    assert not any(p.exists() for t in tours for p in tour_outputs("tunnel", t, out))


def test_fleet_command_refusals(tunnel_model, tours, tmp_path):
    from tunnelsense._cli import main

    model = save_model(tunnel_model, tmp_path / "tunnel.skops")
    base = ["detect", "tunnel", "--model", str(model), str(tours[0]), str(tours[1])]
    assert main([*base, "--out", str(tmp_path / "o"), "--resume"]) == 1
    assert main([*base, "--out", str(tmp_path / "o"), "--draw", str(tmp_path / "d")]) == 1
    (tmp_path / "file.txt").write_text("")
    assert main([*base, "--out", str(tmp_path / "file.txt")]) == 1
    assert main(["detect", "tunnel", "--model", str(model), "--out",
                 str(tmp_path / "o")]) == 1
    assert main(["detect", "tunnel", "--model", str(model), str(tours[0]), "--out",
                 str(tmp_path / "o.txt"), "--dask-scheduler", "tcp://x:1"]) == 1
    assert not (tmp_path / "o").exists()


def test_fleet_command_names_jobs_when_it_is_not_a_count(tunnel_model, tours,
                                                         tmp_path, capsys):
    from tunnelsense._cli import main

    model = save_model(tunnel_model, tmp_path / "tunnel.skops")
    assert main(["detect", "tunnel", "--model", str(model), str(tours[0]),
                 str(tours[1]), "--out", str(tmp_path / "o"), "--jobs", "0"]) == 1
    assert capsys.readouterr().err.startswith("tunnelsense: error: --jobs: expected")
    assert not (tmp_path / "o").exists()


def test_fleet_command_exits_1_naming_the_tour_whose_worker_died(
        tunnel_model, tours, one_by_one, tmp_path, monkeypatch, capsys):
    import tunnelsense.fleet

    def detect_killing(*args, **kwargs):
        kwargs["options"] = {**(kwargs.get("options") or {}), **_killing(tours[0].name)}
        return detect_tours(*args, **kwargs)

    monkeypatch.setattr(tunnelsense.fleet, "detect_tours", detect_killing)
    model = save_model(tunnel_model, tmp_path / "tunnel.skops")
    out = tmp_path / "out"
    args = ["detect", "tunnel", "--model", str(model), *map(str, tours[:3]),
            "--out", str(out), "--jobs", "2", "--quiet"]
    assert main(args) == 1
    captured = capsys.readouterr()
    assert "2 detected, 0 skipped, 1 failed" in captured.out
    errors = captured.err.strip().splitlines()
    assert len(errors) == 1
    assert errors[0].startswith(f"tunnelsense: error: {tours[0]}: the worker process")
    _same_as_one_by_one(out, one_by_one, tours[1:3])
    monkeypatch.undo()
    assert main(args) == 0
    assert "1 detected, 2 skipped, 0 failed" in capsys.readouterr().out
    _same_as_one_by_one(out, one_by_one, tours[:3])
