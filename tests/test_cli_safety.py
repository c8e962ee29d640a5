"""The command line never destroys a file and never prints a plausible wrong score."""

import json
import shutil

import pytest

from tunnelsense._cli import main
from tunnelsense.datasets import make_street_scans, make_tunnel_tour
from tunnelsense.io import write_run, write_tour


@pytest.fixture(scope="module")
def tunnel(tmp_path_factory):
    root = tmp_path_factory.mktemp("tunnel")
    tours = []
    for seed in (0, 1):
        tour = make_tunnel_tour(120, random_state=seed, first_indicator_m=50.0)
        tours.append(write_tour(tour, root / f"tour-{seed}"))
    model = root / "model.skops"
    assert main(["train", "tunnel", str(tours[0]), "--model", str(model)]) == 0
    results = root / "results.txt"
    assert main(["detect", "tunnel", "--model", str(model), str(tours[1]), "--out",
                 str(results), "--quiet"]) == 0
    return {"tours": tours, "model": model, "results": results}


@pytest.fixture(scope="module")
def street(tmp_path_factory):
    root = tmp_path_factory.mktemp("street")
    run = write_run(make_street_scans(600, random_state=2, name="run"), root / "run")
    model = root / "model.skops"
    assert main(["train", "street", str(run), "--model", str(model)]) == 0
    return {"run": run, "model": model}


def _snapshot(folder):
    return {p: p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("kind", ["tunnel", "street"])
def test_detect_never_overwrites_without_force(kind, tunnel, street, tmp_path, capsys):
    setup = tunnel if kind == "tunnel" else street
    source = setup["tours"][1] if kind == "tunnel" else setup["run"]
    out = tmp_path / "out.csv"
    out.write_bytes(b"my precious notes\n")
    argv = ["detect", kind, "--model", str(setup["model"]), str(source), "--out",
            str(out), "--quiet"]
    assert main(argv) == 1
    assert "exists; refusing to overwrite" in capsys.readouterr().err
    assert out.read_bytes() == b"my precious notes\n"
    assert main([*argv, "--force"]) == 0
    assert out.read_bytes() != b"my precious notes\n"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


@pytest.mark.parametrize("kind", ["tunnel", "street"])
def test_detect_never_writes_over_its_inputs_even_with_force(kind, tunnel, street,
                                                             capsys):
    setup = tunnel if kind == "tunnel" else street
    source = setup["tours"][1] if kind == "tunnel" else setup["run"]
    targets = [setup["model"]] + (
        [source / "gt" / "gt.txt", source / "seqinfo.ini", source / "img1" / "000001.png"]
        if kind == "tunnel" else [source / "gt.csv", source / "scans.npz"]
    )
    before = {**_snapshot(source), setup["model"]: setup["model"].read_bytes()}
    for target in targets:
        for extra in ([], ["--force"], ["--resume"]):
            assert main(["detect", kind, "--model", str(setup["model"]), str(source),
                         "--out", str(target), "--quiet", *extra]) == 1
            assert "input of this command" in capsys.readouterr().err
    assert {**_snapshot(source), setup["model"]: setup["model"].read_bytes()} == before


def test_resume_on_an_unrelated_file_touches_nothing(tunnel, tmp_path, capsys):
    gt = tunnel["tours"][0] / "gt" / "gt.txt"
    copy = tmp_path / "copy.txt"
    data = gt.read_bytes() + b"1,2,3"  # a partial last line, which must stay too
    copy.write_bytes(data)
    assert main(["detect", "tunnel", "--model", str(tunnel["model"]),
                 str(tunnel["tours"][1]), "--out", str(copy), "--resume",
                 "--quiet"]) == 1
    assert "not a line this command writes" in capsys.readouterr().err
    assert copy.read_bytes() == data


@pytest.mark.parametrize("kind", ["tunnel", "street"])
def test_train_checks_its_output_before_fitting(kind, tunnel, street, tmp_path,
                                                capsys):
    source = tunnel["tours"][0] if kind == "tunnel" else street["run"]
    model = tmp_path / "m.skops"
    model.write_bytes(b"an older model")
    assert main(["train", kind, str(source), "--model", str(model)]) == 1
    captured = capsys.readouterr()
    assert "exists; refusing to overwrite" in captured.err
    assert "training on" not in captured.out  # refused before any work
    assert model.read_bytes() == b"an older model"
    assert main(["train", kind, str(source), "--model", str(model), "--force"]) == 0
    assert model.read_bytes()[:2] == b"PK"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.skops"]


def test_draw_folder_is_not_drawn_over(tunnel, tmp_path, capsys):
    draw = tmp_path / "draw"
    draw.mkdir()
    (draw / "000001.png").write_bytes(b"a picture of mine")
    assert main(["detect", "tunnel", "--model", str(tunnel["model"]),
                 str(tunnel["tours"][1]), "--out", str(tmp_path / "r.txt"),
                 "--draw", str(draw), "--quiet"]) == 1
    assert "not empty" in capsys.readouterr().err
    assert (draw / "000001.png").read_bytes() == b"a picture of mine"
    assert not (tmp_path / "r.txt").exists()


def test_simulate_never_writes_into_a_folder_with_files(tmp_path, capsys):
    folder = tmp_path / "tour"
    folder.mkdir()
    (folder / "notes.txt").write_text("mine")
    assert main(["simulate", "tunnel", str(folder), "--frames", "5"]) == 1
    assert "refusing to write over it" in capsys.readouterr().err
    assert sorted(p.name for p in folder.iterdir()) == ["notes.txt"]


def _evaluate(tunnel, results, capsys):
    code = main(["evaluate", "tunnel", str(tunnel["tours"][1]), str(results), "--json"])
    captured = capsys.readouterr()
    return code, captured


def test_evaluate_refuses_a_bad_token_in_the_companion(tunnel, tmp_path, capsys):
    results = tmp_path / "r.txt"
    shutil.copy(tunnel["results"], results)
    companion = tunnel["results"].with_name("results.clusters.csv").read_text()
    lines = companion.splitlines()
    row = next(i for i, line in enumerate(lines[1:], 1) if line.endswith(",False,False"))
    lines[row] = lines[row][: -len(",False,False")] + ",no,False"
    (tmp_path / "r.clusters.csv").write_text("\n".join(lines) + "\n")
    code, captured = _evaluate(tunnel, results, capsys)
    assert code == 1
    assert f"r.clusters.csv, line {row + 1}: indicator is 'no'" in captured.err


@pytest.mark.parametrize("companion", ["header-only", "stale"])
def test_evaluate_refuses_a_companion_of_another_run(tunnel, tmp_path, capsys,
                                                     companion):
    results = tmp_path / "r.txt"
    shutil.copy(tunnel["results"], results)
    text = tunnel["results"].with_name("results.clusters.csv").read_text()
    if companion == "header-only":
        text = text.splitlines()[0] + "\n"
    else:  # one detection less in the companion than in the results file
        lines = text.splitlines()
        row = next(i for i, line in enumerate(lines) if line.endswith(",True"))
        text = "\n".join(lines[:row] + lines[row + 1 :]) + "\n"
    (tmp_path / "r.clusters.csv").write_text(text)
    code, captured = _evaluate(tunnel, results, capsys)
    assert code == 1
    assert "does not match" in captured.err and "another run" in captured.err


def test_evaluate_says_n_a_for_0_of_0(tmp_path, capsys):
    tour = make_tunnel_tour(30, random_state=0)
    folder = write_tour(tour, tmp_path / "empty-tour")
    gt = folder / "gt" / "gt.txt"  # a tour with no indicator
    gt.write_text("".join(line for line in gt.read_text().splitlines(True)
                          if line.split(",")[7] != "1"))
    results = tmp_path / "r.txt"
    results.write_text("")
    assert main(["evaluate", "tunnel", str(folder), str(results), "--json"]) == 0
    scores = json.loads(capsys.readouterr().out)
    assert scores["trajectory"]["indicators"] == 0
    assert scores["trajectory"]["detection_rate"] is None
    assert scores["cluster"]["detection_rate"] is None
    assert main(["evaluate", "tunnel", str(folder), str(results)]) == 0
    text = capsys.readouterr().out
    assert "100.0 %" not in text and "n/a (0 of 0)" in text


def test_draw_every_and_the_disk_it_uses(tunnel, tmp_path, capsys):
    draw = tmp_path / "draw"
    assert main(["detect", "tunnel", "--model", str(tunnel["model"]),
                 str(tunnel["tours"][1]), "--out", str(tmp_path / "r.txt"),
                 "--draw", str(draw), "--draw-every", "10", "--quiet"]) == 0
    pictures = sorted(p.name for p in draw.iterdir())
    assert pictures == [f"{k:06d}.png" for k in range(1, 121, 10)]
    size = sum(p.stat().st_size for p in draw.iterdir()) / 1e6
    assert f"drew 12 pictures ({size:.1f} MB) in {draw}" in capsys.readouterr().out


@pytest.mark.parametrize("where", ["frames", "device"])
def test_draw_never_goes_into_inputs_or_device_folders(tunnel, tmp_path, capsys, where):
    tour = tunnel["tours"][1]
    before = _snapshot(tour)
    draw = tour / "img1" if where == "frames" else "/dev/shm/tunnelsense-draw-test"
    assert main(["detect", "tunnel", "--model", str(tunnel["model"]), str(tour),
                 "--out", str(tmp_path / "r.txt"), "--draw", str(draw), "--force",
                 "--quiet"]) == 1
    err = capsys.readouterr().err
    assert ("input of this command" if where == "frames" else "device folder") in err
    assert _snapshot(tour) == before
    assert not (tmp_path / "r.txt").exists()
    import os

    assert not os.path.exists("/dev/shm/tunnelsense-draw-test")


def test_the_key_file_is_an_input(street, tmp_path, capsys):
    key = tmp_path / "fleet.key"
    key.write_text("fleet-secret-0123456789")
    signed = tmp_path / "signed.skops"
    assert main(["train", "street", str(street["run"]), "--model", str(signed),
                 "--key-file", str(key)]) == 0
    assert main(["detect", "street", "--model", str(signed), str(street["run"]),
                 "--out", str(key), "--key-file", str(key), "--force", "--quiet"]) == 1
    assert "input of this command" in capsys.readouterr().err
    named = tmp_path / "fleet-key.skops"  # a key file a model could be written over
    named.write_text("fleet-secret-0123456789")
    assert main(["train", "street", str(street["run"]), "--model", str(named),
                 "--key-file", str(named), "--force"]) == 1
    assert "input of this command" in capsys.readouterr().err
    assert named.read_text() == "fleet-secret-0123456789"
    assert key.read_text() == "fleet-secret-0123456789"


# --- outputs of one run never clash, and nothing is lost on --resume ---


def test_draw_refuses_a_folder_that_holds_an_input(tunnel, tmp_path, capsys):
    """A single frame D/000001.png as the source, --draw D --force: refused."""
    folder = tmp_path / "D"
    folder.mkdir()
    frame = folder / "000001.png"
    frame.write_bytes((tunnel["tours"][1] / "img1" / "000001.png").read_bytes())
    before = frame.read_bytes()
    out = tmp_path / "r.txt"
    assert main(["detect", "tunnel", "--model", str(tunnel["model"]), str(frame),
                 "--out", str(out), "--draw", str(folder), "--force", "--quiet"]) == 1
    assert "holds an input of this command" in capsys.readouterr().err
    assert frame.read_bytes() == before
    assert sorted(p.name for p in folder.iterdir()) == ["000001.png"]
    assert not out.exists()


@pytest.mark.parametrize("kind,name", [("tunnel", "000001.png"),
                                       ("street", "range_image_000000.png")])
def test_out_is_never_a_name_draw_writes(kind, name, tunnel, street, tmp_path, capsys):
    setup = tunnel if kind == "tunnel" else street
    source = setup["tours"][1] if kind == "tunnel" else setup["run"]
    folder = tmp_path / "D"
    out = folder / name
    assert main(["detect", kind, "--model", str(setup["model"]), str(source), "--out",
                 str(out), "--draw", str(folder), "--quiet"]) == 1
    assert "inside the picture folder" in capsys.readouterr().err
    assert not folder.exists()  # refused before any work


@pytest.mark.parametrize("tail", [b"garbage text", b"1,1,0"])
def test_resume_refuses_trailing_text_that_is_not_a_cut_off_line(tunnel, tmp_path,
                                                                 capsys, tail):
    """Trailing text without a newline is kept and refused, unless it is the start
    of the line the run writes there (a line cut off by the interruption)."""
    out = tmp_path / "r.txt"
    shutil.copy(tunnel["results"], out)
    from tunnelsense.io import clusters_path

    shutil.copy(clusters_path(tunnel["results"]), clusters_path(out))
    lines = out.read_bytes().splitlines(keepends=True)
    head = b"".join(lines[:5])
    data = head + tail
    out.write_bytes(data)
    assert main(["detect", "tunnel", "--model", str(tunnel["model"]),
                 str(tunnel["tours"][1]), "--out", str(out), "--resume",
                 "--quiet"]) == 1
    assert "refusing to delete it" in capsys.readouterr().err
    assert out.read_bytes() == data
    # a real cut-off line resumes to the uninterrupted result
    out.write_bytes(head + lines[5][:7])
    assert main(["detect", "tunnel", "--model", str(tunnel["model"]),
                 str(tunnel["tours"][1]), "--out", str(out), "--resume",
                 "--quiet"]) == 0
    assert out.read_bytes() == tunnel["results"].read_bytes()


@pytest.fixture(scope="module")
def colour_tours(tunnel, tmp_path_factory):
    """The test tour with its frames stored in false colour, and as grey in RGB."""
    import cv2

    root = tmp_path_factory.mktemp("colour")
    tours = {}
    for kind in ("palette", "grey-rgb"):
        folder = root / kind
        shutil.copytree(tunnel["tours"][1], folder)
        for png in sorted((folder / "img1").glob("*.png")):
            grey = cv2.imread(str(png), cv2.IMREAD_UNCHANGED)
            image = (cv2.applyColorMap(grey, cv2.COLORMAP_JET) if kind == "palette"
                     else cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR))
            cv2.imwrite(str(png), image)
        tours[kind] = folder
    return tours


def test_colour_frames_are_refused_unless_a_conversion_is_named(tunnel, colour_tours,
                                                                tmp_path, capsys):
    out = tmp_path / "r.txt"
    argv = ["detect", "tunnel", "--model", str(tunnel["model"]), "--out", str(out),
            "--quiet"]
    assert main([*argv, str(colour_tours["palette"])]) == 1
    err = capsys.readouterr().err
    assert "a colour frame" in err and "--channel" in err and "internal" not in err
    assert not out.exists()
    assert main(["train", "tunnel", str(colour_tours["palette"]), "--model",
                 str(tmp_path / "m.skops"), "--quiet"]) == 1
    assert "a colour frame" in capsys.readouterr().err
    for option in (["--channel", "2"], ["--palette-to-grey"]):
        assert main([*argv, str(colour_tours["palette"]), "--force", *option]) == 0
    # grey stored as RGB is grey: the same results as the grey frames
    assert main([*argv, str(colour_tours["grey-rgb"]), "--force"]) == 0
    assert out.read_bytes() == tunnel["results"].read_bytes()
