"""A dependency-free progress bar for long command-line work (written to stderr)."""

from __future__ import annotations

import sys
import time

__all__ = ["Progress"]


class Progress:
    """Report ``done / total`` of a long job on stderr.

    On a terminal the line is redrawn in place at most every 0.2 s; in a log (CI, a
    pipe) a line is written at every tenth of the work, so logs stay short.

    Parameters
    ----------
    total : int
        Units of work (frames, scans).
    desc : str
        What is being done, e.g. ``"rendering frames"``.
    stream : file, default=sys.stderr
    enabled : bool, default=True
    """

    def __init__(self, total, desc, *, stream=None, enabled=True):
        self.total = max(int(total), 1)
        self.desc = desc
        self.stream = sys.stderr if stream is None else stream
        self.enabled = enabled
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.start = time.perf_counter()
        self._last_draw = 0.0
        self._last_tenth = -1

    def __call__(self, done, total=None):
        self.update(done)

    def update(self, done):
        if not self.enabled:
            return
        now = time.perf_counter()
        fraction = min(done / self.total, 1.0)
        if self.tty:
            if now - self._last_draw < 0.2 and done < self.total:
                return
            self._last_draw = now
            width = 30
            bar = "#" * int(fraction * width)
            self.stream.write(
                f"\r{self.desc}: [{bar:<{width}}] {done}/{self.total} {self._rate(done, now)}"
            )
            if done >= self.total:
                self.stream.write("\n")
        else:
            tenth = int(fraction * 10)
            if tenth == self._last_tenth:
                return
            self._last_tenth = tenth
            self.stream.write(
                f"{self.desc}: {done}/{self.total} ({fraction:.0%}) {self._rate(done, now)}\n"
            )
        self.stream.flush()

    def _rate(self, done, now):
        elapsed = now - self.start
        return f"{done / elapsed:.0f}/s" if elapsed > 0 and done else ""
