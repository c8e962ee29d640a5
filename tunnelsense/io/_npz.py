"""The ``scans.npz`` container: its members read safely, whole or scan by scan.

Every member must be a ``.npy`` array without Python objects; the header is checked
against the member's size before a byte of data is read, CRC and decompression errors
are named, and ``ranges`` can be decompressed a chunk of scans at a time.
"""

from __future__ import annotations

import math
import struct
import zipfile
import zlib
from pathlib import Path

import numpy as np

from tunnelsense.exceptions import InputFormatError

__all__ = ["LazyRanges", "load_npz", "write_npz"]

_NPZ_ERRORS = (zipfile.BadZipFile, zlib.error, ValueError, OSError, EOFError, KeyError,
               NotImplementedError, RuntimeError, OverflowError, TypeError,
               struct.error)

#: The .npy format versions NumPy reads, and their header readers.
_NPY_HEADERS = {
    (1, 0): np.lib.format.read_array_header_1_0,
    (2, 0): np.lib.format.read_array_header_2_0,
    (3, 0): np.lib.format.read_array_header_2_0,  # 2.0 with a UTF-8 header
}


def _corrupt(npz_path, problem) -> InputFormatError:
    return InputFormatError(f"{npz_path}: corrupt or not an .npz file ({problem})")


class _Member:
    """A ``.npy`` member of an npz, its header read and checked against its size."""

    def __init__(self, npz_path, zf, info):
        self.npz_path, self.name = npz_path, info.filename
        try:
            with zf.open(info) as f:
                version = np.lib.format.read_magic(f)
                if version not in _NPY_HEADERS:
                    raise ValueError(f".npy format version {version[0]}."
                                     f"{version[1]} is not supported")
                self.shape, self.fortran, self.dtype = _NPY_HEADERS[version](f)
                self.offset = f.tell()
        except _NPZ_ERRORS as exc:
            raise _corrupt(npz_path, f"{self.name}: {exc}") from None
        problem = self._problem(info.file_size - self.offset)
        if problem:
            raise _corrupt(npz_path, f"{self.name}: {problem}")

    def _read_into(self, zf, view) -> None:
        """Fill ``view`` with the member's data, in bounded reads, checking its CRC."""
        with zf.open(self.name) as f:
            f.read(self.offset)
            done = 0
            while done < len(view):
                chunk = f.read(min(len(view) - done, 1 << 22))
                if not chunk:
                    raise _corrupt(self.npz_path, f"{self.name}: ends early")
                view[done : done + len(chunk)] = chunk
                done += len(chunk)
            f.read()  # to the end of the member: checks its CRC

    def _problem(self, data_bytes) -> str | None:
        if self.dtype.hasobject:
            return "holds Python objects; pickled arrays are refused"
        if self.dtype.subdtype is not None or self.dtype.itemsize == 0:
            return f"unsupported dtype {self.dtype}"
        if any(n < 0 for n in self.shape):
            return f"negative dimension in shape {self.shape}"
        if self.nbytes != data_bytes:
            return (f"its header describes {self.dtype} of shape {self.shape} "
                    f"({self.nbytes} bytes), but it holds {data_bytes} bytes")
        return None

    @property
    def nbytes(self) -> int:
        """The size of the array the header describes, in bytes."""
        return math.prod(self.shape) * self.dtype.itemsize

    def read(self, zf) -> np.ndarray:
        """The whole array; reads at most the bytes the member really holds."""
        try:
            raw = np.empty(self.nbytes, dtype=np.uint8)
        except MemoryError:
            raise _corrupt(self.npz_path, f"{self.name}: {self.nbytes} bytes do not "
                           "fit in memory") from None
        try:
            self._read_into(zf, memoryview(raw))
        except InputFormatError:
            raise
        except _NPZ_ERRORS as exc:
            raise _corrupt(self.npz_path, f"{self.name}: {exc}") from None
        flat = np.frombuffer(raw, dtype=self.dtype, count=math.prod(self.shape))
        return flat.reshape(self.shape, order="F" if self.fortran else "C")


def load_npz(path: Path, *, lazy_ranges=False) -> tuple[dict, list]:
    """The arrays of an npz by field name, and the names of its other members.

    ``ranges`` is a :class:`LazyRanges` if ``lazy_ranges``.  Members whose names do
    not end in ``.npy`` are not read.
    """
    if not path.is_file():
        raise FileNotFoundError(f"{path}: scans file not found")
    try:
        with zipfile.ZipFile(path) as zf:
            infos = {i.filename: i for i in zf.infolist()}  # the last of a name wins
            data, others = {}, []
            for name, info in infos.items():
                if not name.endswith(".npy"):
                    others.append(name)
                    continue
                member = _Member(path, zf, info)
                if lazy_ranges and name == "ranges.npy":
                    data["ranges"] = LazyRanges(member)
                else:
                    data[name[: -len(".npy")]] = member.read(zf)
    except InputFormatError:
        raise
    except _NPZ_ERRORS as exc:
        raise _corrupt(path, exc) from None
    return data, others


class LazyRanges:
    """Shape and dtype of ``ranges.npy`` inside an npz, rows read on demand."""

    def __init__(self, member):
        self.member = member
        self.npz_path, self.shape, self.dtype = (
            member.npz_path, member.shape, member.dtype
        )

    def iter_chunks(self, rows):
        """Yield ``(first_scan, block)``; a damaged member raises InputFormatError.

        A column-major (Fortran-ordered) member is read whole first.
        """
        start = 0
        try:
            with zipfile.ZipFile(self.npz_path) as zf:
                blocks = (self._whole if self.member.fortran else self._rows)(zf, rows)
                for start, block in blocks:
                    yield start, block
        except InputFormatError:
            raise
        except _NPZ_ERRORS as exc:
            raise InputFormatError(
                f"{self.npz_path}: corrupt ranges.npy after scan {start} ({exc})"
            ) from None

    def _whole(self, zf, rows):
        ranges = self.member.read(zf)
        for start in range(0, len(ranges), rows):
            yield start, ranges[start : start + rows]

    def _rows(self, zf, rows):
        n_scans, n_beams = self.shape
        row_bytes = n_beams * self.dtype.itemsize
        with zf.open(self.member.name) as f:
            f.read(self.member.offset)
            for start in range(0, n_scans, rows):
                n = min(rows, n_scans - start)
                buf = f.read(n * row_bytes)
                if len(buf) != n * row_bytes:
                    raise InputFormatError(
                        f"{self.npz_path}: ranges end early (truncated file)"
                    )
                if start + n == n_scans:
                    f.read()  # to the end of the member: checks its CRC
                yield start, np.frombuffer(buf, self.dtype).reshape(n, n_beams)


def write_npz(path: Path, arrays: dict) -> None:
    """Like ``np.savez_compressed`` but byte-identical for identical arrays.

    NumPy stamps each member with the current time; a fixed timestamp makes the same
    run give the same file.
    """
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for key, value in arrays.items():
            info = zipfile.ZipInfo(f"{key}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            with zf.open(info, "w", force_zip64=True) as f:
                np.lib.format.write_array(f, np.asanyarray(value), allow_pickle=False)
