"""Each frame is decoded once per pass through the pipeline, in batch and streaming."""

import copy
import pickle
from collections import Counter

import numpy as np
import pytest

from tunnelsense import DecodedImage, make_indicator_pipeline, to_xy
from tunnelsense._streaming import StreamingPipeline
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.io import open_tour, write_tour


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    train = make_tunnel_tour(150, random_state=0, first_indicator_m=40.0)
    X, y, _ = to_xy([train])
    model = make_indicator_pipeline(random_state=0).fit(X, y)
    tour = make_tunnel_tour(90, random_state=1, first_indicator_m=40.0, name="t")
    folder = write_tour(tour, tmp_path_factory.mktemp("tour") / "t")
    return model, folder, tour


@pytest.fixture
def decodes(monkeypatch):
    """Count the decodes of every frame file."""
    import tunnelsense.io._images as images

    counts = Counter()
    read = images.read_image

    def counting(path, **kwargs):
        counts[str(path)] += 1
        return read(path, **kwargs)

    monkeypatch.setattr(images, "read_image", counting)
    return counts


@pytest.mark.slow
def test_streaming_decodes_each_frame_once(fitted, decodes):
    model, folder, tour = fitted
    frames = open_tour(folder).frames
    out = list(StreamingPipeline(model).run(frames))
    assert len(out) == len(frames) == len(decodes)
    assert set(decodes.values()) == {1}
    # the held frames were released to their file: nothing decoded is kept
    assert not any(isinstance(r.source, DecodedImage) for r in out)
    expected = model.predict(to_xy([tour])[0])
    assert [r.payload["detections"].tolist() for r in out] == [
        r.payload["detections"].tolist() for r in expected
    ]


def test_batch_predict_and_fit_decode_each_frame_once(fitted, decodes):
    model, folder, _ = fitted
    tour = open_tour(folder)
    model.predict(tour.frames)
    assert len(decodes) == len(tour) and set(decodes.values()) == {1}
    decodes.clear()
    X, y, _ = to_xy([tour])
    make_indicator_pipeline(random_state=0).fit(X, y)
    assert len(decodes) == len(tour) and set(decodes.values()) == {1}


def test_decoded_image_pickles_as_its_origin(fitted):
    _, folder, _ = fitted
    record = open_tour(folder).frames[0]
    decoded = DecodedImage(record.source, record.image)
    back = pickle.loads(pickle.dumps(decoded))
    assert type(back) is type(record.source) and back.path == record.source.path
    assert len(pickle.dumps(decoded)) < 1000  # no pixels
    assert np.array_equal(back.load(), decoded.load())


def test_a_canonical_frame_pickles_and_copies_as_its_own_pixels_made_again(fitted):
    # the keypoint stage hands the later stages the frame in the training frames'
    # radiometry; a worker process (a search's fits on Dask or loky) or a copy must
    # see that frame, not the file's pixels, and no pixels travel
    model, folder, _ = fitted
    sampler = copy.deepcopy(model.named_steps["keypoints"])
    out = sampler.transform(open_tour(folder).frames[:20])
    assert all(isinstance(r.source, DecodedImage) for r in out)
    assert any(not np.array_equal(r.image, r.source.origin.load()) for r in out)
    back = pickle.loads(pickle.dumps(out))
    assert len(pickle.dumps(out[0])) < 5000  # the file and the mapping, no pixels
    for a, b, c in zip(out, back, copy.deepcopy(out), strict=True):
        assert b.image.dtype == a.image.dtype == c.image.dtype
        np.testing.assert_array_equal(b.image, a.image)
        np.testing.assert_array_equal(c.image, a.image)
    # a later fit of the same sampler does not change the frames made before it
    sampler.fit(*to_xy([make_tunnel_tour(40, scenario="heavy", random_state=7)])[:2])
    again = pickle.loads(pickle.dumps(out))
    np.testing.assert_array_equal(again[0].image, out[0].image)


@pytest.mark.slow
def test_fit_pipeline_equals_pipeline_fit(fitted):
    from tunnelsense._fitting import fit_pipeline

    _, folder, tour = fitted
    X, y, _ = to_xy([tour])
    reference = make_indicator_pipeline(random_state=3, verifier__n_jobs=2).fit(X, y)
    steps = []
    model, out = fit_pipeline(make_indicator_pipeline(random_state=3, verifier__n_jobs=2),
                              X, y, progress=lambda name, k, n: steps.append(name))
    assert steps == [*model.named_steps, None]
    assert np.array_equal(model.named_steps["verifier"].negative_centers_,
                          reference.named_steps["verifier"].negative_centers_)
    expected = reference.predict(X)
    for a, b, c in zip(out, model.predict(X), expected, strict=True):
        assert a.payload["detections"].tolist() == c.payload["detections"].tolist()
        assert b.payload["detections"].tolist() == c.payload["detections"].tolist()


def test_kmeans_threads_do_not_change_the_centres(global_random_seed):
    from tunnelsense.tunnel._verification import fit_kmeans

    rng = np.random.default_rng(global_random_seed)
    X = rng.random((30_000, 8))
    one = fit_kmeans(X, 50, n_steps=20, random_state=global_random_seed)
    two = fit_kmeans(X, 50, n_steps=20, random_state=global_random_seed, n_jobs=2)
    np.testing.assert_array_equal(one, two)


@pytest.mark.parametrize("n_threads", [1, 2])
def test_reader_threads_run_the_stateless_stages_with_the_same_results(
        fitted, decodes, n_threads):
    from tunnelsense.tunnel import stream_detect

    model, folder, _ = fitted
    plain = list(stream_detect(model, iter(open_tour(folder).frames[:40])))
    decodes.clear()
    threaded = list(stream_detect(model, iter(open_tour(folder).frames[:40]),
                                  n_threads=n_threads, stages_in_readers=True))
    assert len(decodes) == 40 and set(decodes.values()) == {1}
    assert [r.key for r in threaded] == [r.key for r in plain]
    for a, b in zip(threaded, plain, strict=True):
        assert a.payload.keys() == b.payload.keys()
        for k in a.payload:
            np.testing.assert_array_equal(a.payload[k], b.payload[k], err_msg=k)


def test_a_frame_that_cannot_be_read_stops_after_the_frames_before_it(
        fitted, tmp_path):
    from tunnelsense.exceptions import InputFormatError
    from tunnelsense.tunnel import detect_to_files

    model, folder, tour = fitted
    # trajectories of at most 20 frames: the frames before the bad one are final
    model = copy.deepcopy(model).set_params(tracks__max_track_length=20)
    copy_ = write_tour(tour, tmp_path / "t")
    bad = copy_ / "img1" / "000080.png"
    bad.write_bytes(bad.read_bytes()[:100])  # truncated
    whole = tmp_path / "whole.txt"
    detect_to_files(model, folder, whole)
    written = {}
    # in this thread; readers that decode; readers that also run the first stage,
    # every stage
    modes = {"here": (0, False), "decode": (2, False), "keypoints": (2, 1),
             "stages": (2, True)}
    for mode, (n_threads, stages) in modes.items():
        out = tmp_path / f"{mode}.txt"
        with pytest.raises((InputFormatError, ValueError, OSError), match="000080.png"):
            detect_to_files(model, copy_, out, n_threads=n_threads,
                            stages_in_readers=stages)
        written[mode] = [out.read_text().splitlines(),
                         (tmp_path / f"{mode}.clusters.csv").read_text().splitlines()]
    # what the readers' runs wrote is what the plain run wrote: the uninterrupted
    # run's lines of the frames finished before frame 80
    assert len(written) == 4
    assert (written["stages"] == written["keypoints"] == written["decode"]
            == written["here"])
    lines, clusters = written["stages"]
    assert lines == whole.read_text().splitlines()[:len(lines)]
    assert all(int(line.split(",")[0]) < 80 for line in lines)
    assert len(clusters) > 1 and clusters == (
        tmp_path / "whole.clusters.csv").read_text().splitlines()[:len(clusters)]


def test_stages_in_readers_and_prepare_steps_are_counts(fitted):
    from tunnelsense._streaming import StreamingPipeline
    from tunnelsense.tunnel import stream_detect

    model = fitted[0]
    for bad in ("keypoints", 2.7, -1, None):
        with pytest.raises(ValueError, match="stages_in_readers"):
            next(stream_detect(model, iter([]), n_threads=1, stages_in_readers=bad))
    for bad in (-1, 1.0, True):
        with pytest.raises(ValueError, match="prepare_steps"):
            StreamingPipeline(model, prepare_steps=bad)
    assert StreamingPipeline(model, prepare_steps=1).prepared_steps == 1
    assert StreamingPipeline(model, prepare_steps=0).prepared_steps == 0
    assert StreamingPipeline(model).prepared_steps == 4  # every per-frame stage
