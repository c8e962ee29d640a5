"""Positioning a tour from files: positioning/_run.py."""

import pandas as pd
import pytest

from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.io import write_tour
from tunnelsense.positioning import evaluate_positions, position_tour, tour_tables


@pytest.fixture
def tour(tmp_path):
    write_tour(make_tunnel_tour(20, random_state=0), tmp_path / "tour")
    (tmp_path / "none.txt").write_text("")
    return tmp_path / "tour"


def test_position_tour_writes_every_frame_and_never_overwrites(tour, tmp_path):
    out = tmp_path / "pos.csv"
    positions, fixes = position_tour(tour, out, results=tmp_path / "none.txt")
    written = pd.read_csv(out)
    assert list(written["frame"]) == list(positions["frame"]) and len(written) == 20
    assert len(fixes) == 0
    with pytest.raises(FileExistsError):
        position_tour(tour, out, results=tmp_path / "none.txt")
    with pytest.raises(ValueError, match="exactly one"):
        position_tour(tour, tmp_path / "x.csv")
    with pytest.raises(FileExistsError, match="an input of this command"):
        position_tour(tour, tour / "odometry.csv", results=tmp_path / "none.txt",
                      overwrite=True)


def test_evaluate_positions_scores_and_draws(tour, tmp_path):
    position_tour(tour, tmp_path / "pos.csv", results=tmp_path / "none.txt")
    errors = evaluate_positions(tour, tmp_path / "pos.csv", draw=tmp_path / "e.png")
    assert errors["rms"] <= errors["max"]
    assert (tmp_path / "e.png").read_bytes()[:4] == b"\x89PNG"


def test_tour_tables_default_to_the_tour():
    odometry, imap, inputs = tour_tables("t", odometry="o.csv")
    assert (odometry.as_posix(), imap.as_posix()) == ("o.csv", "t/indicators.csv")
    assert odometry in inputs and imap in inputs
