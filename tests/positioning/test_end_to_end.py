"""The real detector on a rendered tour, then positioning; the command line.

A 900-frame tour at 90 km/h (750 m, indicators at 40, 240, 440 and 640 m) is
rendered and written, a detector is trained on another tour, and ``position`` /
``evaluate position`` run on it.  The 2-km figures with real detections are made by
``docs/figures/positioning_accuracy.py``.
"""

import json

import numpy as np
import pandas as pd
import pytest

from tunnelsense._cli import main
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.io import read_mot_results, write_tour
from tunnelsense.positioning import (
    TunnelPositioner,
    position_errors,
    read_indicator_map,
    read_odometry,
    read_positions,
)

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    root = tmp_path_factory.mktemp("positioning")
    train = make_tunnel_tour(300, random_state=11, first_indicator_m=40.0)
    test = make_tunnel_tour(900, random_state=12, first_indicator_m=40.0,
                            speed_kmh=90.0)
    write_tour(train, root / "train")
    write_tour(test, root / "tour")
    model = root / "m.skops"
    assert main(["train", "tunnel", str(root / "train"), "--model", str(model),
                 "--quiet", "--jobs", "1"]) == 0
    results = root / "tour.txt"
    assert main(["detect", "tunnel", "--model", str(model), str(root / "tour"),
                 "--out", str(results), "--quiet", "--jobs", "1"]) == 0
    return root, model, results


def _tables(root):
    tour = root / "tour"
    return (read_positions(tour / "positions.csv"), read_odometry(tour / "odometry.csv"),
            read_indicator_map(tour / "indicators.csv"))


def test_real_detections_fix_the_position(rendered):
    root, _, results = rendered
    positions, odometry, indicators = _tables(root)
    det = read_mot_results(results)
    est, fixes = TunnelPositioner(smooth=True).fit(indicators).predict(
        det, odometry, return_fixes=True)
    errors = position_errors(positions, est, odometry, indicators)
    passes = errors["passes"]
    assert len(passes) == 4
    kept = fixes[fixes["accepted"]]
    assert len(kept) >= 3
    # every fix went to the sign whose trajectory it is: the gt id of its boxes
    from tunnelsense.io import read_mot_gt

    gt = read_mot_gt(root / "tour" / "gt" / "gt.txt")
    gt = gt[gt["class"] == 1]
    for row in kept.itertuples():
        boxes = det[det["id"] == row.track_id].merge(gt, on="frame", suffixes=("", "_g"))
        near = (boxes["bb_left"] - boxes["bb_left_g"]).abs() < 5
        assert boxes.loc[near, "id_g"].mode().item() == row.indicator_id
    assert all(abs(p["error"]) < 1.0 for p in passes)
    assert errors["max"] < 1.0
    assert errors["max"] * 10 <= errors["dead_reckoning"]["max"]


def test_cli_position_and_evaluate(rendered, tmp_path, capsys):
    root, model, results = rendered
    tour = str(root / "tour")
    out = tmp_path / "pos.csv"
    assert main(["position", tour, "--model", str(model), "--odometry",
                 f"{tour}/odometry.csv", "--map", f"{tour}/indicators.csv", "--out",
                 str(out), "--smooth", "--quiet"]) == 0
    got = pd.read_csv(out)
    assert list(got.columns) == ["frame", "stamp", "chainage", "sigma", "locked",
                                 "scale", "scale_sigma"]
    assert len(got) == 900 and got["locked"].all()
    # the live detector (a fixed-lag smoother whose window holds the whole tour) and
    # its results file (the whole-tour smoother) give the same smoothed positions; a
    # fix the live detector releases after the pass is applied at the pass, one the
    # file gives before it at the frame it is known: the process noise over those
    # few metres is left out, a fraction of a millimetre
    again = tmp_path / "pos2.csv"
    assert main(["position", tour, "--results", str(results), "--out", str(again),
                 "--smooth"]) == 0
    offline = pd.read_csv(again)
    pd.testing.assert_frame_equal(got, offline, rtol=0, atol=1e-3)
    capsys.readouterr()
    picture = tmp_path / "errors.png"
    assert main(["evaluate", "position", tour, str(out), "--json", "--draw",
                 str(picture)]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["max"] < 1.0 and report["dead_reckoning"]["max"] > 10.0
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["evaluate", "position", tour, str(out)]) == 0
    text = capsys.readouterr().out
    assert "dead reckoning" in text and "maximum error" in text


def test_online_position_is_causal(rendered, tmp_path):
    """Online, a frame's position uses only what was known then: before the first
    sign is passed, it is dead reckoning."""
    root, model, _ = rendered
    tour = root / "tour"
    out = tmp_path / "online.csv"
    assert main(["position", str(tour), "--model", str(model), "--out", str(out),
                 "--quiet"]) == 0
    got = read_positions(out, sigma=True)
    positions, odometry, indicators = _tables(root)
    from tunnelsense.positioning import dead_reckoning

    # until the first trajectory that gave a fix ended (its sign had left the
    # image, the camera a few metres before it), dead reckoning
    fixes = TunnelPositioner().fit(indicators).predict(
        read_mot_results(rendered[2]), odometry, return_fixes=True)[1]
    known = fixes.loc[fixes["accepted"], "last_frame"].min()
    before = got["frame"].to_numpy() <= known
    assert before.sum() > 30
    np.testing.assert_allclose(got["chainage"].to_numpy()[before],
                               dead_reckoning(odometry)[before], atol=1e-9)
    assert not np.allclose(got["chainage"].to_numpy()[~before],
                           dead_reckoning(odometry)[~before])
    errors = position_errors(positions, got, odometry, indicators)
    assert errors["final"] < 1.0 < errors["dead_reckoning"]["final"]


def test_cli_never_overwrites(rendered, tmp_path, capsys):
    root, _, results = rendered
    tour = root / "tour"
    out = tmp_path / "pos.csv"
    out.write_text("keep")
    args = ["position", str(tour), "--results", str(results), "--out", str(out)]
    assert main(args) == 1
    assert out.read_text() == "keep"
    assert "--force" in capsys.readouterr().err
    assert main([*args, "--force"]) == 0
    # the tour's own tables are inputs: never written, even with --force
    odo = (tour / "odometry.csv").read_bytes()
    assert main(["position", str(tour), "--results", str(results), "--out",
                 str(tour / "odometry.csv"), "--force"]) == 1
    assert (tour / "odometry.csv").read_bytes() == odo
    picture = tmp_path / "p.png"
    picture.write_text("keep")
    assert main(["evaluate", "position", str(tour), str(out), "--draw",
                 str(picture)]) == 1
    assert picture.read_text() == "keep"
    assert main(["evaluate", "position", str(tour), str(out), "--draw",
                 str(out), "--force"]) == 1  # the estimate is an input
    assert out.read_bytes()[:5] == b"frame"


def test_missing_frames_gap_positions_every_frame(rendered, tmp_path, capsys):
    """A tour whose recorder lost frames: ``position`` refuses it by default (the
    message names the option, nothing is written); with ``--missing-frames gap`` a
    lost frame keeps its row, positioned from its odometry, and the live detector
    gives the positions its results file gives (as on the whole tour)."""
    import shutil

    root, model, _ = rendered
    gapped = tmp_path / "gapped"
    shutil.copytree(root / "tour", gapped)
    lost = (120, 121, 122, 455)
    for k in lost:
        (gapped / "img1" / f"{k:06d}.png").unlink()
    out = tmp_path / "pos.csv"
    assert main(["position", str(gapped), "--model", str(model), "--out", str(out),
                 "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "000120.png" in err and "--missing-frames gap" in err
    assert not out.exists()
    assert main(["position", str(gapped), "--model", str(model), "--out", str(out),
                 "--smooth", "--quiet", "--missing-frames", "gap"]) == 0
    got = pd.read_csv(out)
    assert got["frame"].tolist() == list(range(1, 901)) and got["locked"].all()
    results = tmp_path / "r.txt"
    assert main(["detect", "tunnel", "--model", str(model), str(gapped), "--out",
                 str(results), "--quiet", "--missing-frames", "gap"]) == 0
    assert not set(lost) & set(read_mot_results(results)["frame"])
    offline = tmp_path / "offline.csv"
    # a results file on the tour: refused too by default (the coverage check reads
    # the tour's frames)
    assert main(["position", str(gapped), "--results", str(results), "--out",
                 str(offline), "--smooth"]) == 1
    assert "--missing-frames gap" in capsys.readouterr().err
    assert not offline.exists()
    assert main(["position", str(gapped), "--results", str(results), "--out",
                 str(offline), "--smooth", "--missing-frames", "gap"]) == 0
    pd.testing.assert_frame_equal(got, pd.read_csv(offline), rtol=0, atol=1e-3)
    positions, odometry, indicators = _tables(root)
    errors = position_errors(positions, read_positions(out, sigma=True), odometry,
                             indicators)
    assert errors["max"] < 1.0
