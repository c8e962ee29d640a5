"""Physics of the simulated camera's and recorder's artefacts: the flat-field
(NUC) shutter's frozen frames, dropped frames with gaps in the frame numbers, and
defective pixels and columns; each leaves every other frame as it was."""

import numpy as np
import pytest

from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.datasets._tunnel_sensor import nuc_freezes

SCENE = dict(first_indicator_m=30.0, speed_kmh=90.0, traffic_per_km=10.0)
N = 60


@pytest.fixture(scope="module")
def plain():
    return make_tunnel_tour(N, random_state=4, **SCENE)


def _same_frame(a, b):
    return np.array_equal(a.image, b.image)


def test_nuc_freeze_repeats_the_last_picture_and_its_ground_truth(plain):
    kw = dict(nuc_interval_s=(1.0, 1.5), nuc_freeze_s=(0.3, 0.5))
    tour = make_tunnel_tour(N, random_state=4, **kw, **SCENE)
    source = nuc_freezes(4, N, 30.0, (1.0, 1.5), (0.3, 0.5))
    frozen = np.flatnonzero(source != np.arange(N))
    assert tour.info["nuc_frozen_frames"] == len(frozen) > 0
    # every freeze lasts 0.3-0.5 s: 9-15 frames, each showing the frame before it
    starts = frozen[np.r_[True, np.diff(frozen) > 1]]
    ends = frozen[np.r_[np.diff(frozen) > 1, True]]
    assert all(9 <= e - s + 1 <= 15 for s, e in zip(starts, ends, strict=True))
    assert (source[frozen] == np.repeat(starts - 1, ends - starts + 1)).all()
    assert [r.frame for r in tour.frames] == list(range(1, N + 1))
    for f in range(N):
        assert _same_frame(tour.frames[f], plain.frames[source[f]])
        gt = tour.gt[tour.gt.frame == f + 1].drop(columns="frame").reset_index(drop=True)
        ref = plain.gt[plain.gt.frame == source[f] + 1].drop(columns="frame")
        assert gt.equals(ref.reset_index(drop=True))


def test_dropped_frames_leave_gaps_in_the_frame_numbers(plain):
    tour = make_tunnel_tour(N, random_state=4, dropped_frames=0.1, **SCENE)
    numbers = np.array([r.frame for r in tour.frames])
    assert numbers[0] == 1 and (np.diff(numbers) >= 1).all() and numbers[-1] <= N
    lost = N - len(numbers)
    assert tour.info["frames_dropped"] == lost and 2 <= lost <= 20
    assert (np.diff(numbers) > 1).any()
    # the frames kept are the camera's frames at their instants, truth and all
    for r in tour.frames:
        assert _same_frame(r, plain.frames[r.frame - 1])
    assert set(tour.gt.frame) <= set(numbers.tolist())
    kept = plain.gt[plain.gt.frame.isin(numbers)].reset_index(drop=True)
    assert tour.gt.equals(kept)
    assert tour.frames[0].payload["frame_rate"] == 30.0


def test_sequential_numbers_lose_the_time_of_lost_frames(plain):
    kw = dict(dropped_frames=0.1, **SCENE)
    counter = make_tunnel_tour(N, random_state=4, **kw)
    tour = make_tunnel_tour(N, random_state=4, frame_numbers="sequential", **kw)
    assert tour.info["frame_numbers"] == "sequential"
    assert [r.frame for r in tour.frames] == list(range(1, len(counter) + 1))
    for a, b in zip(tour.frames, counter.frames, strict=True):
        assert np.array_equal(a.image, b.image)
        ga = tour.gt[tour.gt.frame == a.frame].drop(columns="frame")
        gb = counter.gt[counter.gt.frame == b.frame].drop(columns="frame")
        assert ga.reset_index(drop=True).equals(gb.reset_index(drop=True))


def test_defective_pixels_and_dead_column_are_fixed_in_every_frame(plain):
    tour = make_tunnel_tour(N, random_state=4, defect_pixels=0.002, dead_columns=1,
                            **SCENE)
    a = np.stack([r.image for r in tour.frames]).astype(np.int16)
    b = np.stack([r.image for r in plain.frames]).astype(np.int16)
    changed = (a != b).any(axis=0)
    # the defects stay put: each changed pixel reads one level in every frame
    assert (a[:, changed] == a[0, changed]).all()
    dead = np.flatnonzero((a == 0).all(axis=(0, 1)))
    assert len(dead) == 1 and changed[:, dead[0]].mean() > 0.9
    stuck = changed.copy()
    stuck[:, dead[0]] = False
    n = int(round(0.002 * a.shape[1] * a.shape[2]))
    assert n * 0.8 <= stuck.sum() <= n  # a stuck level may equal a pixel's own
    levels = a[0, stuck]
    assert (levels == 255).mean() > 0.2 and (levels == 0).mean() > 0.2
    assert tour.gt.equals(plain.gt)


def test_default_tour_names_no_artefact(plain):
    for key in ("nuc_interval_s", "dropped_frames", "defect_pixels", "dead_columns",
                "frames_dropped", "nuc_frozen_frames", "frame_numbers"):
        assert key not in plain.info


@pytest.mark.parametrize("kwargs, match", [
    (dict(nuc_interval_s=(0.0, 10.0)), "nuc_interval_s"),
    (dict(nuc_interval_s=(10.0, 5.0)), "nuc_interval_s"),
    (dict(nuc_interval_s=(10.0, 20.0), nuc_freeze_s=(0.1, 0.2, 0.3)), "nuc_freeze_s"),
    (dict(dropped_frames=0.7), "dropped_frames"),
    (dict(defect_pixels=-0.1), "defect_pixels"),
    (dict(dead_columns=1.5), "dead_columns"),
    (dict(dead_columns=True), "dead_columns"),
    (dict(frame_numbers="camera"), "frame_numbers"),
])
def test_bad_artefact_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        make_tunnel_tour(2, random_state=0, **kwargs)
