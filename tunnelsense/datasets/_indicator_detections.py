"""The indicator detector's output, simulated from where the signs stand.

A stand-in for a rendered tour's detections when a positioning experiment needs
thousands of tours: each indicator of a :class:`~tunnelsense.datasets.TourKinematics`
becomes one trajectory whose box follows the pinhole model, with noise, misses and
false alarms on request.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from sklearn.utils import check_random_state

__all__ = ["simulate_indicator_detections"]


def simulate_indicator_detections(
    kinematics,
    *,
    focal_length_px=800.0,
    sign_height_m=1.0,
    min_height_px=12.0,
    exit_depth_m=9.3,
    box_noise=0.03,
    missed=(),
    false_alarms=(),
    random_state=None,
):
    """The indicator detector's output, simulated from where the signs stand.

    Each indicator is detected, as one trajectory, from the frame its box grows to
    ``min_height_px`` until it leaves the image (``exit_depth_m`` ahead, plus up to
    2 m earlier at random); its box height is ``focal_length_px * sign_height_m /
    depth`` with relative noise ``box_noise``; it stands 3.7 m beside the camera on
    its wall (``kinematics.side``), so its box drifts outwards on that side as it
    grows.  A false alarm is a trajectory of an object that looks like an indicator
    but stands elsewhere (on the left wall).

    Parameters
    ----------
    kinematics : TourKinematics
    focal_length_px : float, default=800.0
    sign_height_m : float, default=1.0
    min_height_px : float, default=12.0
    exit_depth_m : float, default=9.3
        Depth at which a sign leaves the image.
    box_noise : float, default=0.03
        Relative standard deviation of the box height.
    missed : sequence of int, default=()
        Ids of indicators the detector misses.
    false_alarms : sequence of float, default=()
        Chainages of false alarms: each gives a trajectory of an indicator-sized
        object standing there.
    random_state : int, RandomState instance or None, default=None

    Returns
    -------
    detections : DataFrame
        MOTChallenge results rows ``frame, id, bb_left, bb_top, bb_width, bb_height,
        conf``.
    """
    rng = check_random_state(random_state)
    s = np.asarray(kinematics.chainage, np.float64)
    missed = {int(m) for m in missed}
    sides = np.broadcast_to(np.asarray(kinematics.side),
                            np.shape(kinematics.indicator_ids))
    objects = [
        (int(i), float(c), str(side) == "right")
        for i, c, side in zip(kinematics.indicator_ids,
                              kinematics.indicator_chainage, sides, strict=True)
        if int(i) not in missed
    ]
    next_id = int(max(kinematics.indicator_ids, default=0)) + 1
    objects += [(next_id + k, float(c), False) for k, c in enumerate(false_alarms)]
    fh = float(focal_length_px) * float(sign_height_m)
    rows = []
    for oid, c, right in objects:
        depth = c - s
        end = exit_depth_m + rng.uniform(0.0, 2.0)
        seen = np.flatnonzero((depth >= end) & (fh / np.maximum(depth, 1e-9)
                                                >= min_height_px))
        if len(seen) < 2:
            continue
        h = fh / depth[seen] * (1.0 + box_noise * rng.standard_normal(len(seen)))
        w = 0.45 * h
        if right:  # the box's left edge 3.7 m right of the camera
            left = 320.0 + focal_length_px * 3.7 / depth[seen]
        else:  # its right edge 3.7 m left of it
            left = 320.0 - focal_length_px * 3.7 / depth[seen] - w
        top = 240.0 - focal_length_px * 1.1 / depth[seen] - h / 2
        rows.extend(zip(seen + 1, [oid] * len(seen), left, top, w, h,
                        [1.0] * len(seen), strict=True))
    cols = ["frame", "id", "bb_left", "bb_top", "bb_width", "bb_height", "conf"]
    out = pd.DataFrame(rows, columns=cols).astype({"frame": np.int64, "id": np.int64})
    return out.sort_values(["frame", "id"], kind="stable").reset_index(drop=True)
