"""Frames that are not a MOTChallenge folder: image folders and video files.

:func:`open_tour` reads any frame source: a MOTChallenge sequence folder, a plain
image folder or a video file.
"""

from __future__ import annotations

import math
import re
from collections import deque
from collections.abc import Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import cv2

from tunnelsense._records import (
    FrameRecord,
    FrameSequence,
    ImageFile,
    Tour,
    VideoFrame,
    decode_once,
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
from tunnelsense.io._mot import _check_sizes, read_tour
from tunnelsense.io._tables import _MAX_INT

__all__ = ["decode_ahead", "decode_tours", "open_tour", "read_image_folder", "read_video"]


def _natural_key(path):
    """``frame_2`` before ``frame_10``: runs of ASCII digits compare as numbers."""
    parts = re.split(r"([0-9]+)", path.name)  # odd items are the digit runs
    return [int(t) if i % 2 else t for i, t in enumerate(parts)]


def read_image_folder(path, *, frame_rate=30.0, colour=None) -> Tour:
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
        else read_image(first, colour=colour if colour is not None else "luminance").shape
    )
    _check_sizes(files, shape)
    name = path.resolve().name
    numbers = _frame_numbers(path, files)
    frames = FrameSequence(
        FrameRecord(name, k, ImageFile(f, shape, colour))
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


def read_video(path, *, check_length=True, colour=None) -> Tour:
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
        FrameRecord(name, i + 1, VideoFrame(path, i, colour)) for i in range(n)
    )
    rate = float(fps) if math.isfinite(fps) and fps > 0 else 30.0
    return Tour(name, frames, empty_mot_gt(), rate, {"source": str(path)})


def open_tour(source, *, colour=None, ground_truth=True, missing_frames="raise") -> Tour:
    """Read a tour from a MOTChallenge folder, an image folder or a video file.

    Parameters
    ----------
    source : str or Path
        A folder with ``seqinfo.ini`` (:func:`read_tour`), another folder
        (:func:`read_image_folder`) or a file (:func:`read_video`).
    colour : int, "luminance" or None, default=None
        How colour frames become grey: refused (None), one channel, or luminance
        (see :func:`~tunnelsense.io.read_image`).
    ground_truth : bool, default=True
        Read a MOTChallenge folder's ``gt/gt.txt`` (see :func:`read_tour`); False:
        its ``gt`` is None.
    missing_frames : {"raise", "gap"}, default="raise"
        A MOTChallenge folder's frame files missing from ``1..seqLength``: refused,
        or read as gaps in time (see :func:`read_tour`).  An image folder always
        reads its files' numbers as time.

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
            return read_tour(source, colour=colour, ground_truth=ground_truth,
                             missing_frames=missing_frames)
        return read_image_folder(source, colour=colour)
    if source.is_file():
        if source.suffix.lower() in IMAGE_EXTENSIONS + (".txt", ".csv", ".json", ".ini"):
            raise InputFormatError(
                f"{source}: a single file of this kind is not a tour (expected a "
                "MOTChallenge folder, an image folder or a video file)"
            )
        return read_video(source, colour=colour)
    raise FileNotFoundError(
        f"{source}: not found (expected a MOTChallenge folder, an image folder or a "
        "video file)"
    )


def decode_ahead(records: Iterable, *, n_threads=1, ahead=8, then=None) -> Iterator:
    """Yield the records with their images decoded, decoding ahead in threads.

    OpenCV and NumPy release the interpreter lock while they decode and compute, so
    reader threads decode the next frames (and, with ``then``, run the first work
    on them) while the detector works on this one.  Records come out in input
    order, each with a :class:`~tunnelsense.DecodedImage` source (in-memory images
    pass unchanged); at most ``ahead`` frames wait, so memory stays bounded.  An
    error of a frame (its file unreadable, say) is raised when that frame's turn
    comes, after every frame before it.

    Parameters
    ----------
    records : iterable of FrameRecord
    n_threads : int, default=1
        Reader threads; 0 decodes in the calling thread, as the records are taken.
    ahead : int, default=8
        Frames decoded ahead at most.
    then : callable or None, default=None
        ``then(record)`` of each decoded record, in the reader thread; what it
        returns is yielded instead of the record.  It must not depend on the order
        in which frames are taken.

    Yields
    ------
    record : FrameRecord
        Or what ``then`` returns.
    """
    work = decode_once if then is None else (lambda r: then(decode_once(r)))
    if n_threads < 1:
        for record in records:
            yield work(record)
        return
    with ThreadPoolExecutor(max_workers=n_threads,
                            thread_name_prefix="decode") as pool:
        pending = deque()
        for record in records:
            pending.append(pool.submit(work, record))
            if len(pending) >= ahead:
                yield pending.popleft().result()
        while pending:
            yield pending.popleft().result()


def decode_tours(tours, *, n_threads=1, sample_rate=None):
    """Start decoding every frame of labelled tours in reader threads, at once.

    The training command calls it before it imports the fitting machinery
    (scikit-learn, about a second), so that the import runs while the reader threads
    decode.  Returns ``(frames, y, groups, n_frames)``: ``frames`` yields the decoded
    records in order (see :func:`decode_ahead`); ``y`` and ``groups`` are those of
    :func:`~tunnelsense.to_xy`.  With ``sample_rate`` (frames per second), only the
    frames :func:`~tunnelsense._records._sampling.sample_in_time` keeps are decoded
    and given (renumbered as a recording at that rate).

    Examples
    --------
    >>> from tunnelsense.datasets import make_tunnel_tour
    >>> from tunnelsense.io._sources import decode_tours
    >>> frames, y, groups, n = decode_tours([make_tunnel_tour(5, random_state=0)])
    >>> n, len(list(frames))
    (5, 5)
    """
    from tunnelsense._records import to_xy  # noqa: PLC0415
    from tunnelsense._records._sampling import sample_in_time  # noqa: PLC0415

    X, y, groups = sample_in_time(*to_xy(tours), sample_rate)
    frames = decode_ahead(X, n_threads=max(int(n_threads), 1), ahead=max(len(X), 1))
    first = next(frames, None)  # every frame is queued now: the reader threads start

    def ordered():
        if first is not None:
            yield first
            yield from frames

    return ordered(), y, groups, len(X)
