"""A run's ground truth ``gt.csv`` and the object tables ``detect street`` writes.

``gt.csv`` holds ``id,first_scan,last_scan,label`` (0-based, inclusive scans; labels
``parked`` and ``passing``); every malformed line is named.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
import pandas as pd

from tunnelsense._records import (
    RUN_GT_COLUMNS,
    RUN_LABELS,
)
from tunnelsense.exceptions import InputFormatError
from tunnelsense.io._mot import LineNumbers

__all__ = ["read_objects", "read_run_gt", "write_run_gt"]

def read_run_gt(path) -> pd.DataFrame:
    """Read a laser run's ``gt.csv`` (``id,first_scan,last_scan,label``).

    The first line is the header; an optional ``vehicle_class`` column (``car``,
    ``van``, ``motorbike`` or empty) is kept, further columns are allowed and left
    out; blank lines are skipped.  A row with more non-empty fields than the header is refused
    (never shifted).

    Parameters
    ----------
    path : str or Path
        The ground-truth file.

    Returns
    -------
    gt : DataFrame
        ``id``, ``first_scan``, ``last_scan`` as int64 and ``label`` (and
        ``vehicle_class`` when the file has it) as strings;
        ``gt.attrs["lines"]`` holds the file line of each row.

    Raises
    ------
    FileNotFoundError
        The file is missing.
    InputFormatError
        Text that is not UTF-8 CSV, a missing or repeated column, a row with more
        fields than the header, a scan number that is not an integer of at most 18
        digits, ``first_scan > last_scan`` or a label other than ``parked`` /
        ``passing`` (names the file and line).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: ground-truth file not found")
    lines, header, rows = _read_csv_rows(path)
    columns = _gt_columns(path, header)
    out = {
        c: np.array(
            [_scan_number(path, i, c, row[columns[c]]) for i, row in zip(lines, rows,
                                                                          strict=True)],
            dtype=np.int64,
        )
        for c in ("id", "first_scan", "last_scan")
    }
    labels = [row[columns["label"]].strip() for row in rows]
    for i, label in zip(lines, labels, strict=True):
        if label not in RUN_LABELS:
            raise InputFormatError(
                f"{path}, line {i}: unknown label {label!r}, expected one of "
                f"{', '.join(RUN_LABELS)}"
            )
    for i, a, b in zip(lines, out["first_scan"], out["last_scan"], strict=True):
        if a < 0 or b < a:
            raise InputFormatError(
                f"{path}, line {i}: first_scan={a}, last_scan={b}; expected "
                "0 <= first_scan <= last_scan"
            )
    table = pd.DataFrame({**out, "label": pd.Series(labels, dtype=str)})
    if "vehicle_class" in header:
        from tunnelsense.street._census import VEHICLE_CLASSES  # (no import circle)

        at = header.index("vehicle_class")
        kinds = [row[at].strip() for row in rows]
        for i, kind in zip(lines, kinds, strict=True):
            if kind not in ("", *VEHICLE_CLASSES):
                raise InputFormatError(
                    f"{path}, line {i}: vehicle_class is {kind!r}, expected one of "
                    f"{', '.join(VEHICLE_CLASSES)} or empty")
        table["vehicle_class"] = pd.Series(kinds, dtype=object)
    table.attrs["lines"] = LineNumbers(lines)
    return table


def _read_csv_rows(path) -> tuple[list, list, list]:
    """File lines (from 2) and fields of the non-blank rows, and the header's fields.

    Rows shorter than the header are padded with empty fields; fields beyond the
    header's are refused unless empty.
    """
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputFormatError(f"{path}: not UTF-8 text ({exc})") from None
    reader = csv.reader(io.StringIO(text, newline=""), strict=True)
    header, lines, rows = None, [], []
    try:
        while True:
            line = reader.line_num + 1
            row = next(reader, None)
            if row is None:
                break
            if header is None:
                header = [c.strip() for c in row]
            elif any(f.strip() for f in row):
                if any(f.strip() for f in row[len(header) :]):
                    raise InputFormatError(
                        f"{path}, line {line}: {len(row)} fields, expected "
                        f"{len(header)} as in the header"
                    )
                lines.append(line)
                rows.append((row + [""] * len(header))[: len(header)])
    except csv.Error as exc:
        raise InputFormatError(
            f"{path}, line {reader.line_num}: not readable as CSV ({exc})"
        ) from None
    return lines, header or [], rows


def _gt_columns(path, header) -> dict:
    """The position of each ground-truth column in the header."""
    missing = [c for c in RUN_GT_COLUMNS if c not in header]
    if missing:
        raise InputFormatError(
            f"{path}: lacks column(s) {', '.join(missing)} (expected header "
            f"{','.join(RUN_GT_COLUMNS)})"
        )
    for c in RUN_GT_COLUMNS:
        if header.count(c) > 1:
            raise InputFormatError(f"{path}, line 1: column {c} appears twice")
    return {c: header.index(c) for c in RUN_GT_COLUMNS}


def _scan_number(path, line, column, text) -> int:
    """An integer field of gt.csv, of at most 18 digits (int64 holds it)."""
    try:
        number = int(text.strip())
    except ValueError:  # not an integer, or thousands of digits
        number = None
    if number is None or not -(2**62) < number < 2**62:
        raise InputFormatError(
            f"{path}, line {line}: {column} is {text!r}, expected an integer"
            + ("" if number is None else " of at most 18 digits")
        )
    return number


def read_objects(path) -> pd.DataFrame:
    """Read an object table written by ``tunnelsense detect street``.

    Parameters
    ----------
    path : str or Path
        A CSV file with at least the columns ``first_scan``, ``last_scan`` and
        ``label`` (``detect street`` writes ``id,first_scan,last_scan,label,...``).

    Returns
    -------
    objects : DataFrame
        Its optional ``vehicle_class`` column (``car``, ``van``, ``motorbike``, or
        empty for an object of no class) as strings; a table written before the
        detector gave classes has none, and reads as it is.

    Raises
    ------
    FileNotFoundError
        The file is missing.
    InputFormatError
        It is not a CSV table, lacks a column, or a row's scans are not integers
        ``0 <= first_scan <= last_scan`` (of at most 18 digits), its label is
        empty or its ``vehicle_class`` is not a vehicle class; the message names
        the file and the line.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: objects file not found")
    try:
        objects = pd.read_csv(path, dtype={c: str for c in ("first_scan", "last_scan",
                                                           "label", "vehicle_class")})
    except (pd.errors.ParserError, UnicodeDecodeError, pd.errors.EmptyDataError,
            ValueError, OSError) as exc:
        raise InputFormatError(f"{path}: not a CSV object table ({exc})") from None
    missing = [c for c in ("first_scan", "last_scan", "label") if c not in objects]
    if missing:
        raise InputFormatError(f"{path}: lacks column(s) {', '.join(missing)}: expected "
                               "id,first_scan,last_scan,label,mean_depth")
    for column in ("first_scan", "last_scan"):
        text = objects[column].fillna("").str.strip()
        bad = ~text.str.fullmatch(r"\d{1,18}")
        if bad.any():
            row = int(np.flatnonzero(bad.to_numpy())[0])
            raise InputFormatError(
                f"{path}, line {row + 2}: {column} is {objects[column].iloc[row]!r}, "
                "expected a non-negative integer of at most 18 digits")
        objects[column] = text.astype(np.int64)
    after = objects["first_scan"] > objects["last_scan"]
    objects["label"] = objects["label"].fillna("")
    empty = objects["label"].str.strip() == ""
    for bad, what in ((after, "first_scan after last_scan"), (empty, "an empty label")):
        if bad.any():
            row = int(np.flatnonzero(bad.to_numpy())[0])
            raise InputFormatError(f"{path}, line {row + 2}: {what}")
    if "vehicle_class" in objects:
        from tunnelsense.street._census import VEHICLE_CLASSES  # (no import circle)

        kind = objects["vehicle_class"].fillna("").astype(str).str.strip()
        bad = ~kind.isin(("", *VEHICLE_CLASSES))
        if bad.any():
            row = int(np.flatnonzero(bad.to_numpy())[0])
            raise InputFormatError(
                f"{path}, line {row + 2}: vehicle_class is {kind.iloc[row]!r}, expected "
                f"one of {', '.join(VEHICLE_CLASSES)} or empty")
        objects["vehicle_class"] = kind.astype(object)
    return objects


def write_run_gt(gt: pd.DataFrame, path) -> None:
    """Write a laser run's ground truth as ``gt.csv``.

    Parameters
    ----------
    gt : DataFrame
        With the columns ``id,first_scan,last_scan,label`` (and ``vehicle_class``,
        written when present).
    path : str or Path
        The file to write (its folder is created).
    """
    missing = [c for c in RUN_GT_COLUMNS if c not in gt.columns]
    if missing:
        raise ValueError(f"cannot write {path}: the table lacks columns {missing}")
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    columns = list(RUN_GT_COLUMNS) + (["vehicle_class"] if "vehicle_class" in gt else [])
    gt[columns].to_csv(path, index=False, lineterminator="\n")
