"""Progress of long command-line work, on stderr, through tqdm.

tqdm is the progress bar most Python users know (a bar on a terminal, rate and time
left); this adapter gives it the ``update(done)`` calls of our long jobs, which count
work done so far rather than steps.
"""

from __future__ import annotations

import sys
import weakref

from tqdm import tqdm

__all__ = ["Progress", "close_all"]

#: The bars not yet closed (closed first when a command ends early).
_OPEN = weakref.WeakSet()


def close_all():
    """Close every open bar, so that a message printed next starts on its own line
    (and no bar is drawn again after it when the interpreter exits)."""
    for bar in list(_OPEN):
        bar.close()


class Progress:
    """Report ``done / total`` of a long job on stderr.

    Parameters
    ----------
    total : int
        Units of work (frames, scans, fits).
    desc : str
        What is being done, e.g. ``"rendering frames"``.
    stream : file, default=sys.stderr
    enabled : bool, default=True
    unit : str, default="it"
        Name of a unit of work, for the rate.
    """

    def __init__(self, total, desc, *, stream=None, enabled=True, unit="it"):
        self.total = max(int(total), 1)
        self._bar = tqdm(
            total=self.total,
            desc=desc,
            file=sys.stderr if stream is None else stream,
            disable=not enabled,
            unit=unit,
            mininterval=0.2,
            dynamic_ncols=True,
            leave=True,
        )
        self._done = 0
        _OPEN.add(self)

    def __call__(self, done, total=None):
        self.update(done)

    def set_total(self, total):
        """Change the units of work (once the job knows them)."""
        self.total = max(int(total), 1)
        self._bar.total = self.total
        self._bar.refresh()

    def update(self, done):
        """Set the work done so far; the bar closes when it reaches ``total``."""
        done = min(int(done), self.total)
        if done > self._done:
            self._bar.update(done - self._done)
            self._done = done
        if done >= self.total:
            self.close()

    def describe(self, desc):
        """Say what is being done now."""
        self._bar.set_description_str(desc)  # drawn at once: every stage is seen

    def close(self):
        _OPEN.discard(self)
        self._bar.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
