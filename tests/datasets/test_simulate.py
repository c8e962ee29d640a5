"""Writing a simulated run or tour to a folder: datasets/_simulate.py."""

import pytest

from tunnelsense.datasets._simulate import simulate_to_folder
from tunnelsense.io import read_run


def test_simulate_to_folder_writes_a_run_and_never_writes_over_files(tmp_path):
    what = simulate_to_folder("street", tmp_path / "run", 200, random_state=2)
    assert what.startswith("200 scans, scenario ") and "seed 2" in what
    assert len(read_run(tmp_path / "run")) == 200
    with pytest.raises(FileExistsError, match="--force"):
        simulate_to_folder("street", tmp_path / "run", 200)
    simulate_to_folder("street", tmp_path / "run", 100, overwrite=True)
    assert len(read_run(tmp_path / "run")) == 100
    with pytest.raises(ValueError, match="kind"):
        simulate_to_folder("moon", tmp_path / "x", 10)
