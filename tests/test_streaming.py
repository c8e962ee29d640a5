import numpy as np
import pytest
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.pipeline import Pipeline

from tunnelsense import FrameSequence
from tunnelsense._streaming import ResultsWriter, StreamingPipeline, start_stream


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
    w._file.close()
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
