import numpy as np
import pytest
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.pipeline import Pipeline

from tunnelsense import FrameSequence
from tunnelsense._streaming import (
    ResultsWriter,
    StreamingMixin,
    StreamingPipeline,
    StreamState,
    start_stream,
    stream_order,
    tour_groups,
)


class Brightness(TransformerMixin, BaseEstimator):
    """Stateless: payload "mean"."""

    def fit(self, X, y=None):
        self.fitted_ = True
        return self

    def transform(self, X):
        return [r.evolve(mean=float(r.image.mean())) for r in X]


class _PairState:
    """Holds each record until the next one of its tour: a stage that looks ahead."""

    def __init__(self):
        self.held = None

    def push(self, record):
        out = []
        if self.held is not None:
            nxt = record.payload["mean"] if record.tour == self.held.tour else None
            out.append(self.held.evolve(next_mean=nxt))
        self.held = record
        return out

    def close(self):
        out = [] if self.held is None else [self.held.evolve(next_mean=None)]
        self.held = None
        return out


class LookAhead(TransformerMixin, BaseEstimator):
    def fit(self, X, y=None):
        self.fitted_ = True
        return self

    def start_stream(self):
        return _PairState()

    def transform(self, X):  # batch = the same state machine
        return list(StreamingPipeline(self).run(X))


def _frames(tour, n, offset=0):
    images = (np.arange(n)[:, None, None] + offset) * np.ones((n, 2, 2))
    return FrameSequence.from_array(images, tour=tour)


def test_stream_equals_batch_with_a_stage_that_looks_ahead():
    X = _frames("a", 4) + _frames("b", 3, offset=10)
    pipe = Pipeline([("b", Brightness()), ("l", LookAhead())]).fit(X)
    batch = pipe.transform(X)
    stream = StreamingPipeline(pipe)
    streamed = []
    for r in X:
        streamed.extend(stream.push(r))
    assert len(streamed) == 6  # the last frame is still held
    streamed.extend(stream.close())
    assert [r.key for r in streamed] == [r.key for r in X]
    assert [r.payload["next_mean"] for r in streamed] == [
        r.payload["next_mean"] for r in batch
    ]
    assert [r.payload["next_mean"] for r in streamed] == [
        1.0,
        2.0,
        3.0,
        None,
        11.0,
        12.0,
        None,
    ]


def test_frames_of_a_tour_must_come_in_order():
    X = _frames("a", 3)
    stream = StreamingPipeline(Pipeline([("b", Brightness())]).fit(X))
    stream.push(X[1])
    with pytest.raises(
        ValueError, match=r"increasing frame order: \('a', 1\) came after \('a', 2\)"
    ):
        stream.push(X[0])


def test_unfitted_and_empty_pipelines_are_refused():
    from sklearn.exceptions import NotFittedError

    with pytest.raises(NotFittedError):
        StreamingPipeline(Pipeline([("b", Brightness())]))
    with pytest.raises(ValueError, match="no steps"):
        StreamingPipeline(Pipeline([("b", "passthrough")]))


class Checked(Brightness):
    """A stage whose transform checks each call and whose _transform_frames works."""

    def transform(self, X):
        self.checked_calls_ = getattr(self, "checked_calls_", 0) + 1
        return self._transform_frames(list(X))

    def _transform_frames(self, records):
        return [r.evolve(seen=r.payload.get("seen", 0) + 1) for r in records]


def test_later_stages_skip_the_per_call_checks_the_first_stage_keeps():
    X = _frames("a", 5)
    first, second = Checked().fit(X), Checked().fit(X)
    stream = StreamingPipeline(Pipeline([("first", first), ("second", second)]))
    out = list(stream.run(X))
    # the same records as the public transforms give, the first stage checked per
    # frame, the second (fed by the first) not
    assert [r.payload for r in out] == [r.payload for r in second.transform(
        first.transform(X))]
    assert first.checked_calls_ == 5 + 1 and second.checked_calls_ == 1


def test_stateless_final_step_streams_through_predict():
    class Predictor(BaseEstimator):
        def fit(self, X, y=None):
            self.fitted_ = True
            return self

        def predict(self, X):
            return [r.evolve(said=True) for r in X]

    X = _frames("a", 2)
    state = start_stream(Predictor().fit(X), final=True)
    assert state.push(X[0])[0].payload == {"said": True} and state.close() == []


def test_writer_resume_keeps_complete_lines_and_checks_replay(tmp_path):
    path = tmp_path / "out.csv"
    with ResultsWriter(path, header="a,b") as w:
        w.write("1,2")
        w.write("3,4")
    path.write_bytes(path.read_bytes() + b"5,")  # killed mid-line
    with ResultsWriter(path, header="a,b", resume=True) as w:
        assert w.resumed_lines == 2
        w.write("1,2")
        w.write("3,4")
        w.write("5,6")
        assert w.written == 1
    assert path.read_text() == "a,b\n1,2\n3,4\n5,6\n"


def test_writer_resume_refuses_another_runs_file(tmp_path):
    path = tmp_path / "out.csv"
    path.write_text("a,b\n1,2\n3,4\n")
    w = ResultsWriter(path, header="a,b", resume=True)
    w.write("1,2")
    with pytest.raises(
        ValueError, match=r"line 3 differs from this run's \('3,4' vs '9,9'\)"
    ):
        w.write("9,9")
    w._abandon()
    assert path.read_text() == "a,b\n1,2\n3,4\n"  # nothing touched
    with pytest.raises(ValueError, match="first line is not the header"):
        ResultsWriter(path, header="x,y", resume=True)
    w = ResultsWriter(path, header="a,b", resume=True)
    w.write("1,2")
    with pytest.raises(ValueError, match="1 more lines than this run produced"):
        w.close()


def test_writer_resume_of_a_file_without_a_complete_line_starts_afresh(tmp_path):
    path = tmp_path / "out.csv"
    path.write_text("a,")
    with ResultsWriter(path, header="a,b", resume=True) as w:
        assert w.resumed_lines == 0
        w.write("1,2")
    assert path.read_text() == "a,b\n1,2\n"


def test_writer_refuses_to_overwrite_unless_asked(tmp_path):
    from tunnelsense.exceptions import OutputExistsError

    path = tmp_path / "out.csv"
    path.write_text("precious\n")
    with pytest.raises(OutputExistsError, match="out.csv: exists"):
        ResultsWriter(path, header="a,b")
    assert path.read_text() == "precious\n"
    # overwrite: the old file stays whole until the new one is complete
    w = ResultsWriter(path, header="a,b", overwrite=True)
    w.write("1,2")
    w.flush()
    assert path.read_text() == "precious\n"
    w.close()
    assert path.read_text() == "a,b\n1,2\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]


def test_writer_replacing_a_file_keeps_it_when_the_run_fails(tmp_path):
    path = tmp_path / "out.csv"
    path.write_text("precious\n")
    with pytest.raises(RuntimeError), ResultsWriter(path, overwrite=True) as w:
        w.write("1,2")
        raise RuntimeError("the source is corrupt")
    assert path.read_text() == "precious\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]


def test_writer_resume_checks_an_unrelated_file_before_touching_it(tmp_path):
    path = tmp_path / "gt.txt"
    original = b"1,1,10,20,5,9,1,1,1.0\n2,1,10,20,5,9,1,1,1.0\npartial"
    path.write_bytes(original)
    pattern = r"\d+,-?\d+(,[^,]+){5},-1,-1,-1"
    with pytest.raises(ValueError, match="line 1 .* is not a line this command writes"):
        ResultsWriter(path, resume=True, line_pattern=pattern)
    assert path.read_bytes() == original
    csv = tmp_path / "other.csv"
    csv.write_bytes(b"x,y\n1,2\npart")
    with pytest.raises(ValueError, match="first line is not the header"):
        ResultsWriter(csv, header="a,b", resume=True)
    assert csv.read_bytes() == b"x,y\n1,2\npart"


@pytest.mark.parametrize("where", ["/dev/null", "/dev/shm/tunnelsense-results.txt"])
def test_writer_never_writes_into_device_folders(where):
    import os

    for kwargs in ({}, {"overwrite": True}, {"resume": True}):
        with pytest.raises(ValueError, match="device folder"):
            ResultsWriter(where, **kwargs)
    assert not os.path.exists("/dev/shm/tunnelsense-results.txt")


def test_writer_errors_name_the_file(tmp_path):
    (tmp_path / "file").write_text("")
    with pytest.raises(OSError, match=r"file/r.txt: cannot write \(Not a directory"):
        ResultsWriter(tmp_path / "file" / "r.txt")


@pytest.mark.slow
def test_writer_error_when_the_disk_is_full_names_the_file(tmp_path):
    """A file-size limit stands in for a full disk: the same error (EFBIG/ENOSPC)."""
    import subprocess
    import sys

    code = (
        "import resource, signal, sys\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        "resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))\n"
        "from tunnelsense._streaming import ResultsWriter\n"
        "try:\n"
        "    with ResultsWriter(sys.argv[1], header='a,b') as w:\n"
        "        for i in range(10000):\n"
        "            w.write(f'{i},{i}')\n"
        "            w.flush()\n"
        "except OSError as exc:\n"
        "    print(exc)\n"
    )
    out = subprocess.run([sys.executable, "-c", code, str(tmp_path / "r.csv")],
                         capture_output=True, text=True, check=True).stdout
    assert "r.csv: cannot write (File too large)" in out


class _RunningSum(StreamState):
    """Holds nothing: each record gets the sum of its tour's means so far."""

    def __init__(self):
        self.tour, self.total = None, 0.0

    def _push(self, record):
        if record.tour != self.tour:
            self.tour, self.total = record.tour, 0.0
        self.total += float(record.image.mean())
        return [record.evolve(total=self.total)]


class RunningSum(StreamingMixin, TransformerMixin, BaseEstimator):
    _sequence = FrameSequence

    def fit(self, X, y=None):
        self.fitted_ = True
        return self

    def _check_records(self, X):
        return list(X)

    def _stream_state(self, *, batch=False):
        return _RunningSum()


def test_streaming_mixin_groups_sorts_and_restores_order(global_random_seed):
    X = _frames("a", 4) + _frames("b", 3, offset=10)
    perm = np.random.default_rng(global_random_seed).permutation(len(X))
    shuffled = FrameSequence(X[i] for i in perm)
    out = RunningSum().fit(X).transform(shuffled)
    assert [r.key for r in out] == [r.key for r in shuffled]
    expected = {("a", 1): 0.0, ("a", 2): 1.0, ("a", 3): 3.0, ("a", 4): 6.0,
                ("b", 1): 10.0, ("b", 2): 21.0, ("b", 3): 33.0}
    assert {r.key: r.payload["total"] for r in out} == expected
    streamed = list(StreamingPipeline(RunningSum().fit(X)).run(X))
    assert {r.key: r.payload["total"] for r in streamed} == expected


def test_one_order_check_for_batch_state_and_pipeline():
    X = _frames("a", 3)
    with pytest.raises(ValueError, match=r"frame 2 of tour 'a' came twice"):
        RunningSum().fit(X).transform([X[1], X[0], X[1]])
    state = RunningSum().fit(X)._stream_state()
    state.push(X[1])
    with pytest.raises(ValueError, match=r"\('a', 1\) came after \('a', 2\)"):
        state.push(X[0])
    with pytest.raises(ValueError, match="came twice"):
        state.push_many([X[2], X[2]])
    state.close()
    assert state.push(X[0])[0].key == ("a", 1)  # a closed state starts afresh


def test_tour_groups_by_first_appearance_or_by_name():
    X = _frames("b", 2) + _frames("a", 2)
    assert [g.tolist() for g in tour_groups(X)] == [[0, 1], [2, 3]]
    assert [g.tolist() for g in tour_groups(X, sort_tours=True)] == [[2, 3], [0, 1]]
    assert stream_order(X[::-1]).tolist() == [1, 0, 3, 2]


@pytest.mark.parametrize("chunk", [2, 7, 64])
def test_chunked_stream_equals_one_at_a_time(chunk):
    """push_many (a chunk through every stage at once) gives what push gives.

    The one difference allowed: an object row that becomes final inside a chunk rides
    on a later record of that chunk; the rows, in order, are the same.
    """
    from tunnelsense._payload import FINISHED_OBJECTS
    from tunnelsense.datasets import make_street_scans
    from tunnelsense.street import make_parking_pipeline

    run = make_street_scans(400, scenario="dense", random_state=3)
    model = make_parking_pipeline().fit(run.scans)
    one = list(StreamingPipeline(model).run(run.scans))
    many = list(StreamingPipeline(model).run(run.scans, chunk=chunk))
    assert [r.key for r in many] == [r.key for r in one]
    for a, b in zip(one, many, strict=True):
        assert a.payload.keys() == b.payload.keys()
        for k in a.payload.keys() - {FINISHED_OBJECTS}:
            np.testing.assert_array_equal(np.asarray(a.payload[k], dtype=object),
                                          np.asarray(b.payload[k], dtype=object))
    rows = [[row for r in out for row in r.payload[FINISHED_OBJECTS]] for out in (one, many)]
    assert rows[0] == rows[1] and len(rows[0]) > 5


def test_chunked_stream_checks_the_order():
    X = FrameSequence.from_array(np.zeros((3, 2, 2)))
    stream = StreamingPipeline(Pipeline([("b", Brightness())]).fit(X))
    with pytest.raises(ValueError, match="increasing frame order"):
        stream.push_many([X[1], X[0]])


def test_prepared_records_in_any_order_and_threads_stream_as_pushed():
    from concurrent.futures import ThreadPoolExecutor

    X = _frames("a", 6) + _frames("b", 4, offset=10)
    pipe = Pipeline([("first", Checked()), ("b", Brightness()), ("l", LookAhead()),
                     ("last", Checked())]).fit(X)
    expected = list(StreamingPipeline(pipe).run(X))
    stream = StreamingPipeline(pipe)
    # the stateless head (first, b) runs in threads, last frames first
    with ThreadPoolExecutor(2) as pool:
        prepared = list(pool.map(stream.prepare, X[::-1]))[::-1]
    assert [r.key for r in prepared] == [r.key for r in X]
    assert all("mean" in r.payload and "next_mean" not in r.payload for r in prepared)
    out = [o for r in prepared for o in stream.push_prepared(r)] + stream.close()
    assert [(r.key, r.payload) for r in out] == [(r.key, r.payload) for r in expected]
    with pytest.raises(ValueError, match="increasing frame order"):
        stream.push_prepared(prepared[3]), stream.push_prepared(prepared[2])


@pytest.mark.parametrize("steps", [0, 1, 2, 5])
def test_prepare_steps_runs_at_most_that_many_stages_ahead(steps):
    X = _frames("a", 6) + _frames("b", 4, offset=10)
    pipe = Pipeline([("first", Checked()), ("b", Brightness()), ("l", LookAhead()),
                     ("last", Checked())]).fit(X)
    expected = list(StreamingPipeline(pipe).run(X))
    stream = StreamingPipeline(pipe, prepare_steps=steps)
    prepared = [stream.prepare(r) for r in X]
    # the stateless head is two stages long: Brightness has run only when asked
    assert all(("mean" in r.payload) == (steps >= 2) for r in prepared)
    assert (prepared[0] is X[0]) == (steps == 0)
    out = (stream.push_many(prepared[:4], prepared=True)
           + stream.push_many(prepared[4:], prepared=True) + stream.close())
    assert [(r.key, r.payload) for r in out] == [(r.key, r.payload) for r in expected]


def test_prepare_leaves_a_stateful_first_stage_and_the_last_stage_to_push():
    X = _frames("a", 3)
    first_stateful = StreamingPipeline(
        Pipeline([("l", LookAhead()), ("b", Brightness())]).fit(_frames("a", 1)))
    assert first_stateful.prepare(X[0]) is X[0]
    only = StreamingPipeline(Pipeline([("b", Brightness())]).fit(X))
    assert only.prepare(X[0]) is X[0]
    assert only.push_prepared(X[0])[0].payload == {"mean": 0.0}


def test_a_stream_of_an_unfitted_sampler_is_refused_before_any_frame():
    """The first stage's per-frame call skips the fitted check: the stream checks it
    when it starts."""
    from sklearn.exceptions import NotFittedError

    from tunnelsense._streaming import start_stream
    from tunnelsense.tunnel import IntensityKeypointSampler

    with pytest.raises(NotFittedError):
        start_stream(IntensityKeypointSampler())
