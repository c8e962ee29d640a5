"""The exceptions tunnelsense raises on bad input, untrusted models and outputs.

Every reader raises :class:`InputFormatError` (a :class:`ValueError`) for a file or
argument that does not hold what was expected; the message names the file (and the
line, frame or field) and says what was expected.  A model file that cannot be
trusted raises :class:`UntrustedModelError`; an output that already exists, and
would be destroyed, raises :class:`OutputExistsError`.

Examples
--------
>>> import pathlib, tempfile
>>> from tunnelsense.exceptions import InputFormatError
>>> from tunnelsense.io import read_run_gt
>>> path = pathlib.Path(tempfile.mkdtemp()) / "gt.csv"
>>> _ = path.write_text("id,first_scan,last_scan,label\\n1,3,x,parked\\n")
>>> try:
...     read_run_gt(path)
... except InputFormatError as exc:
...     print(str(exc).endswith("line 2: last_scan is 'x', expected an integer"))
True
"""

from __future__ import annotations

__all__ = [
    "InputFormatError",
    "ModelVersionWarning",
    "OutputExistsError",
    "UntrustedModelError",
]


class InputFormatError(ValueError):
    """A file or argument does not hold what was expected.

    The message names the file (and line, frame, member or field) or the argument,
    and what was expected.  A subclass of :class:`ValueError`.
    """


class UntrustedModelError(InputFormatError):
    """A model file was refused: not ours, tampered, truncated, or untrusted types."""


class OutputExistsError(FileExistsError):
    """An output file already exists; it is left untouched (pass ``force``)."""


class ModelVersionWarning(UserWarning):
    """A model was trained under other library versions than those installed."""
