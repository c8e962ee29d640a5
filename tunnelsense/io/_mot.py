"""Far-infrared tours on disk: MOTChallenge sequence folders, image folders, videos.

A MOTChallenge sequence folder holds::

    seqinfo.ini        [Sequence] name, imDir, frameRate, seqLength, imWidth, imHeight, imExt
    img1/000001.png    one image per frame (8-bit or 16-bit), numbered from 1
    gt/gt.txt          frame,id,bb_left,bb_top,bb_width,bb_height,conf,class,visibility

Ground-truth tables are read and written by :mod:`tunnelsense.io._tables`, results
files by :mod:`tunnelsense.io._results`, image folders and videos by
:mod:`tunnelsense.io._sources`.
"""

from __future__ import annotations

import configparser
import math
import re
from pathlib import Path

import cv2
import numpy as np

from tunnelsense._records import (
    FrameRecord,
    FrameSequence,
    ImageFile,
    Tour,
    empty_mot_gt,
)
from tunnelsense.exceptions import InputFormatError
from tunnelsense.io._images import read_png_size
from tunnelsense.io._tables import (  # LineNumbers: for io/_laser.py
    _MAX_INT,
    _NUMBER,
    LineNumbers,  # noqa: F401
    _read_text,
    read_mot_gt,
    write_mot_gt,
)

__all__ = ["read_tour", "write_tour"]

_SEQINFO_KEYS = (
    "name",
    "imDir",
    "frameRate",
    "seqLength",
    "imWidth",
    "imHeight",
    "imExt",
)

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


def _sequence_files(path, image_dir, seq, missing="raise") -> list:
    """``img1/000001.png ...``: ``(number, file)`` of every frame of ``seqLength``
    present (``missing="gap"``: of those present), and no more."""
    if not image_dir.is_dir():
        raise FileNotFoundError(f"{image_dir}: image folder not found (imDir)")
    ext = seq["imExt"]
    present = _numbered_files(image_dir, ext)
    n = seq["seqLength"]
    files = []
    for i in range(1, n + 1):
        if i not in present:
            if missing == "gap":
                continue
            raise FileNotFoundError(
                f"{image_dir / f'{i:06d}{ext}'}: frame file not found (seqinfo.ini "
                f"says seqLength={n}; missing_frames='gap', on the command line "
                "--missing-frames gap, reads the frames a recorder kept, with gaps in "
                "their numbers)"
            )
        files.append((i, present[i]))
    if not files:
        raise FileNotFoundError(f"{image_dir}: no frame file numbered 1..{n}")
    beyond = sorted(k for k in present if k > n)
    if beyond:
        raise InputFormatError(
            f"{path / 'seqinfo.ini'}: seqLength is {n}, but {image_dir} holds "
            f"{len(beyond)} more frame(s), up to {present[beyond[-1]].name} "
            f"({len(present)} frame files in all); correct seqLength, or remove the "
            "extra frames"
        )
    return files


def read_tour(path, *, colour=None, ground_truth=True, missing_frames="raise") -> Tour:
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
    colour : int, "luminance" or None, default=None
        How colour frames become grey: refused (None), one channel, or luminance
        (see :func:`~tunnelsense.io.read_image`).
    ground_truth : bool, default=True
        Read and check ``gt/gt.txt``.  False (detection, which never uses it): the
        tour's ``gt`` is None, and the file is not read.
    missing_frames : {"raise", "gap"}, default="raise"
        What a number in 1..``seqLength`` without its frame file means: an
        incomplete copy (an error), or, with ``"gap"``, a frame the recorder lost
        while the camera's frame counter ran on: the tour holds the frames present,
        each keeping its file's number, so the stages that follow trajectories in
        time (the linker's prediction, the motion check's fit in time) see the
        time between two frames as their difference in numbers over the frame
        rate.

    Returns
    -------
    tour : Tour
        Frames numbered from 1 (with gaps where frame files are missing and
        ``missing_frames="gap"``), ground truth from ``gt/gt.txt`` (empty when there is
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
    if missing_frames not in ("raise", "gap"):
        raise ValueError(
            f"missing_frames must be 'raise' or 'gap'; got {missing_frames!r}"
        )
    files = _sequence_files(path, _image_dir(path, seq["imDir"]), seq, missing_frames)
    _check_sizes([f for _, f in files], shape)
    frames = FrameSequence(
        FrameRecord(seq["name"], i, ImageFile(f, shape, colour)) for i, f in files
    )
    gt_path = path / "gt" / "gt.txt"
    if not ground_truth:
        return Tour(seq["name"], frames, None, seq["frameRate"], dict(seq["extra"]))
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
        Its frames must be numbered in increasing order from 1 or later; a gap in
        the numbers (frames a recorder lost) stays a gap: each frame is written
        as the file of its number, and ``seqLength`` is the last number
        (:func:`read_tour` with ``missing_frames="gap"`` reads it back).
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
    if not numbers or numbers[0] < 1 or any(
        b <= a for a, b in zip(numbers, numbers[1:], strict=False)
    ):
        raise InputFormatError(
            "tour.frames must be numbered in increasing order from 1 or later to be "
            "written as a MOTChallenge sequence"
        )
    height, width = tour.image_shape
    image_dir = path / "img1"
    image_dir.mkdir(parents=True, exist_ok=True)
    for i, record in enumerate(tour.frames, 1):
        number = record.frame
        image = record.image
        if image.shape != (height, width):
            raise InputFormatError(
                f"frame {record.frame} of tour {tour.name!r} is {image.shape[1]}x"
                f"{image.shape[0]} px, expected {width}x{height} px"
            )
        target = image_dir / f"{number:06d}.png"
        if not cv2.imwrite(str(target), image):
            raise OSError(f"{target}: OpenCV could not write the frame")
        if progress is not None:
            progress(i, len(tour.frames))
    written = set(numbers)
    for stale in image_dir.glob("*.png"):  # frames of an earlier tour
        if stale.stem.isascii() and stale.stem.isdigit() and (
            int(stale.stem) not in written
        ):
            stale.unlink()
    parser = configparser.ConfigParser(interpolation=None)
    parser.optionxform = str
    section = {
        "name": tour.name,
        "imDir": "img1",
        "frameRate": f"{tour.frame_rate:g}",
        "seqLength": str(numbers[-1]),
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
