import numpy as np
import pytest

from tunnelsense import FrameRecord
from tunnelsense.exceptions import InputFormatError
from tunnelsense.tunnel import TrajectoryLinker
from tunnelsense.tunnel._linking import (
    assign_pairs,
    gated_pairs,
    link_log_likelihood,
)
from tunnelsense.utils import record_stage_checks, sklearn_api_checks

IMG = np.zeros((120, 160), np.uint8)


def rec(frame, boxes, tour="t"):
    return FrameRecord(tour, frame, IMG, {"cluster_boxes": np.asarray(boxes, float).reshape(-1, 4)})


def moving(n, start=(10.0, 20.0), step=(3.0, -1.0), size=(4.0, 8.0), first=1, tour="t"):
    return [
        (first + k, [start[0] + step[0] * k, start[1] + step[1] * k, *size])
        for k in range(n)
    ]


def frames_of(*objects, tour="t"):
    per = {}
    for obj in objects:
        for f, box in obj:
            per.setdefault(f, []).append(box)
    return [rec(f, per[f], tour) for f in sorted(per)]


def ids(out):
    return [r.payload["track_ids"].tolist() for r in out]


def test_two_objects_keep_their_trajectories(global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    a = moving(20, start=(10, 20), step=(3, 1))
    b = moving(20, start=(140, 100), step=(-2, -1.5))
    X = frames_of(a, b)
    # cluster order within a frame must not matter
    X = [r.evolve(cluster_boxes=r.payload["cluster_boxes"][rng.permutation(2)]) for r in X]
    out = TrajectoryLinker().fit_transform(X)
    for r_in, r_out in zip(X, out, strict=True):
        left = r_in.payload["cluster_boxes"][:, 0]
        t = r_out.payload["track_ids"]
        assert t.dtype == np.int64
        assert t[np.argmin(left)] != t[np.argmax(left)]
    first = {tuple(np.sort(r.payload["track_ids"])) for r in out}
    assert first == {(1, 2)}


def test_input_order_does_not_matter(global_random_seed):
    X = frames_of(moving(15), moving(15, start=(100, 90), step=(-1, -2)))
    perm = np.random.default_rng(global_random_seed).permutation(len(X))
    shuffled = [X[i] for i in perm]
    a = TrajectoryLinker().fit_transform(X)
    b = TrajectoryLinker().fit_transform(shuffled)
    assert [r.key for r in b] == [X[i].key for i in perm]
    for i, r in zip(perm, b, strict=True):
        assert np.array_equal(r.payload["track_ids"], a[i].payload["track_ids"])


def test_tours_never_share_a_trajectory():
    X = frames_of(moving(5), tour="a") + frames_of(moving(5, first=6), tour="b")
    out = TrajectoryLinker().fit_transform(X)
    assert ids(out) == [[1]] * 10  # numbered per tour, but two separate tracks
    X2 = frames_of(moving(10))
    assert ids(TrajectoryLinker().fit_transform(X2)) == [[1]] * 10


@pytest.mark.parametrize("missing, linked", [(2, True), (3, True), (4, False)])
def test_max_gap(missing, linked):
    obj = moving(12, step=(1, 0))
    kept = [o for o in obj if not (5 <= o[0] < 5 + missing)]
    out = TrajectoryLinker(max_gap=3).fit_transform(frames_of(kept))
    assert (len(set(sum(ids(out), []))) == 1) is linked


@pytest.mark.parametrize("speed", [1.0, 0.25, 0.05])
def test_max_gap_travel_bridges_the_same_stretch_of_path_at_any_speed(speed):
    # the object misses the same 2.5 px of its path (0.44 of its size, 5.66 px):
    # 2 frames at 1 px per frame, 10 at 0.25, 50 at 0.05
    missing = round(2.5 / speed) - 1
    obj = moving(30 + missing, step=(speed, 0))
    kept = [o for o in obj if not (15 <= o[0] < 15 + missing)]
    n_tracks = {
        travel: len(set(sum(ids(TrajectoryLinker(
            max_gap=2, max_gap_travel=travel).fit_transform(frames_of(kept))), [])))
        for travel in (None, 0.5, 0.4)
    }
    assert n_tracks[0.5] == 1  # 2.5 px are 0.44 sizes: bridged at any speed
    assert n_tracks[0.4] == (1 if missing <= 2 else 2)  # beyond: max_gap frames only
    assert n_tracks[None] == (1 if missing <= 2 else 2)


def test_max_gap_travel_needs_a_speed_and_keeps_the_duration_limit():
    still = moving(40, step=(0.0, 0.0))
    # two positions: no speed to go by, max_gap frames only
    two = [o for o in still if o[0] <= 2 or o[0] >= 20]
    out = TrajectoryLinker(max_gap=3, max_gap_travel=0.5).fit_transform(frames_of(two))
    assert len(set(sum(ids(out), []))) == 2
    # a still object bridges any gap, up to max_track_length frames in all
    three = [o for o in still if o[0] <= 3 or o[0] >= 20]
    out = TrajectoryLinker(max_gap=3, max_gap_travel=0.5).fit_transform(frames_of(three))
    assert len(set(sum(ids(out), []))) == 1
    out = TrajectoryLinker(max_gap=3, max_gap_travel=0.5,
                           max_track_length=30).fit_transform(frames_of(three))
    assert sum(ids(out), []) == [1] * 14 + [2] * 10  # frames 1-3 and 20-30, then 31-40
    assert out[13].payload["ended_tracks"].tolist() == [1]  # frame 30: it ends there



def test_max_gap_travel_refuses_an_unbounded_duration():
    # a still object would bridge every gap: without max_track_length it never ends
    X = frames_of(moving(5, step=(0.0, 0.0)))
    with pytest.raises(ValueError, match="max_track_length"):
        TrajectoryLinker(max_gap_travel=0.5, max_track_length=None).fit(X)
    TrajectoryLinker(max_gap_travel=None, max_track_length=None).fit(X)

def test_frame_gap_in_records_breaks_trajectories():
    obj = moving(10, step=(0.5, 0))
    X = frames_of(obj[:5]) + frames_of([(f + 10, b) for f, b in obj[5:]])
    out = TrajectoryLinker(max_gap=3).fit_transform(X)
    assert sum(ids(out), []) == [1] * 5 + [2] * 5


def test_scale_change_limit():
    grow = [(1, [50, 50, 4, 8]), (2, [48, 46, 18, 36])]  # x4.5 in size
    assert ids(TrajectoryLinker().fit_transform(frames_of(grow))) == [[1], [2]]
    assert ids(TrajectoryLinker(max_scale_change=5, gate=3).fit_transform(frames_of(grow))) == [
        [1],
        [1],
    ]


def test_straight_line_prediction_follows_fast_motion():
    # steps grow to 22 px per frame, beyond the 12 px gate around the last position
    # of a 4x8 box; the straight-line prediction keeps the trajectory whole
    x = 10 + np.cumsum([0, 8, 10, 12, 14, 16, 18, 20, 22])
    fast = [(k + 1, [float(v), 50.0, 4.0, 8.0]) for k, v in enumerate(x)]
    assert ids(TrajectoryLinker().fit_transform(frames_of(fast))) == [[1]] * len(x)
    assert (np.diff(x)[3:] > 12).all()


def test_link_log_likelihood_gates():
    h = np.full(4, 0.25)
    ll = link_log_likelihood((0, 0), 10.0, h, (1, 1), 11.0, h, 1)
    assert -1 < ll < 0
    assert link_log_likelihood((0, 0), 10.0, h, (0, 0), 41.0, h, 1) == -np.inf
    assert link_log_likelihood((0, 0), 10.0, h, (30, 0), 10.0, h, 1) == -np.inf
    other = np.array([1.0, 0, 0, 0])
    assert link_log_likelihood((0, 0), 10.0, other, (1, 1), 11.0, h, 1) < ll
    assert link_log_likelihood((0, 0), 10.0, h, (1, 1), 11.0, h, 3) == pytest.approx(ll - 2)


def test_greedy_and_hungarian_assignment():
    # A-1 is the best pair; greedy takes it and leaves B unlinked, Hungarian links both.
    pairs = [(-0.1, 0, 0), (-1.0, 0, 1), (-1.0, 1, 0)]
    assert assign_pairs(list(pairs), 2, 2, hungarian=False) == [(0, 0)]
    assert sorted(assign_pairs(list(pairs), 2, 2, hungarian=True)) == [
        (0, 1),
        (1, 0),
    ]


def test_duplicate_frames_rejected():
    X = [rec(1, [[0, 0, 4, 8]]), rec(1, [[0, 0, 4, 8]])]
    with pytest.raises(ValueError, match="twice"):
        TrajectoryLinker().fit(X)


def test_histograms_of_the_wrong_length_are_refused():
    X = [rec(f, [[10.0 + f, 20, 4, 8]]) for f in (1, 2)]
    X[1] = X[1].evolve(cluster_histograms=np.full((2, 32), 1 / 32))
    with pytest.raises(ValueError, match=r"X\[1\].*cluster_histograms.*\(1, bins\)"):
        TrajectoryLinker().fit(X)
    with pytest.raises(ValueError, match="cluster_histograms"):
        TrajectoryLinker().fit(X[:1]).start_stream().push_many(X)


def test_missing_clusters_is_a_clear_error():
    with pytest.raises(ValueError, match="MSTClusterer"):
        TrajectoryLinker().fit([FrameRecord("t", 1, IMG)])


_X = frames_of(moving(6), moving(6, start=(100, 90), step=(-1, -2)))
_Y = [np.empty((0, 4))] * len(_X)


@pytest.mark.parametrize("assignment", ["greedy", "hungarian"])
def test_record_stage_checks(assignment):
    for _, check in record_stage_checks(TrajectoryLinker(assignment=assignment), _X, _Y):
        check()


@pytest.mark.parametrize("name, check", list(sklearn_api_checks(TrajectoryLinker())))
def test_sklearn_api_checks(name, check):
    check()


def at_rate(records, fps):
    return [r.evolve(frame_rate=fps) for r in records]


@pytest.mark.parametrize("fps, missing, linked", [
    (30.0, 6, True), (30.0, 7, False),  # the counts as given
    (9.0, 2, True), (9.0, 3, False),  # 6 frames at 30 fps are 1.8 -> 2 at 9 fps
    (60.0, 12, True), (60.0, 13, False),  # and 12 at 60 fps
    (3.0, 1, True), (3.0, 2, False),  # scaled down, a trajectory still bridges one
])
def test_max_gap_follows_the_frame_rate(fps, missing, linked):
    obj = moving(30, step=(0.5, 0))
    kept = [o for o in obj if not (5 <= o[0] < 5 + missing)]
    out = TrajectoryLinker(max_gap=6).fit_transform(at_rate(frames_of(kept), fps))
    assert (len(set(sum(ids(out), []))) == 1) is linked


@pytest.mark.parametrize("fps, length", [(30.0, 20), (9.0, 7), (15.0, 10), (60.0, 40),
                                          (1.0, 7)])
def test_max_track_length_follows_the_frame_rate(fps, length):
    X = at_rate(frames_of(moving(80, step=(0.5, 0))), fps)
    out = sum(ids(TrajectoryLinker(max_track_length=20).fit_transform(X)), [])
    assert np.bincount(out).max() == length


def test_frames_without_a_frame_rate_or_frame_rate_none_count_frames():
    obj = moving(20, step=(0.5, 0))
    kept = [o for o in obj if not (5 <= o[0] < 8)]  # 3 missed frames
    X = frames_of(kept)
    linked = [1] * len(kept)
    assert sum(ids(TrajectoryLinker(max_gap=6).fit_transform(X)), []) == linked
    slow = at_rate(X, 9.0)  # 6 frames at 30 fps: 2 at 9 fps
    assert sum(ids(TrajectoryLinker(max_gap=6).fit_transform(slow)), []) != linked
    assert sum(ids(TrajectoryLinker(max_gap=6, frame_rate=None).fit_transform(slow)),
               []) == linked
    # the counts are given at frame_rate: 6 frames at 9 fps are 6 frames at 9 fps
    assert sum(ids(TrajectoryLinker(max_gap=6, frame_rate=9).fit_transform(slow)),
               []) == linked


def test_each_tour_follows_its_own_frame_rate():
    obj = moving(20, step=(0.5, 0))
    kept = [o for o in obj if not (5 <= o[0] < 8)]
    X = at_rate(frames_of(kept, tour="a"), 9.0) + at_rate(frames_of(kept, tour="b"), 30.0)
    out = TrajectoryLinker(max_gap=6).fit_transform(X)
    n = len(kept)
    assert len(set(sum(ids(out[:n]), []))) == 2 and len(set(sum(ids(out[n:]), []))) == 1
    # streaming gives the same
    state = TrajectoryLinker(max_gap=6).fit(X).start_stream()
    streamed = [o for r in X for o in state.push(r)] + state.close()
    assert ids(streamed) == ids(out)


@pytest.mark.parametrize("bad", [0, -9.0, float("nan"), float("inf"), "fast"])
def test_an_invalid_frame_rate_is_refused_naming_it(bad):
    # read as "unknown" it would silently count frames at 30 fps
    X = at_rate(frames_of(moving(10, step=(0.5, 0))), bad)
    with pytest.raises(InputFormatError, match=r'payload\["frame_rate"\].*positive finite'):
        TrajectoryLinker().fit_transform(X)


@pytest.mark.parametrize("gate, min_gate, max_scale_change", [
    (1.0, 12.0, 4.0), (2.5, 3.0, 1.5), (0.5, 20.0, 1.2)])
def test_gated_pairs_keep_every_pair_the_score_does_not_reject(
        gate, min_gate, max_scale_change, global_random_seed):
    """Only pairs whose score is ``-inf`` are left out; responses on the gate's edge
    (distance equal to it, along an axis) are kept."""
    rng = np.random.default_rng(global_random_seed)
    kw = dict(gate=gate, min_gate=min_gate, max_scale_change=max_scale_change)
    left_out = 0
    for _ in range(100):
        n, m = int(rng.integers(1, 6)), int(rng.integers(1, 30))
        px, py = rng.uniform(0, 640, (2, n))
        last = rng.uniform(0.5, 60.0, n)
        last[rng.random(n) < 0.2] = 0.0
        size = rng.uniform(0.0, 70.0, m)
        size[rng.random(m) < 0.1] = 0.0
        # responses around the first trajectory's gate, some on its edge exactly
        limit = np.maximum(np.maximum(size, last[0]) * gate, min_gate)
        d = limit * rng.choice([0.5, 1.0, 1.0 + 1e-12, 1.5], m)
        angle = rng.uniform(0, 2 * np.pi, m)
        cx, cy = px[0] + d * np.cos(angle), py[0] + d * np.sin(angle)
        axis = rng.random(m) < 0.2
        cx[axis], cy[axis] = px[0] + limit[axis], py[0]
        rows, cols = gated_pairs(px, py, last, cx, cy, size, **kw)
        kept = list(zip(rows, cols, strict=True))
        assert kept == sorted(set(kept))  # row-major, each pair once
        for i in range(n):
            for j in range(m):
                ll = link_log_likelihood((px[i], py[i]), last[i], None, (cx[j], cy[j]),
                                         size[j], None, 1, **kw)
                assert (i, j) in kept or ll == -np.inf, (i, j, ll)
        left_out += n * m - len(kept)
    assert left_out > 0  # the gate does leave pairs out


def test_a_trajectory_cut_at_max_track_length_is_continued_by_the_next_piece():
    """The linker says which trajectory continues the one it cut at
    max_track_length (the trajectories and ids are as without it), and that a cut
    trajectory whose object is lost is continued by none."""
    walker = moving(50, step=(2.0, -0.5))
    other = moving(50, start=(120.0, 90.0), step=(-1.0, 0.0))
    lost = [o for o in moving(50, start=(60.0, 100.0), step=(0.5, 0.0)) if o[0] <= 20]
    out = TrajectoryLinker(max_gap=3, max_track_length=20).fit_transform(
        frames_of(walker, other, lost))
    cut = {r.frame: r.payload["cut_tracks"].tolist() for r in out
           if len(r.payload["cut_tracks"])}
    continued = {r.frame: r.payload["continued_tracks"].tolist() for r in out
                 if len(r.payload["continued_tracks"])}
    assert ids(out)[0] == [1, 2, 3]
    assert ids(out)[20] == [4, 5]  # frame 21: new pieces, numbered as they are born
    assert cut == {20: [1, 2, 3], 40: [4, 5]}
    for r in out:  # every cut trajectory has ended
        assert set(r.payload["cut_tracks"].tolist()) <= set(r.payload["ended_tracks"].tolist())
    # frame 21: 4 continues 1, 5 continues 2; 3 is lost and waits out max_gap
    assert continued[21] == [[4, 1], [5, 2]]
    assert continued[25] == [[0, 3]]
    assert continued[41] == [[6, 4], [7, 5]]
    # a trajectory ending by the gap is not cut
    out = TrajectoryLinker(max_gap=3, max_track_length=20).fit_transform(
        frames_of(moving(10)))
    assert all(len(r.payload["cut_tracks"]) == 0 for r in out)
    assert out[-1].payload["continued_tracks"].shape == (0, 2)


def test_a_cut_still_object_is_given_up_within_max_track_length_frames():
    # with max_gap_travel a still object's fit bridges any gap: once lost, its cut
    # trajectory is given up within max_track_length frames (bounded memory)
    still = [o for o in moving(60, step=(0.0, 0.0)) if o[0] <= 20]
    walker = moving(60, start=(100.0, 100.0), step=(1.0, 0.0))
    out = TrajectoryLinker(max_gap=3, max_gap_travel=0.5, max_track_length=20).fit_transform(
        frames_of(still, walker))
    given_up = [r.frame for r in out for a, b in r.payload["continued_tracks"].tolist()
                if a == 0 and b == 1]
    assert given_up == [40]
