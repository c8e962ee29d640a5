import argparse
import json

import numpy as np
import pandas as pd
import pytest

from tunnelsense import LaserGeometry, Run, Tour, __version__
from tunnelsense._cli import main
from tunnelsense.cli import build_parser
from tunnelsense.io import write_run, write_tour


def test_version_and_help(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"tunnelsense {__version__}"
    assert main([]) == 0
    assert "info" in capsys.readouterr().out


def test_info_on_tour_and_run(tmp_path, capsys):
    gt = pd.DataFrame(
        {
            "frame": [1, 2, 2],
            "id": [1, 1, 2],
            "bb_left": 1.0,
            "bb_top": 1.0,
            "bb_width": 2.0,
            "bb_height": 3.0,
            "conf": 1.0,
            "class": [1, 1, 2],
            "visibility": 1.0,
        }
    )
    write_tour(Tour.from_array("t", np.zeros((3, 8, 10), np.uint8), gt), tmp_path / "t")
    assert main(["info", str(tmp_path / "t"), "--json"]) == 0
    facts = json.loads(capsys.readouterr().out)
    assert facts["kind"] == "tunnel" and facts["frames"] == 3
    assert facts["objects"] == {"indicator": 1, "lamp": 1}
    assert (facts["width"], facts["height"], facts["frame_rate"]) == (10, 8, 30.0)
    assert main(["info", str(tmp_path / "t")]) == 0
    assert "3 frames of 10x8 px" in capsys.readouterr().out

    g = LaserGeometry(-1.4, 0.0087, 0.05, 8.191, 2.0)
    rgt = pd.DataFrame(
        {
            "id": [1, 2, 3],
            "first_scan": [0, 1, 2],
            "last_scan": [1, 3, 3],
            "label": ["parked", "parked", "passing"],
        }
    )
    write_run(
        Run.from_arrays("r", np.ones((4, 6)), np.arange(4) / 75, g, rgt), tmp_path / "r"
    )
    assert main(["info", str(tmp_path / "r"), "--json"]) == 0
    facts = json.loads(capsys.readouterr().out)
    assert facts["kind"] == "street" and facts["scans"] == 4 and facts["beams"] == 6
    assert facts["objects"] == {"parked": 2, "passing": 1}
    assert facts["scan_rate"] == pytest.approx(75.0)


def test_info_on_missing_source_is_a_clear_error(tmp_path, capsys):
    assert main(["info", str(tmp_path / "nope")]) == 1
    err = capsys.readouterr().err
    assert err.startswith("tunnelsense: error:") and "nope: not found" in err


def test_simulate_then_info(tmp_path, capsys):
    assert (
        main(
            ["simulate", "tunnel", str(tmp_path / "t"), "--frames", "12", "--seed", "3"]
        )
        == 0
    )
    out = capsys.readouterr()
    assert out.out.startswith(
        f"wrote {tmp_path / 't'}: 12 frames, scenario light, seed 3"
    )
    assert "rendering frames: 100%" in out.err and "12/12" in out.err
    assert "writing frames: 100%" in out.err
    assert main(["info", str(tmp_path / "t"), "--json"]) == 0
    facts = json.loads(capsys.readouterr().out)
    assert facts["kind"] == "tunnel" and facts["frames"] == 12
    assert (facts["width"], facts["height"]) == (640, 480)
    assert facts["info"]["scenario"] == "light" and facts["info"]["seed"] == 3

    assert (
        main(
            [
                "simulate",
                "street",
                str(tmp_path / "s"),
                "--scans",
                "300",
                "--scenario",
                "dense",
            ]
        )
        == 0
    )
    summary = capsys.readouterr().out
    assert main(["info", str(tmp_path / "s"), "--json"]) == 0
    facts = json.loads(capsys.readouterr().out)
    assert facts["kind"] == "street" and facts["scans"] == 300
    assert facts["info"]["scenario"] == "dense"
    parked = facts["objects"].get("parked", 0)
    assert f"{parked} parked" in summary


def test_info_is_concise_unless_verbose(tmp_path, capsys):
    import re

    from tunnelsense.datasets import make_street_scans

    run = make_street_scans(3000, random_state=0, name="s")
    n_vehicles = len(run.info["vehicles"])
    assert n_vehicles >= 20
    write_run(run, tmp_path / "s")
    assert main(["info", str(tmp_path / "s")]) == 0
    lines = capsys.readouterr().out.splitlines()
    # a screenful: the headline, the objects, the geometry and the run's scalars
    assert len(lines) <= 40
    assert f"    vehicles: {n_vehicles} entries (--verbose lists them)" in lines
    assert lines[0].startswith("s: laser run, 3000 scans of 241 beams, 75 scans/s")
    text = "\n".join(lines[1:])
    for fact in ("scans", "beams", "scan_rate", "mount_height"):  # in the headline
        assert not re.search(rf"^  {fact}:", text, re.M), fact
    assert not re.search(r"\d\.\d{5,}", text)  # no float printed to 12 decimals
    assert "speed_kmh_mean: 40.04" in text
    assert main(["info", str(tmp_path / "s"), "--verbose"]) == 0
    verbose = capsys.readouterr().out.splitlines()
    assert sum(line.lstrip().startswith("- ") for line in verbose) == n_vehicles


def test_simulate_rejects_unknown_scenario(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "street", str(tmp_path / "x"), "--scenario", "moon"])
    assert exc.value.code == 2
    assert "invalid choice: 'moon'" in capsys.readouterr().err


@pytest.mark.parametrize("verb", ["train", "detect", "evaluate"])
@pytest.mark.parametrize("kind", ["tunnel", "street"])
def test_method_commands_are_registered(verb, kind, capsys):
    with pytest.raises(SystemExit) as exc:
        main([verb, kind, "--help"])
    assert exc.value.code == 0
    assert f"tunnelsense {verb} {kind}" in capsys.readouterr().out


def test_info_into_a_closed_pipe_is_not_an_error(tmp_path):
    import subprocess
    import sys

    g = LaserGeometry(-1.4, 0.0087, 0.05, 8.191, 2.0)
    write_run(
        Run.from_arrays("r", np.ones((4, 6)), np.arange(4) / 75, g), tmp_path / "r"
    )
    code = "import sys; from tunnelsense._cli import main; sys.exit(main(sys.argv[1:]))"
    proc = subprocess.run(
        f"{sys.executable} -c '{code}' info {tmp_path / 'r'} --json | head -c 1",
        shell=True,
        capture_output=True,
        text=True,
        executable="/bin/bash",
        env={"PATH": "/usr/bin:/bin", "PYTHONUNBUFFERED": "0"},
    )
    assert proc.stdout == "{"
    assert "error" not in proc.stderr


def test_cli_models_are_checked_for_their_detector(tmp_path, capsys):
    from sklearn.pipeline import Pipeline
    from sklearn.preprocessing import StandardScaler

    from tunnelsense.io import save_model
    from tunnelsense.io._trust import load_trusted_model

    other = Pipeline([("scale", StandardScaler())]).fit([[0.0], [1.0]])
    save_model(other, tmp_path / "m.skops")
    with pytest.raises(
        ValueError, match="not a model written by 'tunnelsense train street'"
    ):
        load_trusted_model(
            tmp_path / "m.skops", last_step="cluster", command="train street"
        )
    save_model(other, tmp_path / "m.joblib")
    from tunnelsense.exceptions import UntrustedModelError

    with pytest.raises(UntrustedModelError, match="pass --trust-pickle"):
        load_trusted_model(tmp_path / "m.joblib", last_step="scale", command="x")
    assert (
        load_trusted_model(
            tmp_path / "m.joblib", last_step="scale", command="x", trust_pickle=True
        )
        is not None
    )
    err = capsys.readouterr().err
    assert "--trust-pickle" in err and "can run any code" in err
    with pytest.raises(FileNotFoundError, match="model file not found"):
        load_trusted_model(tmp_path / "none.skops", last_step="cluster", command="x")


def test_unexpected_errors_are_one_line(monkeypatch, capsys):
    import tunnelsense.cli.info as cli

    def broken(args):
        raise KeyError("oops")

    monkeypatch.setattr(cli, "_cmd_info", broken)
    monkeypatch.delenv("TUNNELSENSE_DEBUG", raising=False)
    assert main(["info", "x"]) == 3
    err = capsys.readouterr().err
    assert err.startswith("tunnelsense: internal error: KeyError: 'oops'")
    assert "Traceback" not in err
    monkeypatch.setenv("TUNNELSENSE_DEBUG", "1")
    with pytest.raises(KeyError):
        main(["info", "x"])


def test_demo_with_too_few_frames_says_so(capsys):
    assert main(["demo", "--frames", "5"]) == 1
    assert "--frames 5 is too short" in capsys.readouterr().err


def _actions(parser, path=()):
    """Every argument of every command, and every command, with its command path."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for choice in action._choices_actions:
                yield (*path, choice.dest), choice
            for name, sub in action.choices.items():
                yield from _actions(sub, (*path, name))
        elif not isinstance(action, argparse._HelpAction):
            yield path, action


def test_every_command_and_argument_has_help():
    actions = list(_actions(build_parser()))
    assert len(actions) > 60  # every command was walked
    missing = [(" ".join(p), a.dest) for p, a in actions if not a.help]
    assert missing == []


def test_info_help_mentions_model_files(capsys):
    with pytest.raises(SystemExit):
        main(["info", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "model file (.skops, .joblib)" in text and "never loaded" in text


def test_info_prints_one_fact_per_line_and_json_numbers(tmp_path, capsys):
    tour = Tour.from_array("t", np.zeros((2, 8, 10), np.uint8),
                           info={"seed": "7", "rate": "2.5", "site": "A9"})
    write_tour(tour, tmp_path / "t")
    assert main(["info", str(tmp_path / "t"), "--json"]) == 0
    facts = json.loads(capsys.readouterr().out)
    assert facts["info"] == {"seed": 7, "rate": 2.5, "site": "A9"}
    assert main(["info", str(tmp_path / "t")]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert not any("{" in line for line in lines)  # no dict on one line
    assert "  info:" in lines and "    seed: 7" in lines and "    site: A9" in lines


@pytest.mark.parametrize("kind", ["tunnel", "street"])
def test_simulate_never_writes_over_a_folder_without_force(kind, tmp_path, capsys):
    out = tmp_path / "data"
    out.mkdir()
    (out / "mine.txt").write_text("keep me")
    size = ["--frames", "3"] if kind == "tunnel" else ["--scans", "50"]
    assert main(["simulate", kind, str(out), *size]) == 1
    assert "pass --force" in capsys.readouterr().err
    assert [p.name for p in out.iterdir()] == ["mine.txt"]
    assert main(["simulate", kind, str(out / "mine.txt"), *size]) == 1  # a file
    assert main(["simulate", kind, str(out), *size, "--force"]) == 0
    assert len(list(out.iterdir())) > 1


def test_demo_help_describes_the_scenarios(capsys):
    with pytest.raises(SystemExit):
        main(["demo", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "heavy traffic" in text and "curving tunnel" in text
    assert "--frames" in text and "--seed" in text
    with pytest.raises(SystemExit):
        main(["simulate", "tunnel", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "{light,heavy,curved,randomized}" in text and "curving tunnel" in text


def _commands(parser, path=()):
    """Every command path (``("detect", "tunnel")``, ``("info",)``...) and its parser."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                if any(isinstance(a, argparse._SubParsersAction) for a in sub._actions):
                    yield from _commands(sub, (*path, name))
                else:
                    yield (*path, name), sub


def _describe(parser):
    """What a user sees of a command's parser, and how it parses: its help and usage,
    and each argument's names, defaults, choices and type."""
    return parser.format_help(), [
        (a.option_strings, a.dest, a.default, a.choices, a.nargs, a.required,
         getattr(a.type, "__name__", a.type)) for a in parser._actions]


def test_a_command_line_builds_its_command_as_the_whole_parser_does():
    full = dict(_commands(build_parser()))
    assert len(full) >= 12  # every verb's kinds and every top-level command
    for path, parser in full.items():
        narrow = build_parser([*path, "--help"])
        mine = dict(_commands(narrow))
        assert _describe(mine[path]) == _describe(parser), path
        assert len(mine) < len(full), path  # only the module that owns it
    # no command, an option first, an unknown name, or a name at another level than
    # its own (its error then lists every choice): every command
    for argv in ([], ["--help"], ["detect", "--help"], ["detect", "tunel"], ["nope"],
                 ["train", "info"], ["tunnel"], ["street", "x"], ["detect", "demo"],
                 ["evaluate", "survey"], ["train", "position"]):
        assert set(dict(_commands(build_parser(argv)))) == set(full), argv
