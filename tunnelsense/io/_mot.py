"""Far-infrared tours on disk: MOTChallenge sequence folders, image folders, videos.

A MOTChallenge sequence folder holds::

    seqinfo.ini        [Sequence] name, imDir, frameRate, seqLength, imWidth, imHeight, imExt
    img1/000001.png    one image per frame (8-bit or 16-bit), numbered from 1
    gt/gt.txt          frame,id,bb_left,bb_top,bb_width,bb_height,conf,class,visibility

Results files use MOTChallenge's 10 columns
``frame,id,bb_left,bb_top,bb_width,bb_height,conf,x,y,z`` with ``x, y, z = -1``.
"""

from __future__ import annotations

import configparser
import io
import math
import re
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from tunnelsense._records import (
    MOT_GT_COLUMNS,
    FrameRecord,
    FrameSequence,
    ImageFile,
    Tour,
    VideoFrame,
    empty_mot_gt,
)
from tunnelsense.exceptions import InputFormatError
from tunnelsense.io._images import (
    IMAGE_EXTENSIONS,
    open_video,
    read_image,
    read_png_size,
    stated_frame_count,
    video_length_error,
)

__all__ = [
    "MOT_RESULT_COLUMNS",
    "read_image_folder",
    "read_mot_gt",
    "read_mot_results",
    "read_tour",
    "read_video",
    "write_mot_gt",
    "write_mot_results",
    "write_tour",
]

#: Column names of a MOTChallenge results file.
MOT_RESULT_COLUMNS = (
    "frame",
    "id",
    "bb_left",
    "bb_top",
    "bb_width",
    "bb_height",
    "conf",
    "x",
    "y",
    "z",
)

_SEQINFO_KEYS = (
    "name",
    "imDir",
    "frameRate",
    "seqLength",
    "imWidth",
    "imHeight",
    "imExt",
)
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


def _read_table(path, columns) -> pd.DataFrame:
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
    return _read_table(path, MOT_GT_COLUMNS)


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


def read_mot_results(path) -> pd.DataFrame:
    """Read a MOTChallenge results file as a DataFrame.

    Parameters
    ----------
    path : str or Path
        A results file with the 10 columns
        ``frame,id,bb_left,bb_top,bb_width,bb_height,conf,x,y,z``.

    Returns
    -------
    results : DataFrame
        ``frame`` and ``id`` as int64, the rest float64.

    Raises
    ------
    FileNotFoundError
        There is no such file.
    InputFormatError
        As for :func:`read_mot_gt` (names the file and the line).
    """
    return _read_table(path, MOT_RESULT_COLUMNS)


def write_mot_results(results: pd.DataFrame, path) -> None:
    """Write detections as a MOTChallenge results file.

    Parameters
    ----------
    results : DataFrame
        With ``frame,id,bb_left,bb_top,bb_width,bb_height,conf``; ``x, y, z`` are
        written as -1 unless given.
    path : str or Path
        The file to write (its folder is created).
    """
    results = results.copy()
    for c in ("x", "y", "z"):
        if c not in results.columns:
            results[c] = -1.0
    _write_table(results, path, MOT_RESULT_COLUMNS)


# --------------------------------------------------------------------------------------
# Sequence folders
# --------------------------------------------------------------------------------------
def _read_seqinfo(path: Path) -> dict:
    """The ``[Sequence]`` keys of a ``seqinfo.ini``, numbers parsed and checked."""
    if not path.is_file():
        raise FileNotFoundError(
            f"{path}: seqinfo.ini not found (not a MOTChallenge folder)"
        )
    parser = configparser.ConfigParser(interpolation=None)
    parser.optionxform = str
    try:
        parser.read_string(_read_text(path), source=str(path))
    except configparser.Error as exc:
        raise InputFormatError(f"{path}: not a valid ini file: {exc}") from None
    sections = [s for s in parser.sections() if s.lower() == "sequence"]
    if not sections:
        raise InputFormatError(f"{path}: no [Sequence] section")
    info = _sequence_keys(path, dict(parser.items(sections[0])))
    for key in ("seqLength", "imWidth", "imHeight"):
        info[key] = _ini_integer(path, key, info[key], minimum=int(key != "seqLength"))
    info["frameRate"] = _ini_frame_rate(path, info["frameRate"])
    if not info["imExt"].startswith("."):
        info["imExt"] = "." + info["imExt"]
    return info


def _sequence_keys(path, items) -> dict:
    """The required keys (any letter case), the others under ``"extra"``."""
    lower = {k.lower(): k for k in items}
    info = {}
    missing = []
    for key in _SEQINFO_KEYS:
        if key in items:
            info[key] = items.pop(key)
        elif key.lower() in lower:
            info[key] = items.pop(lower[key.lower()])
        else:
            missing.append(key)
    if missing:
        raise InputFormatError(
            f"{path}: [Sequence] lacks required key(s) {', '.join(missing)}"
        )
    info["extra"] = items
    return info


def _ini_integer(path, key, raw, *, minimum) -> int:
    """A whole number in ASCII digits, at least ``minimum``."""
    value = raw.strip()
    if not re.fullmatch(r"[+-]?[0-9]+", value):
        raise InputFormatError(f"{path}: {key} is {raw!r}, expected an integer")
    number = int(value) if len(value) < 20 else _MAX_INT
    if not minimum <= number < _MAX_INT:
        raise InputFormatError(
            f"{path}: {key} is {value}, expected an integer from {minimum} to 2**53 - 1"
        )
    return number


def _ini_frame_rate(path, raw) -> float:
    """A positive, finite number of frames per second."""
    value = raw.strip()
    rate = float(value) if _NUMBER.fullmatch(value) else math.nan
    if not (math.isfinite(rate) and rate > 0):
        raise InputFormatError(
            f"{path}: frameRate is {raw!r}, expected a positive number of frames per "
            "second"
        )
    return rate


def _check_sizes(files, shape):
    """Check PNG frame sizes from their headers (cheap); others are checked on decode."""
    for f in files:
        if f.suffix.lower() == ".png":
            size = read_png_size(f)
            if size != shape:
                raise InputFormatError(
                    f"{f}: frame is {size[1]}x{size[0]} px, expected "
                    f"{shape[1]}x{shape[0]} px like the rest of its tour"
                )


def _numbered_files(folder, ext) -> dict:
    """The files ``<digits><ext>`` of a folder by number (``000004.png``, ``4.png``).

    Names that are not ASCII digits before ``ext``, and folders, are not frames; two
    files of one number are refused.
    """
    found = {}
    for p in sorted(folder.iterdir()):
        stem = p.name[: -len(ext)] if p.name.endswith(ext) else ""
        if not (stem.isascii() and stem.isdigit() and p.is_file()):
            continue
        k = int(stem)
        if k in found:
            raise InputFormatError(
                f"{folder}: {found[k].name} and {p.name} both hold frame {k}"
            )
        found[k] = p
    return found


def _image_dir(path, name) -> Path:
    """The frames' folder ``imDir``, which must lie inside the sequence folder."""
    if Path(name).is_absolute() or ".." in Path(name).parts:
        raise InputFormatError(
            f"{path / 'seqinfo.ini'}: imDir is {name!r}, expected a folder inside "
            f"{path} (such as img1)"
        )
    return path / name


def _sequence_files(path, image_dir, seq) -> list:
    """``img1/000001.png ...``: every frame of ``seqLength`` present, and no more."""
    if not image_dir.is_dir():
        raise FileNotFoundError(f"{image_dir}: image folder not found (imDir)")
    ext = seq["imExt"]
    present = _numbered_files(image_dir, ext)
    n = seq["seqLength"]
    files = []
    for i in range(1, n + 1):
        if i not in present:
            raise FileNotFoundError(
                f"{image_dir / f'{i:06d}{ext}'}: frame file not found (seqinfo.ini "
                f"says seqLength={n})"
            )
        files.append(present[i])
    beyond = sorted(k for k in present if k > n)
    if beyond:
        raise InputFormatError(
            f"{path / 'seqinfo.ini'}: seqLength is {n}, but {image_dir} holds "
            f"{len(beyond)} more frame(s), up to {present[beyond[-1]].name} "
            f"({len(present)} frame files in all); correct seqLength, or remove the "
            "extra frames"
        )
    return files


def read_tour(path) -> Tour:
    """Read a MOTChallenge sequence folder as a :class:`~tunnelsense.Tour`.

    Frames are not decoded here: each :class:`~tunnelsense.FrameRecord` decodes its
    image on access, so a tour of any length loads at once.  The PNG headers of all
    frames are checked against ``imWidth`` x ``imHeight``.  The frame files are
    ``imDir/<number><imExt>``, numbered 1 to ``seqLength`` (``000001.png`` as
    MOTChallenge writes them; ``1.png`` is read as frame 1 too).

    Parameters
    ----------
    path : str or Path
        The sequence folder (holding ``seqinfo.ini``).

    Returns
    -------
    tour : Tour
        Frames numbered from 1, ground truth from ``gt/gt.txt`` (empty when there is
        none), frame rate, and the other ``[Sequence]`` keys in ``tour.info``.

    Raises
    ------
    FileNotFoundError
        The folder, ``seqinfo.ini``, the image folder or a frame file is missing.
    InputFormatError
        ``seqinfo.ini`` is not UTF-8 text or lacks a required key, a number in it is
        malformed, ``imDir`` holds more frames than ``seqLength`` or two files of one
        frame number, a frame has another size, or ``gt.txt`` is malformed or names a
        frame outside 1..``seqLength`` (the message names the file, and the line).
    """
    path = Path(path)
    if not path.is_dir():
        raise FileNotFoundError(f"{path}: tour folder not found")
    seq = _read_seqinfo(path / "seqinfo.ini")
    shape = (seq["imHeight"], seq["imWidth"])
    files = _sequence_files(path, _image_dir(path, seq["imDir"]), seq)
    _check_sizes(files, shape)
    frames = FrameSequence(
        FrameRecord(seq["name"], i, ImageFile(f, shape)) for i, f in enumerate(files, 1)
    )
    gt_path = path / "gt" / "gt.txt"
    gt = read_mot_gt(gt_path) if gt_path.exists() else empty_mot_gt()
    if len(gt):
        bad = np.flatnonzero((gt["frame"] < 1) | (gt["frame"] > seq["seqLength"]))
        if bad.size:
            raise InputFormatError(
                f"{gt_path}, line {gt.attrs['lines'][bad[0]]}: frame "
                f"{gt['frame'].iloc[bad[0]]} is outside 1..{seq['seqLength']}"
            )
    return Tour(seq["name"], frames, gt, seq["frameRate"], dict(seq["extra"]))


def write_tour(tour: Tour, path, *, progress=None) -> Path:
    """Write a tour as a MOTChallenge sequence folder (PNG frames, lossless).

    Parameters
    ----------
    tour : Tour
        Its frames must be numbered 1..n in order.
    path : str or Path
        The folder to write (created; existing files of the same names are replaced).
    progress : callable or None, default=None
        Called as ``progress(n_done, n_total)`` after each frame.

    Returns
    -------
    path : Path
    """
    path = Path(path)
    numbers = [r.frame for r in tour.frames]
    if numbers != list(range(1, len(numbers) + 1)):
        raise InputFormatError(
            "tour.frames must be numbered 1..n in order to be written as a "
            "MOTChallenge sequence"
        )
    height, width = tour.image_shape
    image_dir = path / "img1"
    image_dir.mkdir(parents=True, exist_ok=True)
    for i, record in enumerate(tour.frames, 1):
        image = record.image
        if image.shape != (height, width):
            raise InputFormatError(
                f"frame {record.frame} of tour {tour.name!r} is {image.shape[1]}x"
                f"{image.shape[0]} px, expected {width}x{height} px"
            )
        target = image_dir / f"{i:06d}.png"
        if not cv2.imwrite(str(target), image):
            raise OSError(f"{target}: OpenCV could not write the frame")
        if progress is not None:
            progress(i, len(tour.frames))
    for stale in image_dir.glob("*.png"):  # frames of an earlier, longer tour
        if stale.stem.isascii() and stale.stem.isdigit() and (
            int(stale.stem) > len(tour.frames)
        ):
            stale.unlink()
    parser = configparser.ConfigParser(interpolation=None)
    parser.optionxform = str
    section = {
        "name": tour.name,
        "imDir": "img1",
        "frameRate": f"{tour.frame_rate:g}",
        "seqLength": str(len(tour.frames)),
        "imWidth": str(width),
        "imHeight": str(height),
        "imExt": ".png",
    }
    for key, value in tour.info.items():
        if key not in section:
            section[str(key)] = str(value)
    parser["Sequence"] = section
    with open(path / "seqinfo.ini", "w", encoding="utf-8") as f:
        parser.write(f)
    write_mot_gt(tour.gt, path / "gt" / "gt.txt")
    if getattr(tour, "kinematics", None) is not None:  # simulated: positions, odometry
        tour.kinematics.write(path)
    return path


# --------------------------------------------------------------------------------------
# Image folders and videos
# --------------------------------------------------------------------------------------
def _natural_key(path):
    """``frame_2`` before ``frame_10``: runs of ASCII digits compare as numbers."""
    parts = re.split(r"([0-9]+)", path.name)  # odd items are the digit runs
    return [int(t) if i % 2 else t for i, t in enumerate(parts)]


def read_image_folder(path, *, frame_rate=30.0) -> Tour:
    """Read a plain folder of image files as a tour without ground truth.

    Files are ordered by name with runs of digits compared as numbers (``f_2.png``
    before ``f_10.png``); hidden files are skipped.  When every name ends in a number
    (ASCII digits before the extension), that number is the frame's: a missing file
    leaves a gap in the frame numbers, which the trajectory linker respects (it ends
    the tracks there); a folder numbered from 0 is shifted to start at 1; two files
    of one number (``1.png`` and ``001.png``) are refused.  When not every name ends
    in a number, the frames are numbered 1..n in that order.

    Parameters
    ----------
    path : str or Path
        A folder of frames (PNG, TIFF, JPEG, BMP, PGM; 8-bit or 16-bit).
    frame_rate : float, default=30.0
        Frames per second (a folder does not say).

    Returns
    -------
    tour : Tour
        Named after the folder; frames numbered from 1, decoded on access.

    Raises
    ------
    FileNotFoundError
        There is no such folder.
    InputFormatError
        The folder holds no image file, two files of one frame number, a frame number
        of ``2**53`` or more, or a PNG frame of another size than the first.
    """
    path = Path(path)
    if not path.is_dir():
        raise FileNotFoundError(f"{path}: image folder not found")
    files = sorted(
        (
            p
            for p in path.iterdir()
            if p.suffix.lower() in IMAGE_EXTENSIONS
            and not p.name.startswith(".")
            and p.is_file()
        ),
        key=_natural_key,
    )
    if not files:
        raise InputFormatError(
            f"{path}: no image files (expected files ending in {', '.join(IMAGE_EXTENSIONS)})"
        )
    first = files[0]
    shape = (
        read_png_size(first)
        if first.suffix.lower() == ".png"
        else read_image(first).shape
    )
    _check_sizes(files, shape)
    name = path.resolve().name
    numbers = _frame_numbers(path, files)
    frames = FrameSequence(
        FrameRecord(name, k, ImageFile(f, shape))
        for k, f in sorted(zip(numbers, files, strict=True), key=lambda kf: kf[0])
    )
    return Tour(name, frames, empty_mot_gt(), float(frame_rate), {"source": str(path)})


def _frame_numbers(folder, files) -> list[int]:
    """Frame numbers from the files' names: the ASCII digits each name ends with.

    A missing file leaves a gap (the trajectory linker sees it); a folder numbered
    from 0 is shifted to start at 1.  Names that do not all end in a number are
    numbered 1..n in order.
    """
    found = [re.search(r"([0-9]+)$", f.stem) for f in files]
    if not all(found):
        return list(range(1, len(files) + 1))
    numbers = [int(m.group(1)) for m in found]
    seen = {}
    for f, k in zip(files, numbers, strict=True):
        if k >= _MAX_INT - 1:
            raise InputFormatError(
                f"{f}: frame number out of range (expected a number below 2**53 - 1)"
            )
        if k in seen:
            raise InputFormatError(
                f"{folder}: {seen[k].name} and {f.name} both hold frame {k}"
            )
        seen[k] = f
    shift = 1 if min(numbers) == 0 else 0
    return [k + shift for k in numbers]


def read_video(path, *, check_length=True) -> Tour:
    """Read a video file (through OpenCV) as a tour without ground truth.

    The frames are counted here (without decoding them) and decoded on access, a
    seek per frame; for a pass over the whole video, :func:`iter_video` decodes
    sequentially and is much faster.  Colour video is converted to grey.

    Parameters
    ----------
    path : str or Path
        A video file OpenCV can open.
    check_length : bool, default=True
        Whether to refuse a video that ends before the number of frames its header
        states (a truncated or damaged file).  A shortfall of up to 1 % of that
        number (at least one frame) is tolerated, since some containers only
        estimate it; pass ``False`` to read the frames there are.

    Returns
    -------
    tour : Tour
        Named after the file; frames numbered from 1; the frame rate the file states
        (30 when it states none).

    Raises
    ------
    InputFormatError
        OpenCV cannot open the file, it holds no frame, or (with ``check_length``) it
        ends before the frame count in its header.
    """
    path = Path(path)
    capture = open_video(path)
    try:
        fps = capture.get(cv2.CAP_PROP_FPS)
        stated = stated_frame_count(capture)
        n = 0
        while capture.grab():
            n += 1
    finally:
        capture.release()
    if n == 0:
        raise InputFormatError(f"{path}: the video holds no frames OpenCV can decode")
    error = video_length_error(path, n, stated)
    if check_length and error is not None:
        raise error
    name = path.stem
    frames = FrameSequence(
        FrameRecord(name, i + 1, VideoFrame(path, i)) for i in range(n)
    )
    rate = float(fps) if math.isfinite(fps) and fps > 0 else 30.0
    return Tour(name, frames, empty_mot_gt(), rate, {"source": str(path)})


def open_tour(source) -> Tour:
    """Read a tour from a MOTChallenge folder, an image folder or a video file.

    Parameters
    ----------
    source : str or Path
        A folder with ``seqinfo.ini`` (:func:`read_tour`), another folder
        (:func:`read_image_folder`) or a file (:func:`read_video`).

    Returns
    -------
    tour : Tour

    Raises
    ------
    FileNotFoundError
        ``source`` does not exist, or a file the tour needs is missing.
    InputFormatError
        ``source`` is a single file that is not a video, or it does not hold what
        its reader expects (a truncated video included; see :func:`read_video`).
    """
    source = Path(source)
    if source.is_dir():
        if (source / "seqinfo.ini").exists():
            return read_tour(source)
        return read_image_folder(source)
    if source.is_file():
        if source.suffix.lower() in IMAGE_EXTENSIONS + (".txt", ".csv", ".json", ".ini"):
            raise InputFormatError(
                f"{source}: a single file of this kind is not a tour (expected a "
                "MOTChallenge folder, an image folder or a video file)"
            )
        return read_video(source)
    raise FileNotFoundError(
        f"{source}: not found (expected a MOTChallenge folder, an image folder or a "
        "video file)"
    )
