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

from tunnelsense.io._writer import ResultsWriter  # its home is tunnelsense.io

__all__ = ["ResultsWriter", "StreamingPipeline", "decode_ahead", "start_stream"]


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


def decode_ahead(records: Iterable, *, n_threads=1, ahead=8) -> Iterator:
    """Yield the records with their images decoded, decoding ahead in threads.

    OpenCV releases the interpreter lock while it decodes, so reader threads decode
    the next frames while the detector works on this one.  Records come out in input
    order, each with a :class:`~tunnelsense.DecodedImage` source (in-memory images
    pass unchanged); at most ``ahead`` decoded frames wait, so memory stays bounded.

    Parameters
    ----------
    records : iterable of FrameRecord
    n_threads : int, default=1
        Reader threads; 0 decodes in the calling thread, as the records are taken.
    ahead : int, default=8
        Frames decoded ahead at most.

    Yields
    ------
    record : FrameRecord
    """
    from collections import deque
    from concurrent.futures import ThreadPoolExecutor

    from tunnelsense._records import decode_once

    if n_threads < 1:
        for record in records:
            yield decode_once(record)
        return
    with ThreadPoolExecutor(max_workers=n_threads,
                            thread_name_prefix="decode") as pool:
        pending = deque()
        for record in records:
            pending.append(pool.submit(decode_once, record))
            if len(pending) >= ahead:
                yield pending.popleft().result()
        while pending:
            yield pending.popleft().result()
