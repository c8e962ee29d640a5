"""A missing optional extra, and Ctrl-C, end a command with one line and no work lost."""

import json
import signal
import subprocess
import sys
import time

import pytest

from tunnelsense._cli import main
from tunnelsense.datasets import make_street_scans
from tunnelsense.io import write_run

#: Runs the commands given as JSON with the optional extras missing: ``None`` in
#: ``sys.modules`` makes their import fail as if they were not installed.
_WITHOUT_EXTRAS = """
import contextlib, io, json, sys
for module in ("matplotlib", "rosbags", "distributed"):
    sys.modules[module] = None
from tunnelsense._cli import main
results = []
for argv in json.loads(sys.argv[1]):
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        status = main(argv)
    results.append([status, err.getvalue()])
print(json.dumps(results))
"""


@pytest.fixture(scope="module")
def street(tmp_path_factory):
    root = tmp_path_factory.mktemp("extras")
    run = write_run(make_street_scans(600, random_state=3, name="r"), root / "run")
    model = root / "m.skops"
    assert main(["train", "street", str(run), "--model", str(model)]) == 0
    bag = root / "run.bag"
    try:
        from tunnelsense.io import write_run_bag

        write_run_bag(make_street_scans(50, random_state=3), bag, version="ros1")
    except ImportError:  # without rosbags here, an empty .bag file stands in
        bag.write_bytes(b"")
    return {"root": root, "run": run, "model": model, "bag": bag}


def _without_extras(*commands):
    proc = subprocess.run([sys.executable, "-c", _WITHOUT_EXTRAS, json.dumps(commands)],
                          capture_output=True, text=True, timeout=300, check=True)
    return json.loads(proc.stdout)


def test_a_missing_extra_is_named_before_any_work(street):
    root, model = street["root"], str(street["model"])
    out, draw = root / "o.csv", root / "pictures"
    results = _without_extras(
        ["detect", "street", str(street["run"]), "--model", model, "--out", str(out),
         "--draw", str(draw), "--quiet"],
        ["evaluate", "position", str(root / "tour"), str(root / "pos.csv"),
         "--draw", str(root / "errors.png")],
        ["detect", "street", str(street["bag"]), "--model", model, "--out", str(out)],
        ["info", str(street["bag"])],
        ["train", "tunnel", str(root / "tour"), "--model", str(root / "t.skops"),
         "--search", "--dask-scheduler", "tcp://127.0.0.1:1"],
    )
    hints = ["pip install 'tunnelsense[plot]'", "pip install 'tunnelsense[plot]'",
             "pip install 'tunnelsense[rosbag]'", "pip install 'tunnelsense[rosbag]'",
             "pip install 'tunnelsense[distributed]'"]
    for (status, err), hint in zip(results, hints, strict=True):
        assert status == 1, err
        assert err.count("\n") == 1 and err.startswith("tunnelsense: error: "), err
        assert hint in err and "internal error" not in err
    # nothing was done: no object table, no pictures (the inputs of the position
    # and tunnel commands do not even exist: the check comes first)
    assert "--draw needs matplotlib" in results[0][1]
    assert not out.exists() and not draw.exists()
    assert "tour" not in results[1][1]


def test_survey_names_a_missing_extra_before_any_work(street):
    root, model = street["root"], str(street["model"])
    out, plot = root / "census.csv", root / "census.png"
    results = _without_extras(
        ["survey", "street", str(street["run"]), "--model", model, "--out", str(out),
         "--plot", str(plot), "--quiet"],
        ["survey", "street", str(street["bag"]), "--model", model, "--out", str(out)],
    )
    hints = ["pip install 'tunnelsense[plot]'", "pip install 'tunnelsense[rosbag]'"]
    for (status, err), hint in zip(results, hints, strict=True):
        assert status == 1, err
        assert err.count("\n") == 1 and hint in err, err
    assert "--plot needs matplotlib" in results[0][1]
    assert not out.exists() and not plot.exists()


def test_an_import_error_of_an_extra_deep_inside_is_a_hint(monkeypatch, capsys):
    from tunnelsense.cli import info

    def needs_matplotlib(args):
        raise ModuleNotFoundError("No module named 'matplotlib'", name="matplotlib")

    monkeypatch.setattr(info, "_cmd_info", needs_matplotlib)
    monkeypatch.setattr(info, "register_top", _registering(info, needs_matplotlib))
    assert main(["info", "x"]) == 1
    err = capsys.readouterr().err
    assert err == ("tunnelsense: error: this needs matplotlib: pip install "
                   "'tunnelsense[plot]'\n")


def _registering(module, func):
    original = module.register_top

    def register_top(sub):
        original(sub)
        sub.choices["info"].set_defaults(func=func)

    return register_top


def test_ctrl_c_during_start_up_imports_is_one_line(monkeypatch, capsys):
    import tunnelsense.cli

    def interrupted(name):
        raise KeyboardInterrupt

    monkeypatch.setattr(tunnelsense.cli.importlib, "import_module", interrupted)
    assert main(["info", "x"]) == 130
    assert capsys.readouterr().err == "tunnelsense: interrupted\n"


@pytest.mark.slow
def test_ctrl_c_during_work_is_one_line(tmp_path):
    """A real SIGINT while a tour is simulated: exit 130, one line, no traceback."""
    import threading

    err = []
    # a child inherits an ignored SIGINT (a background job of a script, or a test run
    # that ignores it); a Python handler in this process becomes the default in it
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        proc = subprocess.Popen(
            [sys.executable, "-m", "tunnelsense.cli", "simulate", "tunnel",
             str(tmp_path / "t"), "--frames", "1500"],
            stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
        )
    finally:
        signal.signal(signal.SIGINT, previous)
    with proc:
        reader = threading.Thread(target=lambda: err.extend(iter(
            lambda: proc.stderr.read(1), "")), daemon=True)
        reader.start()
        deadline = time.monotonic() + 120
        while "rendering frames" not in "".join(err) and time.monotonic() < deadline:
            time.sleep(0.05)  # the work has begun when its progress bar shows
        assert proc.poll() is None, "".join(err)
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=120)
        reader.join(timeout=10)
    err = "".join(err)
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    assert err.rstrip().splitlines()[-1] == "tunnelsense: interrupted"
    assert [line for line in err.splitlines() if "tunnelsense:" in line] == [
        "tunnelsense: interrupted"]
    assert not (tmp_path / "t").exists()
