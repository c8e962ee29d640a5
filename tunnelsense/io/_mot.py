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


def _parse_line_by_line(path, text, columns):
    """Slow path: find the first bad line and say what is wrong with it."""
    rows = []
    for lineno, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        fields = [f.strip() for f in line.split(",")]
        if len(fields) != len(columns):
            raise InputFormatError(
                f"{path}, line {lineno}: {len(fields)} columns, expected "
                f"{len(columns)} ({','.join(columns)})"
            )
        row = []
        for name, value in zip(columns, fields, strict=True):
            try:
                number = float(value)
            except ValueError:
                raise InputFormatError(
                    f"{path}, line {lineno}: column {name!r} is {value!r}, "
                    "expected a number"
                ) from None
            if name in _INT_COLUMNS and not number.is_integer():
                raise InputFormatError(
                    f"{path}, line {lineno}: column {name!r} is {value!r}, "
                    "expected an integer"
                )
            row.append(number)
        rows.append(row)
    return rows


def _read_table(path, columns) -> pd.DataFrame:
    """Parse a headerless MOT table; ``table.attrs["lines"]`` holds each row's line."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: file not found")
    text = path.read_text(encoding="utf-8", errors="replace")
    int_columns = [c for c in columns if c in _INT_COLUMNS]
    if not text.strip():
        table = pd.DataFrame({c: pd.Series(dtype=np.float64) for c in columns})
    else:
        try:  # fast path; any doubt goes to the line-by-line parser, which says where
            table = pd.read_csv(
                io.StringIO(text),
                header=None,
                names=list(columns),
                dtype=np.float64,
                skip_blank_lines=True,
                skipinitialspace=True,
            )
            ints = table[int_columns].to_numpy()
            ok = (
                not table.isna().to_numpy().any()
                and np.array_equal(ints, np.round(ints))
                and all(
                    line.count(",") == len(columns) - 1
                    for line in text.splitlines()
                    if line.strip()
                )
            )
        except (ValueError, pd.errors.ParserError):
            ok = False
        if not ok:
            rows = _parse_line_by_line(path, text, columns)
            table = pd.DataFrame(rows, columns=list(columns), dtype=np.float64)
    values = table.to_numpy()
    lines = [i for i, line in enumerate(text.splitlines(), 1) if line.strip()]
    bad = np.flatnonzero(~np.isfinite(values).all(axis=1))
    if bad.size:
        raise InputFormatError(
            f"{path}, line {lines[bad[0]]}: NaN or infinity, expected numbers"
        )
    ints = table[int_columns].to_numpy()
    bad = np.flatnonzero((np.abs(ints) >= 2**62).any(axis=1))
    if bad.size:
        raise InputFormatError(f"{path}, line {lines[bad[0]]}: integer column out of range")
    if "bb_width" in table:
        bad = np.flatnonzero(
            (table[["bb_width", "bb_height"]].to_numpy() < 0).any(axis=1)
        )
        if bad.size:
            raise InputFormatError(
                f"{path}, line {lines[bad[0]]}: negative box width or height"
            )
    for c in int_columns:
        table[c] = table[c].to_numpy().astype(np.int64)
    table.attrs["lines"] = LineNumbers(lines)
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

    Raises
    ------
    ValueError
        A line with another number of columns, or a field that is not a number (the
        message names the file and the line).
    """
    return _read_table(path, MOT_GT_COLUMNS)


def _write_table(frame: pd.DataFrame, path, columns):
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise ValueError(f"cannot write {path}: the table lacks columns {missing}")
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
    ValueError
        A line with another number of columns or a non-number (names file and line).
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
    if not path.is_file():
        raise FileNotFoundError(
            f"{path}: seqinfo.ini not found (not a MOTChallenge folder)"
        )
    parser = configparser.ConfigParser(interpolation=None)
    parser.optionxform = str
    try:
        parser.read(path, encoding="utf-8-sig")
    except (configparser.Error, UnicodeDecodeError) as exc:
        raise InputFormatError(f"{path}: not a valid ini file: {exc}") from None
    sections = [s for s in parser.sections() if s.lower() == "sequence"]
    if not sections:
        raise InputFormatError(f"{path}: no [Sequence] section")
    items = dict(parser.items(sections[0]))
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
    for key in ("seqLength", "imWidth", "imHeight"):
        try:
            info[key] = int(info[key])
        except ValueError:
            raise InputFormatError(
                f"{path}: {key} is {info[key]!r}, expected an integer"
            ) from None
        if info[key] < 0 or (key != "seqLength" and info[key] == 0):
            raise InputFormatError(
                f"{path}: {key} is {info[key]}, expected a positive integer"
            )
    raw = info["frameRate"]
    try:
        info["frameRate"] = float(raw)
    except ValueError:
        info["frameRate"] = math.nan
    if not (math.isfinite(info["frameRate"]) and info["frameRate"] > 0):
        raise InputFormatError(
            f"{path}: frameRate is {raw!r}, expected a positive number of frames per "
            "second"
        )
    if not info["imExt"].startswith("."):
        info["imExt"] = "." + info["imExt"]
    info["extra"] = items
    return info


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


def _sequence_files(path, image_dir, seq) -> list:
    """``img1/000001.png ...``: every frame of ``seqLength`` present, and no more."""
    if not image_dir.is_dir():
        raise FileNotFoundError(f"{image_dir}: image folder not found (imDir)")
    ext = seq["imExt"]
    present = {
        int(p.stem) for p in image_dir.iterdir()
        if p.suffix == ext and p.stem.isdigit() and len(p.stem) < 12 and p.is_file()
    }
    n = seq["seqLength"]
    files = []
    for i in range(1, n + 1):
        if i not in present:
            raise FileNotFoundError(
                f"{image_dir / f'{i:06d}{ext}'}: frame file not found (seqinfo.ini "
                f"says seqLength={n})"
            )
        files.append(image_dir / f"{i:06d}{ext}")
    beyond = sorted(k for k in present if k > n)
    if beyond:
        raise InputFormatError(
            f"{path / 'seqinfo.ini'}: seqLength is {n}, but {image_dir} holds "
            f"{len(beyond)} more frame(s), up to {beyond[-1]:06d}{ext}; correct "
            "seqLength, or remove the extra frames"
        )
    return files


def read_tour(path) -> Tour:
    """Read a MOTChallenge sequence folder as a :class:`~tunnelsense.Tour`.

    Frames are not decoded here: each :class:`~tunnelsense.FrameRecord` decodes its
    image on access, so a tour of any length loads at once.  The PNG headers of all
    frames are checked against ``imWidth`` x ``imHeight``.

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
        The folder, ``seqinfo.ini`` or a frame file is missing.
    ValueError
        ``seqinfo.ini`` lacks a required key, a frame has another size, or ``gt.txt``
        is malformed (the message names the file and line).
    """
    path = Path(path)
    if not path.is_dir():
        raise FileNotFoundError(f"{path}: tour folder not found")
    seq = _read_seqinfo(path / "seqinfo.ini")
    shape = (seq["imHeight"], seq["imWidth"])
    image_dir = path / seq["imDir"]
    files = _sequence_files(path, image_dir, seq)
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
        raise ValueError(
            "tour.frames must be numbered 1..n in order to be written as a "
            "MOTChallenge sequence"
        )
    height, width = tour.image_shape
    image_dir = path / "img1"
    image_dir.mkdir(parents=True, exist_ok=True)
    for i, record in enumerate(tour.frames, 1):
        image = record.image
        if image.shape != (height, width):
            raise ValueError(
                f"frame {record.frame} of tour {tour.name!r} is {image.shape[1]}x"
                f"{image.shape[0]} px, expected {width}x{height} px"
            )
        target = image_dir / f"{i:06d}.png"
        if not cv2.imwrite(str(target), image):
            raise OSError(f"{target}: OpenCV could not write the frame")
        if progress is not None:
            progress(i, len(tour.frames))
    for stale in image_dir.glob("*.png"):  # frames of an earlier, longer tour
        if stale.stem.isdigit() and int(stale.stem) > len(tour.frames):
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
    return path


# --------------------------------------------------------------------------------------
# Image folders and videos
# --------------------------------------------------------------------------------------
def _natural_key(path):
    """``frame_2`` before ``frame_10``: digit runs compare as numbers."""
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", path.name)]


def read_image_folder(path, *, frame_rate=30.0) -> Tour:
    """Read a plain folder of image files as a tour without ground truth.

    Files are ordered by name with digit runs compared as numbers (``f_2.png`` before
    ``f_10.png``); hidden files are skipped.  When every name ends in a number, that
    number is the frame's (a missing file leaves a gap in the frame numbers, which the
    trajectory linker respects; a folder numbered from 0 is shifted to start at 1;
    two files of one number are refused); otherwise frames are numbered 1..n.

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
    """Frame numbers from the files' names: the number each name ends with.

    A missing file leaves a gap (the trajectory linker sees it); a folder numbered
    from 0 is shifted to start at 1.  Names that do not all end in a number are
    numbered 1..n in order.
    """
    found = [re.search(r"(\d+)$", f.stem) for f in files]
    if not all(found):
        return list(range(1, len(files) + 1))
    numbers = [int(m.group(1)) for m in found]
    seen = {}
    for f, k in zip(files, numbers, strict=True):
        if k in seen:
            raise InputFormatError(
                f"{folder}: {seen[k].name} and {f.name} both hold frame {k}"
            )
        seen[k] = f
    shift = 1 if min(numbers) == 0 else 0
    return [k + shift for k in numbers]


def read_video(path) -> Tour:
    """Read a video file (through OpenCV) as a tour without ground truth.

    Frames are decoded on access (a seek per frame); for a pass over the whole video,
    :func:`iter_video` decodes sequentially and is much faster.  Colour video is
    converted to grey.

    Parameters
    ----------
    path : str or Path
        A video file OpenCV can open.

    Returns
    -------
    tour : Tour
        Named after the file; frames numbered from 1; the frame rate the file states.
    """
    path = Path(path)
    capture = open_video(path)
    try:
        fps = capture.get(cv2.CAP_PROP_FPS) or 30.0
        n = 0
        while capture.grab():
            n += 1
    finally:
        capture.release()
    if n == 0:
        raise InputFormatError(f"{path}: the video holds no frames OpenCV can decode")
    name = path.stem
    frames = FrameSequence(
        FrameRecord(name, i + 1, VideoFrame(path, i)) for i in range(n)
    )
    return Tour(name, frames, empty_mot_gt(), float(fps), {"source": str(path)})


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
