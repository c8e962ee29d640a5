"""Streaming the FIR indicator detector: identical to batch, bounded memory and delay."""

import numpy as np
import pytest

from tunnelsense import FrameRecord, FrameSequence, to_xy
from tunnelsense._streaming import StreamingPipeline
from tunnelsense.datasets import TUNNEL_SCENARIOS, make_tunnel_tour
from tunnelsense.tunnel import PCCVerifier, TrajectoryLinker, make_indicator_pipeline
from tunnelsense.utils import assert_records_equal


@pytest.fixture(scope="module")
def model():
    tour = make_tunnel_tour(150, scenario="light", random_state=0, first_indicator_m=30.0)
    X, y, _ = to_xy([tour])
    # min_length 5 so that these short tours hold positive trajectories too
    return make_indicator_pipeline(random_state=0, min_length=5).fit(X, y)


@pytest.fixture(scope="module")
def tours():
    return {
        s: make_tunnel_tour(100, scenario=s, random_state=10 + k, first_indicator_m=25.0)
        for k, s in enumerate(TUNNEL_SCENARIOS)
    }


def _n_detections(records):
    return sum(len(r.payload["detections"]) for r in records)


@pytest.mark.slow
@pytest.mark.parametrize("scenario", TUNNEL_SCENARIOS)
def test_stream_equals_batch(model, tours, scenario):
    X = to_xy([tours[scenario]])[0]
    batch = model.predict(X)
    stream = list(StreamingPipeline(model).run(X))
    assert_records_equal(stream, batch)
    assert sum(len(r.payload["cluster_boxes"]) for r in batch) > 0


@pytest.mark.slow
def test_stream_equals_batch_with_some_detections(model, tours):
    X = FrameSequence.concat(to_xy([t])[0] for t in tours.values())
    batch = model.predict(X)
    assert _n_detections(batch) > 0  # the comparisons above are not all-empty
    assert_records_equal(list(StreamingPipeline(model).run(X)), batch)


@pytest.mark.slow
def test_tour_changes_and_frame_gaps_inside_a_stream(model, tours):
    a = to_xy([tours["light"]])[0]
    b = to_xy([tours["heavy"]])[0]
    # frames 31-45 of tour a are missing (a gap longer than max_gap), tour b follows
    keep = [i for i in range(len(a)) if not 30 <= i < 45]
    X = FrameSequence.concat([a[np.array(keep)], b])
    batch = model.predict(X)
    stream = list(StreamingPipeline(model).run(X))
    assert_records_equal(stream, batch)
    # trajectories never cross the gap nor the tour boundary
    before = {t for r in stream[:30] for t in r.payload["track_ids"].tolist()}
    after = {t for r in stream[30 : len(keep)] for t in r.payload["track_ids"].tolist()}
    assert not before & after
    assert stream[len(keep)].key == (b[0].tour, 1)
    assert min(stream[len(keep)].payload["track_ids"].tolist() or [1]) == 1


def test_stream_order_is_checked(model, tours):
    X = to_xy([tours["light"]])[0]
    stream = StreamingPipeline(model)
    stream.push(X[5])
    with pytest.raises(ValueError, match="increasing"):
        stream.push(X[3])


# --------------------------------------------------------------------------------------
# bounded memory and delay on a long sequence with an object that never leaves
# --------------------------------------------------------------------------------------
IMG = np.zeros((120, 160), np.uint8)


def long_sequence(n, rng):
    """A still warm object in every frame (a vehicle followed forever), and indicators
    passing one after the other (20 frames each, 10 frames apart)."""
    for f in range(1, n + 1):
        boxes = [[60 + rng.normal(0, 1.0), 90 + rng.normal(0, 1.0), 20, 10]]
        k = (f - 1) % 30
        if k < 20:
            boxes.append([100 + 2.0 * k, 40 - 1.0 * k, 4, 8])
        boxes = np.array(boxes)
        yield FrameRecord(
            "long", f, IMG,
            {"cluster_boxes": boxes, "appearance": np.ones(len(boxes), bool)},
        )


@pytest.mark.parametrize("max_track_length", [40, 300])
def test_buffer_and_delay_are_bounded(global_random_seed, max_track_length):
    rng = np.random.default_rng(global_random_seed)
    n = 2000
    fit_X = list(long_sequence(3, rng))
    linker = TrajectoryLinker(max_track_length=max_track_length).fit(fit_X)
    verifier = PCCVerifier(min_length=10).fit(
        linker.transform(fit_X)
    )
    link, verify = linker.start_stream(), verifier.start_stream()
    released, most_waiting, worst_delay = [], 0, 0
    for r in long_sequence(n, rng):
        (linked,) = link.push(r)
        out = verify.push(linked)
        most_waiting = max(most_waiting, verify.n_waiting)
        worst_delay = max([worst_delay] + [r.frame - o.frame for o in out])
        released += out
    released += verify.close()
    assert [r.frame for r in released] == list(range(1, n + 1))
    assert most_waiting <= max_track_length
    assert worst_delay <= max_track_length - 1
    # the still object is cut into trajectories of max_track_length frames
    still = [int(r.payload["track_ids"][0]) for r in released]
    lengths = np.unique(still, return_counts=True)[1]
    assert lengths.max() == max_track_length
    # its jitter is no line; the indicators are, and each is detected
    assert not any(r.payload["trajectory_positive"][0] for r in released)
    detected = {int(t) for r in released for t in r.payload["detections"][:, 4]}
    assert len(detected) == len(range(0, n, 30))


def test_unbounded_trajectories_hold_every_frame():
    # without max_track_length the still object keeps every frame waiting
    rng = np.random.default_rng(0)
    X = list(long_sequence(300, rng))
    linker = TrajectoryLinker(max_track_length=None).fit(X)
    state = PCCVerifier().fit(linker.transform(X)).start_stream()
    out = [o for r in linker.transform(X) for o in state.push(r)]
    assert out == [] and state.n_waiting == 300
    assert len(state.close()) == 300


def test_released_records_drop_in_memory_images(model, tours, tmp_path):
    X = to_xy([tours["light"]])[0][:40]
    out = list(StreamingPipeline(model).run(X))
    with pytest.raises(ValueError, match="released"):
        out[0].image  # noqa: B018
    # batch keeps them
    assert model.predict(X)[0].image.shape == X[0].image.shape


def test_batch_equals_linker_and_verifier_streams(global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    X = list(long_sequence(400, rng))
    # shuffled input: batch sorts by frame and returns the input order
    perm = rng.permutation(len(X))
    shuffled = [X[i] for i in perm]
    linker = TrajectoryLinker(max_track_length=60).fit(X)
    verifier = PCCVerifier(min_length=10).fit(linker.transform(X))
    batch = verifier.predict(linker.transform(shuffled))
    link, verify = linker.start_stream(), verifier.start_stream()
    stream = [o for r in X for o in verify.push(link.push(r)[0])] + verify.close()
    assert_records_equal(stream, [batch[i] for i in np.argsort(perm)])


def test_stream_detect_runs_opencv_on_one_thread_and_restores_it(model, tours):
    # inside the detection OpenCV keeps to one thread (its pool only contends with the
    # reader threads on small windows); the results are those of a stream with a
    # pool of two, and the setting is restored when the stream ends
    import cv2

    from tunnelsense.tunnel import stream_detect

    X = to_xy([tours["light"]])[0][:40]
    before = cv2.getNumThreads()
    try:
        cv2.setNumThreads(2)
        pool = cv2.getNumThreads()  # 2, or 1 on a build without threads
        pooled = list(StreamingPipeline(model).run(X))
        seen, out = [], []
        for record in stream_detect(model, iter(X), n_threads=1):
            seen.append(cv2.getNumThreads())
            out.append(record)
        assert seen and set(seen) == {1}
        assert cv2.getNumThreads() == pool
        assert_records_equal(out, pooled)
    finally:
        cv2.setNumThreads(before)


def test_stream_detect_in_chunks_yields_the_same_records(model, tours):
    # frames fed to the stages several at once, chunks straddling a change of tour
    # and a last short chunk: the same records, in the same order, as one at a time
    from tunnelsense.tunnel import stream_detect

    X = FrameSequence.concat([to_xy([tours["light"]])[0][:23],
                              to_xy([tours["heavy"]])[0][:18]])
    one = list(stream_detect(model, iter(X)))
    assert len(one) == len(X)
    for chunk in (2, 4, 7):
        assert_records_equal(list(stream_detect(model, iter(X), chunk=chunk)), one)


def queue_sequence(n, rng, tour="queue"):
    """A still warm object (a vehicle ahead in a queue) and a far sign crawling along
    its path, both jittering by about a pixel."""
    for f in range(1, n + 1):
        boxes = np.array([
            [60 + rng.normal(0, 1.0), 90 + rng.normal(0, 1.0), 20, 10],
            [100 + 0.12 * f + rng.normal(0, 0.6), 40 + 0.05 * f + rng.normal(0, 0.6), 4, 8],
        ])
        yield FrameRecord(tour, f, IMG,
                          {"cluster_boxes": boxes, "appearance": np.ones(2, bool)})


@pytest.mark.parametrize("chunk", [1, 3, 17])
def test_carried_pieces_stream_equals_batch_in_any_chunks(global_random_seed, chunk):
    """A trajectory cut at max_track_length and carried into the next piece's motion
    check (carry_travel): batch, one frame at a time and chunks of frames give the
    same records, across a change of tour, with every frame released."""
    rng = np.random.default_rng(global_random_seed)
    X = list(queue_sequence(200, rng)) + list(queue_sequence(90, rng, tour="next"))
    linker = TrajectoryLinker(max_track_length=40).fit(X)
    verifier = PCCVerifier(criterion="quadratic-motion", min_travel=0.25,
                           carry_travel=0.25).fit(linker.transform(X))
    batch = verifier.predict(linker.transform(X))
    link, verify = linker.start_stream(), verifier.start_stream()
    stream, most_waiting = [], 0
    for i in range(0, len(X), chunk):
        stream += verify.push_many(link.push_many(X[i:i + chunk]))
        most_waiting = max(most_waiting, verify.n_waiting)
    stream += verify.close()
    assert_records_equal(stream, batch)
    assert most_waiting <= 40 + chunk  # the delay stays bounded by max_track_length
    # the crawling sign is found on its later pieces, the still object never
    found = {(r.tour, int(t)) for r in batch for t in r.payload["detections"][:, 4]}
    signs = {(r.tour, int(r.payload["track_ids"][1])) for r in batch}
    assert found and found <= signs
    assert not any(r.payload["trajectory_positive"][0] for r in batch)
