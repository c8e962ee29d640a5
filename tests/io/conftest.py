"""The small MOTChallenge tour the reader tests share (8- and 16-bit frames)."""

import numpy as np
import pandas as pd
import pytest

from tunnelsense import Tour


def _gt():
    return pd.DataFrame(
        {
            "frame": [1, 2, 2, 3],
            "id": [1, 1, 2, 5],
            "bb_left": [1.5, 2.25, 3.0, 0.1],
            "bb_top": [1.0, 2.0, 3.1, 0.2],
            "bb_width": [4.0, 5.0, 6.0, 1 / 3],
            "bb_height": [7.0, 8.0, 9.0, 2.0],
            "conf": 1.0,
            "class": [1, 1, 2, 4],
            "visibility": [1.0, 0.5, 1 / 3, 0.9],
        }
    )


@pytest.fixture(params=[np.uint8, np.uint16], ids=["8bit", "16bit"])
def tour(request, global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    info = np.iinfo(request.param)
    images = rng.integers(0, info.max, (4, 24, 32), dtype=request.param, endpoint=True)
    return Tour.from_array(
        "seq-a",
        images,
        _gt(),
        frame_rate=25.0,
        info={"scenario": "light", "focal_px": 512.5},
    )
