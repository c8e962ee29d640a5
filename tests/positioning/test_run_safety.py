"""position --results never writes a plausible partial answer from odometry it
cannot trust: a gap, a short odometry, absurd speeds or frame numbers."""

import pandas as pd
import pytest

from tunnelsense._cli import main
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.exceptions import InputFormatError
from tunnelsense.io import write_tour
from tunnelsense.positioning import position_tour
from tunnelsense.positioning._tables import read_odometry


@pytest.fixture
def tour(tmp_path):
    write_tour(make_tunnel_tour(60, random_state=0), tmp_path / "tour")
    (tmp_path / "res.txt").write_text("5,1,10,10,4,8,1,-1,-1,-1\n")
    return tmp_path / "tour"


@pytest.mark.parametrize("cut", ["gap", "short"])
def test_odometry_must_cover_every_frame(tour, tmp_path, capsys, cut):
    odo = pd.read_csv(tour / "odometry.csv")
    odo = odo[(odo["frame"] < 20) | (odo["frame"] >= 40)] if cut == "gap" else odo.iloc[:30]
    path = tmp_path / "odo.csv"
    odo.to_csv(path, index=False)
    out = tmp_path / "pos.csv"
    with pytest.raises(InputFormatError, match="no odometry for frame"):
        position_tour(tour, out, results=tmp_path / "res.txt", odometry=path)
    assert main(["position", str(tour), "--results", str(tmp_path / "res.txt"),
                 "--odometry", str(path), "--out", str(out), "--quiet"]) == 1
    assert "must cover every frame" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize("column,value,message", [
    ("speed", "1e300", "beyond 100 m/s"),
    ("frame", "99999999999999999999", "frame"),
    ("stamp", "1e300", "stamp"),
])
def test_absurd_speeds_and_frames_are_refused(tour, tmp_path, column, value, message):
    text = (tour / "odometry.csv").read_text().splitlines()
    header = text[0].split(",")
    row = text[-1].split(",")
    row[header.index(column)] = value
    path = tmp_path / "odo.csv"
    path.write_text("\n".join([*text[:-1], ",".join(row)]) + "\n")
    with pytest.raises(InputFormatError, match=message):
        read_odometry(path)
    out = tmp_path / "pos.csv"
    with pytest.raises(InputFormatError):
        position_tour(tour, out, results=tmp_path / "res.txt", odometry=path)
    assert not out.exists()
