"""Online detection: a fitted pipeline fed one frame (or scan) at a time.

On a vehicle, frames arrive one by one and a tour may last for hours, so a fitted
detector must run online with memory that does not grow with the tour's length.

The protocol
------------
A record stage may offer ``start_stream()``, returning a *stream state* with

* ``push(record) -> list of records``: take the next record (the records of a tour
  arrive in increasing frame order; a record of another tour starts that tour
  afresh); return the records that are finished, in input order (possibly
  none yet, possibly several, when the stage must see later frames first);
* ``close() -> list of records``: the end of the stream; return what is left.

A stage without ``start_stream`` is stateless per record: :func:`start_stream` wraps
it so that ``push(r)`` returns ``stage.transform([r])`` (``predict`` for a final step
that has no ``transform``).  A stateful stage (trajectory linking, inter-scan linking)
implements its batch ``transform`` by running its own stream state over each tour, so
streaming and batch give identical results by construction.

:class:`StreamingPipeline` chains the states of a fitted ``Pipeline``'s steps.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

from sklearn.utils.validation import check_is_fitted

__all__ = ["ResultsWriter", "StreamingPipeline", "start_stream"]


class _StatelessStream:
    """Stream state of a stage that maps each record on its own."""

    __slots__ = ("_map",)

    def __init__(self, stage, final):
        if final and not hasattr(stage, "transform"):
            self._map = stage.predict
        else:
            self._map = stage.transform

    def push(self, record):
        return list(self._map([record]))

    def close(self):
        return []


def start_stream(stage, *, final=False):
    """The stream state of a fitted record stage.

    Parameters
    ----------
    stage : estimator
        A fitted record stage.
    final : bool, default=False
        Whether it is the last step of a pipeline (then a stage without ``transform``
        streams through ``predict``).

    Returns
    -------
    state : object with ``push(record) -> list`` and ``close() -> list``
    """
    if hasattr(stage, "start_stream"):
        return stage.start_stream()
    return _StatelessStream(stage, final)


class StreamingPipeline:
    """Run a fitted pipeline of record stages online, one record at a time.

    Parameters
    ----------
    pipeline : Pipeline or estimator
        A fitted ``sklearn.pipeline.Pipeline`` of record stages (or one stage).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.base import BaseEstimator, TransformerMixin
    >>> from sklearn.pipeline import Pipeline
    >>> from tunnelsense import FrameSequence
    >>> from tunnelsense._streaming import StreamingPipeline
    >>> class Mean(TransformerMixin, BaseEstimator):
    ...     def fit(self, X, y=None):
    ...         self.fitted_ = True
    ...         return self
    ...     def transform(self, X):
    ...         return [r.evolve(mean=float(r.image.mean())) for r in X]
    >>> frames = FrameSequence.from_array(np.arange(12.0).reshape(3, 2, 2))
    >>> stream = StreamingPipeline(Pipeline([("mean", Mean())]).fit(frames))
    >>> [r.payload["mean"] for r in stream.run(frames)]
    [1.5, 5.5, 9.5]
    """

    def __init__(self, pipeline):
        steps = getattr(pipeline, "steps", None)
        stages = [s for _, s in steps] if steps is not None else [pipeline]
        stages = [s for s in stages if s is not None and s != "passthrough"]
        if not stages:
            raise ValueError("pipeline has no steps to stream through")
        for s in stages:
            check_is_fitted(s)
        self._states = [
            start_stream(s, final=(i == len(stages) - 1)) for i, s in enumerate(stages)
        ]
        self._last_key = None

    def push(self, record) -> list:
        """Feed the next record; return the finished records of the last step."""
        key = record.key
        last = self._last_key
        if last is not None and key[0] == last[0] and key[1] <= last[1]:
            raise ValueError(
                f"records of one tour must arrive in increasing frame order: {key} "
                f"came after {last}"
            )
        self._last_key = key
        batch = [record]
        for state in self._states:
            out = []
            for r in batch:
                out.extend(state.push(r))
            batch = out
            if not batch:
                break
        return batch

    def close(self) -> list:
        """End the stream; return the records still held by the stages."""
        batch = []
        for state in self._states:
            out = []
            for r in batch:
                out.extend(state.push(r))
            out.extend(state.close())
            batch = out
        return batch

    def run(self, records: Iterable) -> Iterator:
        """Stream ``records`` through; yield the last step's records as they finish."""
        for record in records:
            yield from self.push(record)
        yield from self.close()


class ResultsWriter:
    """Write result lines as they come, flushed, so an interrupted run keeps them.

    With ``resume=True`` an existing file is continued: its complete lines are kept (a
    partly written last line is dropped), and the first lines written again -- the
    detector replays the source from its start, which rebuilds its trackers' state
    exactly -- are checked against them instead of being written twice.  The result
    equals an uninterrupted run.

    Parameters
    ----------
    path : str or Path
        The results file.
    header : str or None, default=None
        A first line (for CSV files); checked, not rewritten, when resuming.
    resume : bool, default=False
        Continue an existing file instead of replacing it.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from tunnelsense._streaming import ResultsWriter
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "res.txt"
    >>> with ResultsWriter(path) as w:
    ...     w.write("1,1,0,0,4,8,0.9,-1,-1,-1")
    >>> _ = path.write_text(path.read_text() + "2,1,0")  # killed while writing line 2
    >>> with ResultsWriter(path, resume=True) as w:
    ...     w.write("1,1,0,0,4,8,0.9,-1,-1,-1")  # replayed: checked, not written
    ...     w.write("2,1,1,0,4,8,0.8,-1,-1,-1")
    >>> path.read_text().splitlines()
    ['1,1,0,0,4,8,0.9,-1,-1,-1', '2,1,1,0,4,8,0.8,-1,-1,-1']
    """

    def __init__(self, path, *, header=None, resume=False):
        from pathlib import Path

        self.path = Path(path)
        self._existing = []
        self._first_line = 1 if header is None else 2
        if resume and self.path.exists() and b"\n" not in self.path.read_bytes():
            resume = False  # killed before its first line was complete: start afresh
        if resume and self.path.exists():
            data = self.path.read_bytes()
            complete = data[: data.rfind(b"\n") + 1]
            self._existing = complete.decode("utf-8").splitlines()
            with open(self.path, "r+b") as f:
                f.truncate(len(complete))
            if header is not None:
                if not self._existing or self._existing[0] != header:
                    raise ValueError(
                        f"{self.path}: cannot resume, its first line is not the header "
                        f"{header!r}"
                    )
                self._existing = self._existing[1:]
            self._file = open(self.path, "a", encoding="utf-8")  # noqa: SIM115
        else:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = open(self.path, "w", encoding="utf-8")  # noqa: SIM115
            if header is not None:
                self._file.write(header + "\n")
                self._file.flush()
        self._replayed = 0
        self.written = 0

    @property
    def resumed_lines(self) -> int:
        """Lines kept from an interrupted run."""
        return len(self._existing)

    def write(self, line: str) -> None:
        """Write one line (without its newline); replayed lines are checked instead."""
        if self._replayed < len(self._existing):
            expected = self._existing[self._replayed]
            if line != expected:
                raise ValueError(
                    f"{self.path}: cannot resume, line {self._replayed + self._first_line} "
                    "differs from "
                    f"this run's ({expected!r} vs {line!r}); was it written with another "
                    "model or source?"
                )
            self._replayed += 1
            return
        self._file.write(line + "\n")
        self.written += 1

    def flush(self) -> None:
        """Push what was written to the operating system (call after each frame)."""
        self._file.flush()

    def close(self) -> None:
        if self._replayed < len(self._existing):
            missing = len(self._existing) - self._replayed
            self._file.close()
            raise ValueError(
                f"{self.path}: the existing file has {missing} more lines than this run "
                "produced; was it written with another model or source?"
            )
        self._file.close()

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            self.close()
        else:
            self._file.close()
