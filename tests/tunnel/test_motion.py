import numpy as np
import pytest

from tunnelsense import FrameRecord
from tunnelsense.tunnel import PCCVerifier, pearson_r
from tunnelsense.utils import record_stage_checks, sklearn_api_checks

IMG = np.zeros((120, 160), np.uint8)


def track_frames(tracks, tour="t"):
    """tracks: {track_id: [(frame, box, appearance), ...]} -> records."""
    per = {}
    for tid, items in tracks.items():
        for f, box, app in items:
            per.setdefault(f, []).append((box, app, tid))
    out = []
    for f in sorted(per):
        boxes, app, tids = zip(*per[f], strict=True)
        out.append(
            FrameRecord(
                tour, f, IMG,
                {
                    "cluster_boxes": np.array(boxes, float),
                    "appearance": np.array(app, bool),
                    "track_ids": np.array(tids, np.int64),
                },
            )
        )
    return out


def line(n, app=True, first=1, start=(100, 80), step=(-4, -1.5)):
    apps = app if isinstance(app, list) else [app] * n
    return [
        (first + k, [start[0] + step[0] * k, start[1] + step[1] * k, 4, 8], apps[k])
        for k in range(n)
    ]


def still(n, rng, first=1):
    return [(first + k, [60 + rng.normal(0, 1.5), 90 + rng.normal(0, 1.5), 20, 10], True) for k in range(n)]


def test_pearson_r_matches_numpy(global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    x, y = rng.normal(size=30), rng.normal(size=30)
    assert pearson_r(x, y) == pytest.approx(np.corrcoef(x, y)[0, 1])
    assert pearson_r([1, 2, 3], [7, 7, 7]) == 0.0


def test_straight_track_detected_still_track_not(global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    X = track_frames({1: line(20), 2: still(20, rng)})
    out = PCCVerifier().fit(X).predict(X)
    for r in out:
        p = r.payload
        assert p["indicator"].tolist() == [True, False]
        assert p["trajectory_positive"].tolist() == [True, False]
        assert abs(p["motion_r"][0]) > 0.99 and abs(p["motion_r"][1]) < 0.95
        det = p["detections"]
        assert det.shape == (1, 6)
        np.testing.assert_array_equal(det[0, :4], p["cluster_boxes"][0])
        assert det[0, 4] == 1 and det[0, 5] == 1.0


def test_min_length():
    X = track_frames({1: line(6)})
    assert not PCCVerifier(min_length=10).fit(X).predict(X)[0].payload["indicator"].any()
    assert PCCVerifier(min_length=6).fit(X).predict(X)[0].payload["indicator"].all()


@pytest.mark.parametrize("n_negative, positive", [(3, True), (5, False)])
def test_vote_more_than_80_percent(n_negative, positive):
    # 20 clusters: 3 negative -> 85 % positive; 5 negative -> 75 %
    app = [True] * (20 - n_negative) + [False] * n_negative
    X = track_frames({7: line(20, app=app)})
    out = PCCVerifier(vote=0.8).fit(X).predict(X)
    assert all(r.payload["trajectory_positive"][0] == positive for r in out)
    # the indicator decisions follow appearance; detections cover the whole trajectory
    assert [bool(r.payload["indicator"][0]) for r in out] == app
    assert sum(len(r.payload["detections"]) for r in out) == (20 if positive else 0)


def test_tracks_are_per_tour():
    # the same track id in two tours: two trajectories, neither straight alone? each is.
    a = track_frames({1: line(12)}, tour="a")
    b = track_frames({1: line(12, start=(20, 20), step=(3, 3))}, tour="b")
    out = PCCVerifier().fit(a + b).predict(a + b)
    assert all(r.payload["trajectory_length"][0] == 12 for r in out)


def test_missing_payload_is_a_clear_error():
    X = track_frames({1: line(3)})
    bad = [X[0].evolve(track_ids=np.array([1, 2]))]
    with pytest.raises(ValueError, match="track_ids"):
        PCCVerifier().fit(bad)
    no_app = [FrameRecord("t", 1, IMG, {"cluster_boxes": np.zeros((1, 4)), "track_ids": np.ones(1)})]
    with pytest.raises(ValueError, match="WeightedAdaBoost"):
        PCCVerifier().fit(no_app)


def test_no_clusters_at_all():
    X = [FrameRecord("t", 1, IMG, {"cluster_boxes": np.empty((0, 4)), "appearance": np.empty(0, bool), "track_ids": np.empty(0, np.int64)})]
    out = PCCVerifier().fit(X).predict(X)
    assert out[0].payload["detections"].shape == (0, 6)


_X = track_frames({1: line(12), 2: line(12, start=(20, 100), step=(0.2, 0.1))})
_Y = [np.empty((0, 4))] * len(_X)


@pytest.mark.parametrize(
    "name, check", list(record_stage_checks(PCCVerifier(), _X, _Y, method="predict"))
)
def test_record_stage_checks(name, check):
    check()


@pytest.mark.parametrize("name, check", list(sklearn_api_checks(PCCVerifier())))
def test_sklearn_api_checks(name, check):
    check()


def test_principal_criterion_accepts_straight_lines_of_any_direction():
    """Pearson's r is 0 on a horizontal line; the principal-axis measure is 1."""
    from tunnelsense import FrameRecord
    from tunnelsense.tunnel import PCCVerifier, straightness

    img = np.zeros((48, 64), np.uint8)

    def frames(dx, dy, jitter=0.0):
        rng = np.random.default_rng(0)
        return [
            FrameRecord("t", f, img, {
                "cluster_boxes": np.array([[10.0 + dx * f + jitter * rng.normal(),
                                            20.0 + dy * f + jitter * rng.normal(), 4, 8]]),
                "appearance": np.array([True]),
                "track_ids": np.array([1]),
            })
            for f in range(1, 16)
        ]

    horizontal = frames(3, 0)
    assert len(PCCVerifier().fit(horizontal).predict(horizontal)[0].payload["detections"]) == 0
    principal = PCCVerifier(criterion="principal").fit(horizontal).predict(horizontal)
    assert len(principal[0].payload["detections"]) == 1
    still = frames(0, 0, jitter=2.0)  # a vehicle ahead: jitter, no line
    out = PCCVerifier(criterion="principal").fit(still).predict(still)
    assert all(len(r.payload["detections"]) == 0 for r in out)
    assert straightness([0, 1, 2], [0, 2, 4]) == pytest.approx(1.0)


def test_path_travel_is_a_ratio_of_lengths():
    from tunnelsense.tunnel._pcc_stream import path_travel

    x, y, h = np.arange(12.0) * 3, np.arange(12.0), np.full(12, 10.0)
    assert path_travel(x, y, h) == pytest.approx(path_travel(2 * x, 2 * y, 2 * h))
    assert path_travel(x, y, h) == pytest.approx(np.hypot(24, 8) / 10)
    assert path_travel([5.0], [5.0], [10.0]) == 0.0


def test_min_travel_rejects_a_box_that_jitters_along_a_line_in_place():
    """A rectangle anchored at its top-left corner whose size jitters moves its
    centre along one diagonal: a "path" with r near 1, but it goes nowhere."""
    rng = np.random.default_rng(0)
    grow = rng.uniform(0, 6, 20)
    jitter = [(k + 1, [80.0, 40.0, 8 + grow[k], 16 + 2 * grow[k]], True) for k in range(20)]
    X = track_frames({1: jitter, 2: line(20)})
    for min_travel, expected in ((0.0, {1, 2}), (0.25, {2})):
        out = PCCVerifier(criterion="quadratic", min_travel=min_travel).fit(X).predict(X)
        found = {int(d[4]) for r in out for d in r.payload["detections"]}
        assert found == expected


@pytest.mark.parametrize("fps, shortest", [
    (30.0, 10),  # the count as given
    (9.0, 7),  # 10 frames at 30 fps are 3 at 9 fps, but never fewer than 7 points
    (15.0, 7),
    (60.0, 20),
    (45.0, 15),
])
def test_min_length_follows_the_frame_rate(fps, shortest):
    for n in (shortest - 1, shortest):
        X = [r.evolve(frame_rate=fps) for r in track_frames({1: line(n)})]
        found = PCCVerifier(min_length=10).fit(X).predict(X)[0].payload["indicator"]
        assert bool(found.all()) == (n == shortest)


def test_min_length_below_the_floor_is_kept_and_none_counts_frames():
    X = [r.evolve(frame_rate=9.0) for r in track_frames({1: line(5)})]
    # 5 frames at 30 fps: scaled to 2, kept at 5 (the floor never raises a count)
    assert PCCVerifier(min_length=5).fit(X).predict(X)[0].payload["indicator"].all()
    X = [r.evolve(frame_rate=9.0) for r in track_frames({1: line(8)})]
    assert not PCCVerifier(frame_rate=None).fit(X).predict(X)[0].payload["indicator"].any()
    assert PCCVerifier().fit(X).predict(X)[0].payload["indicator"].all()
    # streaming decides the same
    state = PCCVerifier().fit(X).start_stream()
    out = [o for r in X for o in state.push(r)] + state.close()
    assert out[0].payload["indicator"].all()


def approach(n, first_height, last_height, first=1):
    """A sign growing from ``first_height`` to ``last_height`` as the camera covers
    its range: height ``f H / Z``, Z falling linearly in time; its centre moves
    away from the vanishing point (100, 80) in proportion to its height."""
    z = np.linspace(1.0 / first_height, 1.0 / last_height, n)
    h = 1.0 / z
    return [(first + k, [100 - 2 * h[k], 80 - 0.5 * h[k], h[k] / 2, h[k]], True)
            for k in range(n)]


def test_approach_fraction_is_the_range_covered():
    from tunnelsense.tunnel._pcc_stream import approach_fraction

    # heights f H / Z: from 50 m to 25 m the range is halved, whatever f H
    for fh in (700.0, 350.0, 1000.0):
        h = fh / np.linspace(50.0, 25.0, 12)
        k = 4  # the medians of the first and last four
        expected = 1 - np.median(h[:k]) / np.median(h[-k:])
        assert approach_fraction(h) == pytest.approx(expected)
        assert approach_fraction(h) == pytest.approx(approach_fraction(h / 2))
    assert approach_fraction(np.full(9, 20.0)) == 0.0
    assert approach_fraction(np.linspace(40, 20, 9)) < 0  # receding
    assert approach_fraction([30.0]) == 0.0


def test_min_approach_accepts_a_short_trajectory_that_approaches():
    near = approach(8, 45.0, 100.0)  # a near sign at speed: 8 points, range more than halved
    still = [(k + 1, [60 + (k % 2), 40 - (k % 3), 10, 20 + (k % 2)], True) for k in range(8)]
    short_line = line(8, first=1, start=(300, 200))  # 8 points, a straight path, no growth
    X = track_frames({1: near, 2: still, 3: short_line})
    found = {}
    for min_approach in (None, 0.3):
        out = PCCVerifier(criterion="quadratic-motion", min_approach=min_approach).fit(X).predict(X)
        found[min_approach] = {int(d[4]) for r in out for d in r.payload["detections"]}
    assert found[None] == set()  # the paper's rule: 8 < min_length
    assert found[0.3] == {1}
    # never below the floor of 7 points, however much it approaches
    X = track_frames({1: approach(6, 45.0, 120.0)})
    out = PCCVerifier(min_approach=0.1).fit(X).predict(X)
    assert not out[0].payload["indicator"].any()


def test_min_approach_is_validated():
    X = track_frames({1: line(12)})
    for bad in (0.0, 1.0, -0.2, "0.3"):
        with pytest.raises((ValueError, TypeError), match="min_approach"):
            PCCVerifier(min_approach=bad).fit(X)


def test_motion_fit_counts_time_in_frame_numbers():
    """Frames a recorder lost leave gaps in the frame numbers: the motion in time
    still fits when the numbers are the times; numbered as if consecutive, the
    same positions jump."""
    from tunnelsense.tunnel._pcc_stream import motion_fit_r

    t = np.array([1, 2, 3, 6, 7, 8, 12, 13, 14, 15], float)
    z = 40.0 - 0.8 * t  # metres: the camera approaches at constant speed
    x, y = 320 - 2100 / z, 240 - 700 / z  # image position ~ 1 / Z
    assert motion_fit_r(t, x, y) > 0.999
    assert motion_fit_r(np.arange(10.0), x, y) < motion_fit_r(t, x, y) - 0.005


def shaken_sign(n, z_first, z_last, jitter, first=1):
    """A sign approached from ``z_first`` to ``z_last`` metres (700 px focal
    length, a 1 m sign), its image position shaken by ``jitter`` (n, 2) pixels,
    the camera's vibration; its height (the box's) is whole pixels."""
    z = np.linspace(z_first, z_last, n)
    h = np.round(700.0 / z)
    return [(first + k, [300 - 2.2 * 700.0 / z[k] + jitter[k, 0],
                         200 - 0.6 * 700.0 / z[k] + jitter[k, 1], h[k] / 2, h[k]], True)
            for k in range(n)]


def test_min_scale_r_passes_a_far_sign_under_camera_vibration():
    """The trajectory of a far sign shaken by 2.5 px a frame fits no smooth path,
    but its size grows steadily; a vehicle ahead (jittering, keeping or opening
    its distance) passes neither way."""
    rng = np.random.default_rng(3)
    n = 25
    sign = shaken_sign(n, 50.0, 35.0, rng.normal(0.0, 2.5, (n, 2)))
    ahead = [(k + 1, [60 + rng.normal(0, 2.5), 40 + rng.normal(0, 2.5), 10,
                      20 + rng.integers(-1, 2)], True) for k in range(n)]
    z = np.linspace(30.0, 45.0, n)  # a vehicle pulling away
    away = [(k + 1, [150 + rng.normal(0, 2.5) - 0.2 * k, 90 + rng.normal(0, 2.5),
                     700.0 / z[k], np.round(1400.0 / z[k])], True) for k in range(n)]
    X = track_frames({1: sign, 2: ahead, 3: away})
    found = {}
    for min_scale_r in (None, 0.95):
        out = PCCVerifier(criterion="quadratic-motion", min_travel=0.25,
                          min_scale_r=min_scale_r).fit(X).predict(X)
        found[min_scale_r] = {int(d[4]) for r in out for d in r.payload["detections"]}
    assert found == {None: set(), 0.95: {1}}


def test_approach_r_is_a_ratio_of_sizes():
    from tunnelsense.tunnel._pcc_measures import approach_r

    t = np.arange(1.0, 21.0)
    h = 700.0 / np.linspace(50.0, 30.0, 20)
    assert approach_r(t, h) == pytest.approx(1.0)
    assert approach_r(t, 3 * h) == pytest.approx(1.0)  # another resolution or size
    assert approach_r(t, h[::-1]) == pytest.approx(-1.0)  # receding
    assert approach_r(t, np.full(20, 14.0)) == 0.0
    assert approach_r(t[:2], h[:2]) == 0.0
    with pytest.raises(ValueError, match="min_scale_r"):
        PCCVerifier(min_scale_r=0.0).fit(track_frames({1: line(12)}))


# --------------------------------------------------------------------------------------
# trajectories cut at the linker's max_track_length: carry_travel
# --------------------------------------------------------------------------------------
def crawling(n, step, stop=None, jitter=0.6, seed=0):
    """One warm sign crawling along a line (``step`` px a frame), jittering by
    ``jitter`` px; after frame ``stop`` it stands still."""
    rng = np.random.default_rng(seed)
    x, y, out = 100.0, 70.0, []
    for f in range(1, n + 1):
        if stop is None or f <= stop:
            x, y = x + step[0], y + step[1]
        j = rng.normal(0.0, jitter, 2)
        out.append(FrameRecord("t", f, IMG, {
            "cluster_boxes": np.array([[x + j[0] - 2, y + j[1] - 4, 4, 8]]),
            "appearance": np.array([True])}))
    return out


def carried_detections(X, carry_travel, max_track_length=40):
    from tunnelsense.tunnel import TrajectoryLinker

    linked = TrajectoryLinker(max_track_length=max_track_length).fit_transform(X)
    out = PCCVerifier(criterion="quadratic-motion", min_travel=0.25,
                      carry_travel=carry_travel).fit(linked).predict(linked)
    return sorted({int(d[4]) for r in out for d in r.payload["detections"]})


def test_carry_travel_checks_a_crawling_sign_on_the_path_it_continues():
    """Cut into pieces of 40 frames, over each of which it moves half its height
    against its jitter, a crawling sign's pieces fit no path on their own; joined to
    the pieces before, the second and later do."""
    X = crawling(160, (0.12, 0.05))
    assert carried_detections(X, None) == []
    assert carried_detections(X, 0.25) == [2, 3, 4]
    # without cuts nothing is carried: the same as each piece on its own
    assert carried_detections(X, 0.25, max_track_length=None) == carried_detections(
        X, None, max_track_length=None)


def test_carry_travel_accepts_no_piece_that_stood_still():
    """The first piece moves well (a sign, found); the queue then stops: the later
    pieces, jitter in place, are not accepted because the first one moved."""
    X = crawling(160, (0.3, 0.12), stop=40)
    assert carried_detections(X, None) == [1]
    assert carried_detections(X, 0.25) == [1]


def test_carried_travel_is_the_motion_along_the_path_in_sizes():
    from tunnelsense.tunnel._pcc_stream import carried_travel

    # the piece goes on along the path, 4.47 px over a median height of 5
    assert carried_travel([0, 2, 4], [0, 1, 2], [6, 8, 10], [3, 4, 5],
                          [5, 5, 5]) == pytest.approx(np.hypot(4, 2) / 5)
    # backwards along it: negative; standing still: 0
    assert carried_travel([0, 2, 4], [0, 1, 2], [10, 8, 6], [5, 4, 3], [5] * 3) < 0
    assert carried_travel([0, 2, 4], [0, 1, 2], [6, 6, 6], [3, 3, 3], [5] * 3) == 0.0
    assert carried_travel([], [], [6], [3], [5]) == 0.0
    # doubling every length (a finer sensor) keeps it
    assert carried_travel([0, 4, 8], [0, 2, 4], [12, 16, 20], [6, 8, 10],
                          [10] * 3) == pytest.approx(np.hypot(4, 2) / 5)


def test_carry_travel_is_validated():
    X = crawling(12, (1.0, 0.5))
    with pytest.raises(ValueError, match="carry_travel"):
        PCCVerifier(carry_travel=-0.1).fit(X)
