import argparse
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from tunnelsense.cli import main
from tunnelsense.cli import tunnel as cli_tunnel
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.io import mot_result_lines, read_mot_results, read_tour, write_tour

CLI = [sys.executable, "-c", "import sys; from tunnelsense.cli import main; sys.exit(main())"]


def run(argv):
    parser = argparse.ArgumentParser(prog="tunnelsense")
    sub = parser.add_subparsers(dest="command")
    verbs = {
        v: sub.add_parser(v).add_subparsers(dest="kind", required=True)
        for v in ("train", "detect", "evaluate")
    }
    cli_tunnel.register(verbs)
    cli_tunnel.register_top(sub)
    args = parser.parse_args(argv)
    return args.func(args)


@pytest.fixture(scope="module")
def tour_dirs(tmp_path_factory):
    root = tmp_path_factory.mktemp("tours")
    dirs = []
    for seed in (0, 1):
        tour = make_tunnel_tour(120, random_state=seed, first_indicator_m=50.0)
        write_tour(tour, root / f"tour-{seed}")
        dirs.append(root / f"tour-{seed}")
    return dirs


@pytest.fixture(scope="module")
def models(tour_dirs, tmp_path_factory):
    root = tmp_path_factory.mktemp("models")
    paths = {}
    for ext in ("skops", "joblib"):
        paths[ext] = root / f"model.{ext}"
        assert run(["train", "tunnel", str(tour_dirs[0]), "--model", str(paths[ext])]) == 0
    return paths


@pytest.fixture(scope="module")
def long_folder(tour_dirs, tmp_path_factory):
    """An image folder of 240 frames: the 120 frames of a tour, hard-linked twice."""
    folder = tmp_path_factory.mktemp("long") / "long-tour"
    folder.mkdir()
    frames = sorted((tour_dirs[1] / "img1").glob("*.png"))
    k = 0
    for _ in range(2):
        for f in frames:
            k += 1
            os.link(f, folder / f"{k:06d}.png")
    return folder


@pytest.fixture(scope="module")
def batch_records(models, tour_dirs):
    """The batch predict of the trained model on the second tour."""
    from tunnelsense.io import load_model

    return load_model(models["skops"]).predict(read_tour(tour_dirs[1]).frames)


def lines_of(records):
    """Results lines of records, as detect writes them."""
    return [line for r in records for line in mot_result_lines(r)]


@pytest.fixture(scope="module")
def full_long(models, long_folder, tmp_path_factory):
    """An uninterrupted detect run on the long folder: (results, companion) bytes."""
    full = tmp_path_factory.mktemp("full") / "full.txt"
    run(["detect", "tunnel", "--model", str(models["skops"]), str(long_folder), "--out", str(full)])
    return full.read_bytes(), full.with_name("full.clusters.csv").read_bytes()


def test_train_detect_evaluate(tour_dirs, models, tmp_path, capsys):
    out = tmp_path / "res" / "results.txt"
    draw = tmp_path / "draw"
    assert run(["detect", "tunnel", "--model", str(models["skops"]), str(tour_dirs[1]),
                "--out", str(out), "--draw", str(draw)]) == 0
    res = read_mot_results(out)
    assert list(res.columns[:7]) == ["frame", "id", "bb_left", "bb_top", "bb_width", "bb_height", "conf"]
    assert (res[["x", "y", "z"]] == -1).all().all()
    assert (out.parent / "results.clusters.csv").is_file()
    assert len(list(draw.glob("*.png"))) == 120
    capsys.readouterr()
    assert run(["evaluate", "tunnel", str(tour_dirs[1]), str(out), "--json"]) == 0
    scores = json.loads(capsys.readouterr().out)
    assert set(scores["cluster"]) == {
        "total", "correct", "misses", "false_alarms", "detection_rate", "false_alarm_rate"
    }
    assert set(scores["trajectory"]) == {"indicators", "detected", "false_alarms", "detection_rate"}
    assert scores["trajectory"]["indicators"] == 1
    assert 0 <= scores["cluster"]["false_alarm_rate"] <= 1
    # without the companion file the false-alarm rate is unknown
    (out.parent / "results.clusters.csv").unlink()
    assert run(["evaluate", "tunnel", str(tour_dirs[1]), str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["cluster"]["false_alarm_rate"] is None
    assert run(["evaluate", "tunnel", str(tour_dirs[1]), str(out)]) == 0
    text = capsys.readouterr().out
    assert "detection rate" in text and "n/a" in text


def test_streamed_outputs_equal_batch_predict(tour_dirs, models, batch_records, tmp_path):
    from tunnelsense.metrics import hypotheses_from_records

    out = tmp_path / "r.txt"
    run(["detect", "tunnel", "--model", str(models["skops"]), str(tour_dirs[1]), "--out", str(out)])
    lines = out.read_text().splitlines()
    assert lines == lines_of(batch_records)
    assert len(lines) > 0
    # the companion holds every cluster with the batch decisions
    import pandas as pd

    hyp = hypotheses_from_records(batch_records).drop(columns="tour")
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "r.clusters.csv"), hyp)


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_readers_decode_or_stages_write_the_same_bytes(tour_dirs, models, batch_records,
                                                      tmp_path, jobs, monkeypatch):
    """--readers keypoints and stages (the reader threads also run the first or every
    per-frame stage) write the results and clusters --readers decode writes, byte for
    byte, alone and in a fleet."""
    from tunnelsense.tunnel import _detect

    asked, stream_detect = [], _detect.stream_detect

    def spy(*args, **kwargs):  # the mode reaches the streaming detector
        asked.append(kwargs["stages_in_readers"])
        return stream_detect(*args, **kwargs)

    monkeypatch.setattr(_detect, "stream_detect", spy)
    written = {}
    for mode in ("decode", "keypoints", "stages"):
        out = tmp_path / mode / "r.txt"
        assert run(["detect", "tunnel", "--model", str(models["skops"]), str(tour_dirs[1]),
                    "--out", str(out), "--jobs", jobs, "--readers", mode, "--quiet"]) == 0
        fleet = tmp_path / f"fleet-{mode}"
        assert run(["detect", "tunnel", "--model", str(models["skops"]),
                    *map(str, tour_dirs), "--out", str(fleet), "--jobs", "1",
                    "--readers", mode, "--quiet"]) == 0
        written[mode] = [out.read_bytes(), out.with_name("r.clusters.csv").read_bytes(),
                         *(p.read_bytes() for p in sorted(fleet.glob("tour-*")))]
    assert len(written["decode"]) == 2 + 4  # a results file and its clusters per tour
    # one source, then a fleet of two
    assert asked == [False] * 3 + [1] * 3 + [True] * 3
    assert [type(a) for a in asked[3::3]] == [int, bool]
    assert written["stages"] == written["keypoints"] == written["decode"]
    assert written["decode"][0].decode().splitlines() == lines_of(batch_records)
    assert any(lines_of(batch_records))


def test_readers_refuses_another_choice(tour_dirs, models, tmp_path, capsys):
    with pytest.raises(SystemExit):
        run(["detect", "tunnel", "--model", str(models["skops"]), str(tour_dirs[1]),
             "--out", str(tmp_path / "r.txt"), "--readers", "threads"])
    assert "--readers: invalid choice: 'threads'" in capsys.readouterr().err
    assert not (tmp_path / "r.txt").exists()


@pytest.mark.slow
def test_video_source(tour_dirs, models, batch_records, tmp_path):
    import cv2

    tour = read_tour(tour_dirs[1])
    video = tmp_path / "tour.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"FFV1"), 30.0, (640, 480), False)
    for r in tour.frames:
        writer.write(r.image)
    writer.release()
    out = tmp_path / "v.txt"
    draw = tmp_path / "draw"
    assert run(["detect", "tunnel", "--model", str(models["skops"]), str(video), "--out", str(out),
                "--draw", str(draw)]) == 0
    # FFV1 is lossless: the same detections as from the PNG folder
    assert out.read_text().splitlines() == lines_of(batch_records)
    assert len(list(draw.glob("*.png"))) == 120


@pytest.mark.slow
def test_draw_video(tour_dirs, models, batch_records, tmp_path, capsys):
    """--draw-video: one video file holding every frame drawn, never over a file."""
    import cv2

    from tunnelsense.plotting import draw_detections

    out, video = tmp_path / "v.txt", tmp_path / "drawn.mp4"
    argv = ["detect", "tunnel", "--model", str(models["skops"]), str(tour_dirs[1]),
            "--out", str(out), "--draw-video", str(video), "--quiet"]
    assert main(argv) == 0
    assert "drew 120 frames into" in capsys.readouterr().out
    assert out.read_text().splitlines() == lines_of(batch_records)
    capture = cv2.VideoCapture(str(video))
    assert capture.isOpened()
    assert int(capture.get(cv2.CAP_PROP_FRAME_COUNT)) == 120
    assert capture.get(cv2.CAP_PROP_FPS) == pytest.approx(30.0)
    decoded = []
    while True:
        ok, picture = capture.read()
        if not ok:
            break
        decoded.append(picture)
    capture.release()
    assert len(decoded) == 120 and decoded[0].shape == (480, 640, 3)
    # the frames are the drawn pictures (lossy codec: close, not equal; its mean
    # error is 3.4-4.3 grey levels here, higher with more drawn boxes; a black frame
    # would differ by tens)
    drawn = [pic for _, pic in draw_detections(batch_records)]
    for k in (0, 60, 119):
        assert np.mean(np.abs(decoded[k].astype(float) - drawn[k])) < 6.0
    assert not list(tmp_path.glob(".*partial*"))  # no temporary file left
    # an existing video is not replaced without --force; with it, it is
    before = video.read_bytes()
    out.unlink()
    out.with_suffix(".clusters.csv").unlink()
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "--draw-video" in err and "--force" in err
    assert video.read_bytes() == before and not out.exists()
    assert main([*argv, "--force"]) == 0
    assert int(cv2.VideoCapture(str(video)).get(cv2.CAP_PROP_FRAME_COUNT)) == 120
    # a name OpenCV is not asked to encode, or the results file itself: refused first
    same = tmp_path / "same.mp4"
    for extra, message in ((["--out", str(out), "--draw-video", str(tmp_path / "v.gif")],
                            "expected a .mp4 or .avi file"),
                           (["--out", str(same), "--draw-video", str(same)],
                            "is also the results file")):
        assert main([*argv[:4], str(tour_dirs[1]), *extra, "--force"]) == 1
        assert message in capsys.readouterr().err
    assert not same.exists()


@pytest.mark.slow
def test_skops_and_joblib_in_a_fresh_process(tour_dirs, models, batch_records, tmp_path):
    outs = {}
    for ext, path in models.items():
        outs[ext] = tmp_path / f"{ext}.txt"
        proc = subprocess.run(
            [*CLI, "detect", "tunnel", "--model", str(path), str(tour_dirs[1]), "--out", str(outs[ext]),
             *(["--trust-pickle"] if ext == "joblib" else [])],
            capture_output=True, text=True, check=True,
        )
        assert ("pickle" in proc.stderr) is (ext == "joblib")
    assert outs["skops"].read_bytes() == outs["joblib"].read_bytes()
    assert outs["skops"].read_text().splitlines() == lines_of(batch_records)


def test_info_shows_the_model_card(models, capsys):
    assert main(["info", str(models["skops"])]) == 0
    text = capsys.readouterr().out
    assert "skops model file" in text and "trained under scikit-learn" in text
    assert "tunnel-light-0" in text and "training_scores" in text
    assert main(["info", str(models["skops"]), "--json"]) == 0
    card = json.loads(capsys.readouterr().out)
    assert card["summary"]["tours"][0]["frames"] == 120
    assert card["summary"]["parameters"]["motion__min_r"] == 0.95
    assert set(card["summary"]["training_scores"]) == {"cluster", "trajectory"}
    # the band of local contrast learned from the training tour (the pipeline's
    # default), as grey levels of the training frames: widened to 0.45-1.5 times the
    # indicators' contrast, it reaches from well below the simulated indicators'
    # [160, 190] to above them
    low, high = card["summary"]["keypoint_band"]
    assert card["summary"]["parameters"]["keypoints__band"] == "learned"
    assert card["summary"]["parameters"]["keypoints__radiometry"] == "contrast"
    assert 100 < low < 145 and 190 < high < 260


def test_pickle_posing_as_skops_is_refused(models, tour_dirs, tmp_path, capsys):
    fake = tmp_path / "model.skops"
    fake.write_bytes(models["joblib"].read_bytes())
    code = main(["detect", "tunnel", "--model", str(fake), str(tour_dirs[1]),
                 "--out", str(tmp_path / "r.txt")])
    assert code == 1
    assert "pickle" in capsys.readouterr().err
    assert not (tmp_path / "r.txt").exists()


def test_resume_completes_a_truncated_file(
    models, long_folder, full_long, tmp_path, global_random_seed
):
    data, companion = full_long
    assert data.count(b"\n") > 10
    rng = np.random.default_rng(global_random_seed)
    out = tmp_path / "cut.txt"
    # cut both files mid-line, at different places (as a kill would)
    out.write_bytes(data[: int(rng.integers(1, len(data) - 1))])
    (tmp_path / "cut.clusters.csv").write_bytes(companion[: int(rng.integers(1, len(companion)))])
    run(["detect", "tunnel", "--model", str(models["skops"]), str(long_folder), "--out", str(out),
         "--resume"])
    assert out.read_bytes() == data
    assert (tmp_path / "cut.clusters.csv").read_bytes() == companion
    # a file of another source cannot be resumed
    other = tmp_path / "other.txt"
    other.write_text("1,1,0.0,0.0,1.0,1.0,1.0,-1,-1,-1\n")
    with pytest.raises(ValueError, match="cannot resume"):
        run(["detect", "tunnel", "--model", str(models["skops"]), str(long_folder), "--out",
             str(other), "--resume"])


@pytest.mark.slow
def test_kill_then_resume(models, long_folder, full_long, tmp_path):
    data, full_companion = full_long
    out = tmp_path / "killed.txt"
    companion = tmp_path / "killed.clusters.csv"
    argv = [*CLI, "detect", "tunnel", "--model", str(models["skops"]), str(long_folder), "--out", str(out)]
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:
        if companion.exists() and companion.read_bytes().count(b"\n") >= 20:
            break
        time.sleep(0.005)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert proc.returncode == -signal.SIGKILL  # killed mid-run, not finished
    kept = companion.read_bytes()
    assert kept.endswith(b"\n")  # flushed whole lines
    assert len(kept) < len(full_companion) and full_companion.startswith(kept)
    assert data.startswith(out.read_bytes())
    subprocess.run([*argv, "--resume"], check=True, capture_output=True)
    assert out.read_bytes() == data
    assert companion.read_bytes() == full_companion


def _learned(estimator):
    return {k: v for k, v in vars(estimator).items() if k.endswith("_")
            and not k.startswith("_")}


@pytest.mark.slow
def test_train_gives_the_model_fit_gives(models, tour_dirs):
    """'train tunnel' with its defaults equals make_indicator_pipeline().fit(X, y).

    The command's default ``--jobs`` (the number of CPUs) is the verifier's k-means
    threads, whose sums round in another order than on one thread.
    """
    from tunnelsense import to_xy
    from tunnelsense.io import load_model
    from tunnelsense.tunnel import make_indicator_pipeline

    X, y, _ = to_xy([read_tour(tour_dirs[0])])
    fitted = make_indicator_pipeline(random_state=0,
                                     verifier__n_jobs=os.cpu_count() or 1).fit(X, y)
    trained = load_model(models["skops"])
    for (name, a), (_, b) in zip(fitted.steps, trained.steps, strict=True):
        learned_a, learned_b = _learned(a), _learned(b)
        assert learned_a.keys() == learned_b.keys() and learned_a, name
        for key, value in learned_a.items():
            if isinstance(value, np.ndarray) and value.dtype.kind in "fiub":
                np.testing.assert_array_equal(value, learned_b[key], f"{name}.{key}")
            elif not hasattr(value, "get_params"):
                assert repr(value) == repr(learned_b[key]), f"{name}.{key}"
    test = read_tour(tour_dirs[1]).frames
    assert lines_of(fitted.predict(test)) == lines_of(trained.predict(test))
    assert any(lines_of(trained.predict(test)))  # something to compare


def test_info_of_a_model_is_indented_one_fact_per_line(models, capsys):
    assert main(["info", str(models["skops"])]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "  summary:" in lines and "    parameters:" in lines
    assert "      motion__min_r: 0.95" in lines
    first = lines.index("    tours:") + 1  # a bulleted list of tours
    assert lines[first] == "      - frames: 120"
    assert "        name: tunnel-light-0" in lines[first:]
    assert not any("{" in line for line in lines)


def test_missing_frames_gap_reads_a_recorder_s_gaps(tour_dirs, models, tmp_path):
    """A tour whose recorder lost frames: refused by default (the message names the
    option), read as gaps in time with --missing-frames gap, by detect (one tour and
    a fleet) and evaluate alike."""
    import shutil

    from tunnelsense.io import load_model

    gapped = tmp_path / "gapped"
    shutil.copytree(tour_dirs[1], gapped)
    for k in (40, 41, 77):
        (gapped / "img1" / f"{k:06d}.png").unlink()
    model = ["--model", str(models["skops"])]
    with pytest.raises(FileNotFoundError, match="--missing-frames gap"):
        run(["detect", "tunnel", *model, str(gapped), "--out", str(tmp_path / "no.txt")])
    assert not (tmp_path / "no.txt").exists()
    out = tmp_path / "r.txt"
    assert run(["detect", "tunnel", *model, str(gapped), "--out", str(out),
                "--missing-frames", "gap"]) == 0
    frames = read_tour(gapped, missing_frames="gap").frames
    expected = lines_of(load_model(models["skops"]).predict(frames))
    assert out.read_text().splitlines() == expected
    assert not {40, 41, 77} & set(read_mot_results(out)["frame"])
    # a fleet passes the option to its workers: the same lines
    folder = tmp_path / "fleet"
    assert run(["detect", "tunnel", *model, str(gapped), str(tour_dirs[0]),
                "--out", str(folder), "--jobs", "1", "--missing-frames", "gap"]) == 0
    assert (folder / "gapped.txt").read_text().splitlines() == expected
    assert run(["evaluate", "tunnel", str(gapped), str(out), "--json",
                "--missing-frames", "gap"]) == 0
    with pytest.raises(FileNotFoundError, match="--missing-frames gap"):
        run(["evaluate", "tunnel", str(gapped), str(out)])
    assert run(["train", "tunnel", str(gapped), "--model", str(tmp_path / "m.skops"),
                "--missing-frames", "gap"]) == 0
