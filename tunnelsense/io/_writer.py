"""Results written line by line, flushed, and resumed after an interruption."""

from __future__ import annotations

import contextlib
import os
import re
import tempfile
from pathlib import Path

from tunnelsense.io._output import check_output, output_error

__all__ = ["ResultsWriter"]


class ResultsWriter:
    """Write result lines as they come, flushed, so an interrupted run keeps them.

    A new file is written in place, line by line: a run killed part-way leaves its
    complete lines, which ``resume=True`` continues.  An existing file is never
    destroyed by accident: it is refused unless ``overwrite=True`` (then the new
    results go to a temporary file renamed over it only when complete) or
    ``resume=True``.

    With ``resume=True`` an existing file is continued.  Before a byte of it is
    changed, its header (or, for a file without one, every line against
    ``line_pattern``) is checked, so that a file this writer did not write is refused
    whole.  The first lines written again -- the detector replays the source from its
    start, which rebuilds its trackers' state exactly -- are checked against the
    complete lines of the file instead of being written twice; a partly written last
    line is replaced only when the replay has matched every line before it and it is
    the start of the line the replay writes there (a line cut off by the
    interruption); other trailing text refuses the file, untouched.  The result
    equals an uninterrupted run.

    Parameters
    ----------
    path : str or Path
        The results file.
    header : str or None, default=None
        A first line (for CSV files); checked, not rewritten, when resuming.
    resume : bool, default=False
        Continue an existing file instead of replacing it.
    overwrite : bool, default=False
        Replace an existing file (atomically, when the writer is closed).
    line_pattern : str or None, default=None
        A regular expression every line of a file without ``header`` must match to
        be resumed.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from tunnelsense.io import ResultsWriter
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "res.txt"
    >>> with ResultsWriter(path) as w:
    ...     w.write("1,1,0,0,4,8,0.9,-1,-1,-1")
    >>> _ = path.write_text(path.read_text() + "2,1,1,0")  # killed while writing line 2
    >>> with ResultsWriter(path, resume=True) as w:
    ...     w.write("1,1,0,0,4,8,0.9,-1,-1,-1")  # replayed: checked, not written
    ...     w.write("2,1,1,0,4,8,0.8,-1,-1,-1")
    >>> path.read_text().splitlines()
    ['1,1,0,0,4,8,0.9,-1,-1,-1', '2,1,1,0,4,8,0.8,-1,-1,-1']
    """

    def __init__(self, path, *, header=None, resume=False, overwrite=False,
                 line_pattern=None):
        self.path = Path(path)
        self._header = header
        self._existing = []
        self._keep = 0  # bytes of the existing file to keep when appending
        self._first_line = 1 if header is None else 2
        self._file = None
        self._tmp = None
        self._pending_header = False
        self._replayed = 0
        self._partial = ""  # a cut-off last line of the existing file
        self.written = 0
        if resume and self.path.exists():
            check_output(self.path, overwrite=True)
            self._read_existing(line_pattern)
            return
        check_output(self.path, overwrite=overwrite)
        if self.path.exists():
            self._open_temporary()
        else:
            if not self.path.parent.exists():
                try:
                    self.path.parent.mkdir(parents=True)
                except OSError as exc:
                    raise output_error(self.path, exc) from None
            self._open(self.path, "x")  # never truncate a file made meanwhile
        if header is not None:
            self._emit(header)
            self.flush()

    def _read_existing(self, line_pattern) -> None:
        """Check the existing file is one this writer wrote; touch nothing yet."""

        data = self.path.read_bytes()
        complete = data[: data.rfind(b"\n") + 1]
        try:
            lines = complete.decode("utf-8").splitlines()
            partial = data[len(complete):].decode("utf-8")
        except UnicodeDecodeError:
            raise ValueError(
                f"{self.path}: cannot resume, the file is not UTF-8 text written by "
                "this command"
            ) from None
        if self._header is not None:
            if not lines:  # killed before the header was complete
                if not self._header.startswith(partial):
                    raise ValueError(
                        f"{self.path}: cannot resume, it does not start with the "
                        f"header {self._header!r}"
                    )
                self._pending_header = True
                return
            if lines[0] != self._header:
                raise ValueError(
                    f"{self.path}: cannot resume, its first line is not the header "
                    f"{self._header!r}"
                )
            lines = lines[1:]
        elif line_pattern is not None:
            pattern = re.compile(line_pattern)
            for n, line in enumerate(lines, 1):
                if not pattern.fullmatch(line):
                    raise ValueError(
                        f"{self.path}: cannot resume, line {n} ({line[:60]!r}) is not "
                        "a line this command writes; is it the right file?"
                    )
        self._existing = lines
        self._keep = len(complete)
        self._partial = partial

    def _open(self, path, mode) -> None:
        try:
            self._file = open(path, mode, encoding="utf-8", newline="\n")  # noqa: SIM115
        except OSError as exc:
            raise output_error(self.path, exc) from None

    def _open_temporary(self) -> None:
        try:
            fd, tmp = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".tmp",
                                       dir=self.path.parent)
            os.chmod(tmp, self.path.stat().st_mode & 0o777)
        except OSError as exc:
            raise output_error(self.path, exc) from None
        os.close(fd)
        self._tmp = tmp
        self._open(tmp, "w")

    def _emit(self, line: str) -> None:
        if self._file is None:  # resuming: every kept line matched, now append
            self._open(self.path, "r+")
            try:
                self._file.truncate(self._keep)
                self._file.seek(self._keep)
                if self._pending_header:
                    self._file.write(self._header + "\n")
                    self._pending_header = False
            except OSError as exc:
                raise output_error(self.path, exc) from None
        try:
            self._file.write(line + "\n")
        except OSError as exc:
            raise output_error(self.path, exc) from None

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
        if self._partial:
            self._check_partial(line)
        self._emit(line)
        self.written += 1

    def _check_partial(self, line) -> None:
        """The file's unfinished last line must be the start of ``line``."""
        partial, self._partial = self._partial, ""
        if line is None or not line.startswith(partial):
            raise ValueError(
                f"{self.path}: cannot resume, the file ends with {partial[:60]!r}, "
                "which is not the start of "
                + ("any line of this run" if line is None else f"this run's next line "
                   f"({line[:60]!r})")
                + "; refusing to delete it (remove it by hand if it is not needed)"
            )

    def flush(self) -> None:
        """Push what was written to the operating system (call after each frame)."""

        if self._file is not None:
            try:
                self._file.flush()
            except OSError as exc:
                raise output_error(self.path, exc) from None

    def close(self) -> None:
        """Check the replay covered the kept lines; finish the file."""

        if self._replayed < len(self._existing):
            missing = len(self._existing) - self._replayed
            self._abandon()
            raise ValueError(
                f"{self.path}: the existing file has {missing} more lines than this run "
                "produced; was it written with another model or source?"
            )
        if self._file is None:  # resumed, nothing new: drop a partial last line
            if self._partial:
                self._check_partial(None)
            self._emit_nothing()
            return
        self.flush()
        self._file.close()
        if self._tmp is not None:
            os.replace(self._tmp, self.path)
            self._tmp = None

    def _emit_nothing(self) -> None:
        if self.path.stat().st_size != self._keep or self._pending_header:
            try:
                with open(self.path, "r+b") as f:
                    f.truncate(self._keep)
                    if self._pending_header:
                        f.write((self._header + "\n").encode())
            except OSError as exc:
                raise output_error(self.path, exc) from None

    def _abandon(self) -> None:
        """Close after an error: a replaced file stays as it was."""

        if self._file is not None:
            with contextlib.suppress(OSError):
                self._file.close()
        if self._tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(self._tmp)
            self._tmp = None

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            self.close()
        else:
            self._abandon()
