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
that has no ``transform``; a stage that offers ``_stream_frames(records) -> list``,
its ``transform`` checking the records but not again that it is fitted, is called
through that, the state being made only from a fitted stage).  Inside a
:class:`StreamingPipeline`, a stateless stage
after the first receives only records that earlier stages made and that were checked
on entry, from stages checked fitted at the start; when it offers
``_transform_frames(records) -> list`` (the work of its ``transform`` without the
per-call checks), the pipeline calls that instead: one frame at a time, the checks
would cost more than the work of a small stage.

A stateful stage (trajectory linking, motion verification, inter-scan linking) derives
from :class:`StreamingMixin` and supplies only its state, a :class:`StreamState`; the
mixin's batch ``transform`` groups the records by tour, sorts them by frame, runs them
through one state and restores the input order, so streaming and batch give identical
results by construction.  The order of a tour's records is checked in one place,
:func:`check_next_key`, for batch and streaming alike.

:class:`StreamingPipeline` chains the states of a fitted ``Pipeline``'s steps.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np
from sklearn.utils.validation import check_is_fitted

from tunnelsense._stream_order import check_next_key, stream_order, tour_groups
from tunnelsense.io._writer import ResultsWriter  # its home is tunnelsense.io

__all__ = [
    "ResultsWriter",
    "StreamState",
    "StreamingMixin",
    "StreamingPipeline",
    "check_next_key",
    "start_stream",
    "stream_order",
    "tour_groups",
]


class StreamState:
    """Base of a stage's stream state: the order check, then the stage's own step.

    A subclass supplies ``_push(record) -> list`` (and, when it holds records,
    ``_close() -> list``; when taking several records at once is faster,
    ``_push_many(records) -> list``).  The public :meth:`push`, :meth:`push_many` and
    :meth:`close` check the order of the records (:func:`check_next_key`) first.
    """

    _last_key = None

    def push(self, record) -> list:
        """Take the next record; return the records finished by it, in input order."""
        self._last_key = check_next_key(self._last_key, record)
        return self._push(record)

    def push_many(self, records) -> list:
        """Take consecutive records at once (the same result as pushing them one by one)."""
        last = self._last_key
        for r in records:
            last = check_next_key(last, r)
        self._last_key = last
        return self._push_many(records)

    def close(self) -> list:
        """End the stream; return the records still held."""
        self._last_key = None
        return self._close()

    def _push(self, record) -> list:
        raise NotImplementedError

    def _push_many(self, records) -> list:
        out = []
        for r in records:
            out.extend(self._push(r))
        return out

    def _close(self) -> list:
        return []


class StreamingMixin:
    """Batch ``transform`` of a record stage defined by its stream state.

    A stage supplies

    * ``_stream_state(*, batch)``: a new :class:`StreamState` (``batch=True`` when the
      mixin runs it over records that are all in memory anyway, so that the state
      need not release images);
    * ``_check_records(X) -> list``: the records of ``X``, validated (record type and
      what the stage reads of the payload), errors naming ``X[i]``;
    * ``_sequence``: the container of ``transform``'s output
      (:class:`~tunnelsense.FrameSequence` or :class:`~tunnelsense.ScanSequence`);
    * ``_sort_tours`` (default ``False``): run the tours in the order of their names
      rather than of their first appearance (when ids count across tours).

    :meth:`start_stream` returns a new state for online use; :meth:`transform`
    checks the records once, runs them through one state
    tour by tour in frame order (a repeated key is refused) and returns them in input
    order; :meth:`_stream_batch` gives the records and the state, for ``predict`` and
    the stage's own outputs.
    """

    _sort_tours = False

    def start_stream(self):
        """A new stream state: ``push(record) -> list``, ``close() -> list``.

        Returns
        -------
        state : StreamState
        """
        check_is_fitted(self)
        return self._stream_state()

    def _stream_batch(self, X):
        """Run ``X`` through a new stream state; the records in input order, and the state."""
        check_is_fitted(self)
        records = self._check_records(X)
        order = stream_order(records, sort_tours=self._sort_tours)
        state = self._stream_state(batch=True)
        done = state.push_many([records[i] for i in order.tolist()])
        done.extend(state.close())
        if len(done) != len(records):
            raise RuntimeError(
                f"{type(self).__name__}'s stream state returned {len(done)} records "
                f"for {len(records)}"
            )
        out = [None] * len(records)
        for i, r in zip(order.tolist(), done, strict=True):
            out[i] = r
        return out, state

    def transform(self, X):
        """The records of ``X`` through the stage, in input order.

        Parameters
        ----------
        X : sequence of records

        Returns
        -------
        X_new : FrameSequence or ScanSequence
        """
        return self._sequence(self._stream_batch(X)[0])


class _StatelessStream:
    """Stream state of a stage that maps each record on its own.

    ``checked=True``: the records come checked (see the module docstring), so a stage
    that offers ``_transform_frames`` maps them through it.
    """

    __slots__ = ("_map",)

    def __init__(self, stage, final, checked=False):
        if final and not hasattr(stage, "transform"):
            self._map = stage.predict
        elif checked and hasattr(stage, "_transform_frames"):
            self._map = stage._transform_frames
        elif hasattr(stage, "_stream_frames"):  # checks the records, not the fit
            self._map = stage._stream_frames
        else:
            self._map = stage.transform

    def push(self, record):
        return list(self._map([record]))

    def push_many(self, records):
        return list(self._map(records)) if records else []

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
    if hasattr(stage, "_stream_frames"):  # which does not check the fit a frame at a time
        check_is_fitted(stage)
    return _StatelessStream(stage, final)


class StreamingPipeline:
    """Run a fitted pipeline of record stages online, one record at a time.

    Parameters
    ----------
    pipeline : Pipeline or estimator
        A fitted ``sklearn.pipeline.Pipeline`` of record stages (or one stage).
    prepare_steps : int or None, default=None
        How many of the leading stages that keep no state :meth:`prepare` runs: all
        of them (None), or at most this many.

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

    def __init__(self, pipeline, *, prepare_steps=None):
        steps = getattr(pipeline, "steps", None)
        stages = [s for _, s in steps] if steps is not None else [pipeline]
        stages = [s for s in stages if s is not None and s != "passthrough"]
        if not stages:
            raise ValueError("pipeline has no steps to stream through")
        for s in stages:
            check_is_fitted(s)
        # the first stage checks what the caller pushes; later stateless stages take
        # their predecessors' records without repeating the checks
        self._states = [
            s.start_stream() if hasattr(s, "start_stream")
            else _StatelessStream(s, final=(i == len(stages) - 1), checked=i > 0)
            for i, s in enumerate(stages)
        ]
        self._last_key = None
        # the leading stages that keep no state (not the last: its output is the
        # stream's): :meth:`prepare` runs a record through them on its own
        head = 0
        while (head < len(self._states) - 1
               and isinstance(self._states[head], _StatelessStream)):
            head += 1
        if prepare_steps is not None and (
                isinstance(prepare_steps, bool | np.bool_)
                or not isinstance(prepare_steps, int | np.integer) or prepare_steps < 0):
            raise ValueError("prepare_steps must be None or a non-negative int; got "
                             f"{prepare_steps!r}")
        self._head = head if prepare_steps is None else min(head, int(prepare_steps))

    @property
    def prepared_steps(self) -> int:
        """How many leading stages :meth:`prepare` runs (0: none)."""
        return self._head

    def prepare(self, record):
        """Run one record through the leading stages that keep no state.

        Those stages map each record on its own, so records may be prepared in any
        order and in several threads at once (as the tunnel detector's reader
        threads do, beside the decode); :meth:`push_prepared` then takes each
        prepared record, in stream order, through the rest.  ``push_prepared(
        prepare(r))`` is ``push(r)``.

        Parameters
        ----------
        record : FrameRecord or ScanRecord

        Returns
        -------
        prepared : FrameRecord or ScanRecord
            The record as the last of those stages gives it (``record`` itself when
            the first stage keeps a state).
        """
        for state in self._states[:self._head]:
            out = state.push(record)
            if len(out) != 1:
                raise RuntimeError(f"a stage without state returned {len(out)} "
                                   f"records for one ({record.key})")
            record = out[0]
        return record

    def push_prepared(self, record) -> list:
        """Feed the next record, already through :meth:`prepare`; return the
        finished records of the last step (as :meth:`push` of the original)."""
        self._last_key = check_next_key(self._last_key, record)
        return self._push_from(self._head, [record])

    def push(self, record) -> list:
        """Feed the next record; return the finished records of the last step."""
        self._last_key = check_next_key(self._last_key, record)
        return self._push_from(0, [record])

    def _push_from(self, first, batch) -> list:
        for state in self._states[first:]:
            out = []
            for r in batch:
                out.extend(state.push(r))
            batch = out
            if not batch:
                break
        return batch

    def push_many(self, records, *, prepared=False) -> list:
        """Feed consecutive records at once; the same result as pushing them one by one.

        Each stage takes the whole chunk in one call (``push_many`` of its state,
        ``transform`` of a stateless stage), which saves the per-call overhead where
        records are small and many (laser scans).  ``prepared=True``: the records
        have been through :meth:`prepare` (as with :meth:`push_prepared`).
        """
        records = list(records)
        last = self._last_key
        for r in records:
            last = check_next_key(last, r)
        self._last_key = last
        batch = records
        for state in self._states[self._head if prepared else 0:]:
            if not batch:
                break
            if hasattr(state, "push_many"):
                batch = state.push_many(batch)
            else:
                batch = [out for r in batch for out in state.push(r)]
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

    def run(self, records: Iterable, *, chunk=1) -> Iterator:
        """Stream ``records`` through; yield the last step's records as they finish.

        Parameters
        ----------
        records : iterable of FrameRecord or ScanRecord
        chunk : int, default=1
            Records fed at once (:meth:`push_many`); the results are the same at any
            chunk size, only later by up to ``chunk - 1`` records.
        """
        if chunk <= 1:
            for record in records:
                yield from self.push(record)
        else:
            held = []
            for record in records:
                held.append(record)
                if len(held) == chunk:
                    yield from self.push_many(held)
                    held = []
            yield from self.push_many(held)
        yield from self.close()
