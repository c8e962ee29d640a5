"""MOTChallenge tables (``gt.txt``, results files): strict parsing, exact writing.

Every field must be a decimal number; integers (``frame``, ``id``, ``class``) exact in
float64; frames from 1; boxes not negative.  An error names the file and the line.
"""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np
import pandas as pd

from tunnelsense._records import MOT_GT_COLUMNS
from tunnelsense.exceptions import InputFormatError


def _round_trip() -> dict:
    """Read floats back exactly as written: pandas 3 does by default (and deprecates
    the argument), pandas 2's C parser only when asked."""
    return {} if int(pd.__version__.split(".")[0]) >= 3 else {"float_precision":
                                                               "round_trip"}


def __getattr__(name):  # ROUND_TRIP: asks pandas its version when first used
    if name == "ROUND_TRIP":
        return _round_trip()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

__all__ = ["LineNumbers", "read_mot_gt", "read_table", "write_mot_gt"]

_INT_COLUMNS = {"frame", "id", "class"}


# --------------------------------------------------------------------------------------
# Comma-separated MOT tables
# --------------------------------------------------------------------------------------
class LineNumbers(tuple):
    """The file line of each row of a table read from disk (``table.attrs["lines"]``).

    pandas deep-copies ``attrs`` at every operation on the table; a tuple cannot
    change, so its copies are itself.
    """

    __slots__ = ()

    def __deepcopy__(self, memo):
        return self


#: A decimal number as MOTChallenge files write them (ASCII digits, no ``_``).
_NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_NON_FINITE = re.compile(r"[+-]?(?:nan|inf|infinity)", re.IGNORECASE)
#: Integer columns must stay below this: larger integers are not exact in float64.
_MAX_INT = 2**53


def _split_lines(text) -> list[str]:
    """The lines of a text file: LF, CRLF and CR end a line, and nothing else does."""
    return text.replace("\r\n", "\n").replace("\r", "\n").split("\n")


def _read_text(path) -> str:
    """A file's text as UTF-8 (a BOM is dropped); other bytes name their line."""
    data = Path(path).read_bytes()
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = len(_split_lines(data[: exc.start].decode("utf-8", "replace")))
        raise InputFormatError(
            f"{path}, line {line}: not UTF-8 text (byte 0x{data[exc.start]:02x}); "
            "expected a UTF-8 or ASCII text file"
        ) from None
    return text.removeprefix("\ufeff")


def _parse_field(path, lineno, name, value) -> float:
    """One field of a table as a float; integer columns must hold integers."""
    if len(value) > 1 and value[0] == value[-1] == '"':
        value = value[1:-1].strip()
    if not (_NUMBER.fullmatch(value) or _NON_FINITE.fullmatch(value)):
        raise InputFormatError(
            f"{path}, line {lineno}: column {name!r} is {value!r}, expected a number"
        )
    number = float(value)
    if name in _INT_COLUMNS and not number.is_integer():
        raise InputFormatError(
            f"{path}, line {lineno}: column {name!r} is {value!r}, expected an integer"
        )
    return number


def _parse_line_by_line(path, numbered, columns) -> pd.DataFrame:
    """Slow path: parse each line, and say what is wrong with the first bad one."""
    rows = []
    for lineno, line in numbered:
        fields = [f.strip() for f in line.split(",")]
        if len(fields) != len(columns):
            raise InputFormatError(
                f"{path}, line {lineno}: {len(fields)} columns, expected "
                f"{len(columns)} ({','.join(columns)})"
            )
        rows.append([_parse_field(path, lineno, c, v)
                     for c, v in zip(columns, fields, strict=True)])
    return pd.DataFrame(rows, columns=list(columns), dtype=np.float64)


def _parse_fast(numbered, columns):
    """pandas' C parser; None when any line needs the line-by-line parser's eye."""
    if any(line.count(",") != len(columns) - 1 for _, line in numbered):
        return None
    try:
        table = pd.read_csv(
            io.StringIO("\n".join(line for _, line in numbered)),
            header=None,
            names=list(columns),
            dtype=np.float64,
            skip_blank_lines=True,
            skipinitialspace=True,
            **_round_trip(),
        )
    except (ValueError, pd.errors.ParserError):
        return None
    ints = table[[c for c in columns if c in _INT_COLUMNS]].to_numpy()
    if (
        len(table) != len(numbered)
        or table.isna().to_numpy().any()
        or not np.array_equal(ints, np.round(ints))
    ):
        return None
    return table


def _first_bad(path, lines, bad, message):
    """Raise ``message`` for the first row flagged in ``bad``, naming its line."""
    rows = np.flatnonzero(bad)
    if rows.size:
        raise InputFormatError(f"{path}, line {lines[rows[0]]}: {message(rows[0])}")


def _check_table(path, table, lines):
    """Finite numbers, integers exact in float64, frames from 1, boxes not negative."""
    _first_bad(path, lines, ~np.isfinite(table.to_numpy()).all(axis=1),
               lambda i: "NaN or infinity, expected numbers")
    for c in [c for c in table.columns if c in _INT_COLUMNS]:
        _first_bad(path, lines, np.abs(table[c].to_numpy()) >= _MAX_INT,
                   lambda i, c=c: f"integer column out of range: {c!r} is not below "
                   "2**53 in magnitude")
    frames = table["frame"].to_numpy()
    _first_bad(path, lines, frames < 1,
               lambda i: f"column 'frame' is {frames[i]:.0f}, expected a frame number "
               "of 1 or more (MOTChallenge counts frames from 1)")
    sizes = table[["bb_width", "bb_height"]].to_numpy()
    _first_bad(path, lines, (sizes < 0).any(axis=1),
               lambda i: "negative box width or height")


def read_table(path, columns) -> pd.DataFrame:
    """Parse a headerless MOT table; ``table.attrs["lines"]`` holds each row's line."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: file not found")
    numbered = [
        (lineno, line)
        for lineno, line in enumerate(_split_lines(_read_text(path)), start=1)
        if line.strip()
    ]
    if not numbered:
        table = pd.DataFrame({c: pd.Series(dtype=np.float64) for c in columns})
    else:
        table = _parse_fast(numbered, columns)
        if table is None:
            table = _parse_line_by_line(path, numbered, columns)
    lines = LineNumbers(lineno for lineno, _ in numbered)
    _check_table(path, table, lines)
    for c in columns:
        if c in _INT_COLUMNS:
            table[c] = table[c].to_numpy().astype(np.int64)
    table.attrs["lines"] = lines
    return table


def read_mot_gt(path) -> pd.DataFrame:
    """Read a MOTChallenge ``gt.txt`` (9 columns) as a DataFrame.

    Parameters
    ----------
    path : str or Path
        The ground-truth file.

    Returns
    -------
    gt : DataFrame
        Columns ``frame,id,bb_left,bb_top,bb_width,bb_height,conf,class,visibility``;
        ``frame``, ``id`` and ``class`` as int64, the rest float64.
        ``gt.attrs["lines"]`` holds the file line of each row.

    Raises
    ------
    FileNotFoundError
        There is no such file.
    InputFormatError
        Text that is not UTF-8, a line with another number of columns, a field that
        is not a decimal number (ASCII digits), NaN or infinity, a non-integer or an
        integer of magnitude ``2**53`` or more in ``frame``, ``id`` or ``class``, a
        frame below 1, or a negative box width or height.  The message names the file
        and the line.
    """
    return read_table(path, MOT_GT_COLUMNS)


def _write_table(frame: pd.DataFrame, path, columns):
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise InputFormatError(
            f"cannot write {path}: the table lacks columns {missing}"
        )
    out = frame[list(columns)].copy()
    for c in columns:
        if c in _INT_COLUMNS:
            out[c] = out[c].astype(np.int64)
        else:
            out[c] = out[c].astype(np.float64)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    # repr-formatted floats read back to the same bits.
    out.to_csv(path, header=False, index=False, lineterminator="\n")


def write_mot_gt(gt: pd.DataFrame, path) -> None:
    """Write ground truth as a MOTChallenge ``gt.txt``.

    Floats are written in their shortest round-trip form, so :func:`read_mot_gt` gives
    back the same table.

    Parameters
    ----------
    gt : DataFrame
        With the columns ``frame,id,bb_left,bb_top,bb_width,bb_height,conf,class,
        visibility``.
    path : str or Path
        The file to write (its folder is created).
    """
    _write_table(gt, path, MOT_GT_COLUMNS)
