"""Containers of records: one or several tours or runs, split as scikit-learn splits."""

from __future__ import annotations

import numbers
from collections.abc import Iterable, Sequence

import numpy as np

from tunnelsense._records._frames import FrameRecord
from tunnelsense._records._scans import LaserGeometry, ScanRecord

__all__ = ["FrameSequence", "ScanSequence"]


class _RecordSequence(Sequence):
    """A sequence of records that scikit-learn can split.

    ``len``, integer indexing (a record), slice / integer-array / boolean-array
    indexing (a sequence of the same type), ``+`` and :meth:`concat`.  It has no
    ``shape`` on purpose: scikit-learn's ``_safe_indexing`` then hands each CV fold a
    plain list of records, which every stage accepts.
    """

    _record_type: type = object
    _group_attr = ""

    __slots__ = ("_records",)

    def __init__(self, records: Iterable = ()):
        records = tuple(records)
        for i, r in enumerate(records):
            if not isinstance(r, self._record_type):
                raise TypeError(
                    f"{type(self).__name__} holds {self._record_type.__name__} "
                    f"objects; element {i} is {type(r).__name__}"
                )
        self._records = records

    def __getstate__(self):
        return self._records

    def __setstate__(self, state):
        self._records = state

    def __len__(self):
        return len(self._records)

    def __iter__(self):
        return iter(self._records)

    def __getitem__(self, index):
        if isinstance(index, numbers.Integral):
            return self._records[index]
        if isinstance(index, slice):
            return type(self)(self._records[index])
        index = np.asarray(index)
        if index.dtype == bool:
            if index.shape != (len(self),):
                raise IndexError(
                    f"boolean index of shape {index.shape} for {len(self)} records"
                )
            index = np.flatnonzero(index)
        elif index.ndim != 1 or not np.issubdtype(index.dtype, np.integer):
            if index.size == 0:
                index = index.astype(np.intp).ravel()
            else:
                raise IndexError(
                    "records are indexed by an int, a slice, or a 1-D array of ints "
                    f"or bools; got an array of dtype {index.dtype} and shape "
                    f"{index.shape}"
                )
        records = self._records
        return type(self)(records[i] for i in index.tolist())

    def __add__(self, other):
        if not isinstance(other, _RecordSequence | list | tuple):
            return NotImplemented
        return type(self)((*self._records, *other))

    @classmethod
    def concat(cls, sequences: Iterable[Iterable]):
        """Concatenate several sequences of records (for example several tours)."""
        return cls(r for seq in sequences for r in seq)

    @property
    def groups(self) -> np.ndarray:
        """The tour (run) name of every record, for ``GroupKFold``."""
        return np.array(
            [getattr(r, self._group_attr) for r in self._records], dtype=object
        )

    def __repr__(self):
        names = dict.fromkeys(getattr(r, self._group_attr) for r in self._records)
        shown = ", ".join(repr(n) for n in list(names)[:3])
        more = f", ... ({len(names)} in all)" if len(names) > 3 else ""
        return f"{type(self).__name__}({len(self)} records of [{shown}{more}])"


class FrameSequence(_RecordSequence):
    """Frames of one or several tours, loaded lazily (see :class:`FrameRecord`).

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import FrameSequence
    >>> a = FrameSequence.from_array(np.zeros((3, 4, 6), np.uint8), tour="a")
    >>> b = FrameSequence.from_array(np.zeros((2, 4, 6), np.uint8), tour="b")
    >>> X = a + b
    >>> len(X), X[[0, 4]].groups.tolist()
    (5, ['a', 'b'])
    """

    _record_type = FrameRecord
    _group_attr = "tour"
    __slots__ = ()

    @classmethod
    def from_array(cls, images, *, tour: str = "tour", first_frame: int = 1):
        """Frames of one tour from an array of shape ``(n_frames, height, width)``."""
        images = np.asarray(images)
        if images.ndim != 3:
            raise ValueError(
                "images must be an array of shape (n_frames, height, width); "
                f"got shape {images.shape}"
            )
        return cls(
            FrameRecord(str(tour), first_frame + i, images[i])
            for i in range(len(images))
        )


class ScanSequence(_RecordSequence):
    """Scans of one or several laser runs (see :class:`ScanRecord`)."""

    _record_type = ScanRecord
    _group_attr = "run"
    __slots__ = ()

    @classmethod
    def from_arrays(cls, ranges, stamps, geometry: LaserGeometry, *, run: str = "run"):
        """Scans of one run from ``ranges`` (n_scans, n_beams) and ``stamps``."""
        ranges = np.asarray(ranges, dtype=np.float64)
        stamps = np.asarray(stamps, dtype=np.float64)
        if ranges.ndim != 2:
            raise ValueError(
                f"ranges must have shape (n_scans, n_beams); got shape {ranges.shape}"
            )
        if stamps.shape != (len(ranges),):
            raise ValueError(
                f"stamps must have shape ({len(ranges)},) to match ranges; "
                f"got shape {stamps.shape}"
            )
        return cls(
            ScanRecord(str(run), i, ranges[i], float(stamps[i]), geometry)
            for i in range(len(ranges))
        )

    def ranges(self) -> np.ndarray:
        """The ranges of all scans stacked, shape ``(n_scans, n_beams)``."""
        if not self._records:
            return np.empty((0, 0))
        return np.stack([r.ranges for r in self._records])
