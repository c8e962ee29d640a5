"""Decoding frames with OpenCV: image files (8- and 16-bit) and video files."""

from __future__ import annotations

import math
import struct
from pathlib import Path

import cv2
import numpy as np

from tunnelsense.exceptions import InputFormatError

__all__ = [
    "IMAGE_EXTENSIONS",
    "check_colour",
    "iter_video",
    "open_video",
    "read_image",
    "read_png_size",
    "read_video_frame",
    "stated_frame_count",
    "video_length_error",
]

#: File endings read as image frames (case-insensitive).
IMAGE_EXTENSIONS = (".png", ".tif", ".tiff", ".jpg", ".jpeg", ".bmp", ".pgm", ".pnm")

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


#: How far the channels of a grey frame stored in colour may differ (video codecs
#: round their colour conversion).
_GREY_TOLERANCE = 2


def check_colour(colour):
    """A colour conversion: None (refuse colour frames), ``"luminance"`` or a channel.

    Examples
    --------
    >>> check_colour(2), check_colour("luminance"), check_colour(None)
    (2, 'luminance', None)
    """
    if colour is None or colour == "luminance":
        return colour
    if isinstance(colour, int | np.integer) and not isinstance(colour, bool) and colour >= 0:
        return int(colour)
    raise ValueError(f"colour must be None, 'luminance' or a channel index >= 0; got "
                     f"{colour!r}")


def _channel_spread(image: np.ndarray) -> int:
    """The largest difference between the colour channels of any pixel."""
    b, g, r = (np.ascontiguousarray(image[:, :, k]) for k in range(3))
    return max(int(cv2.absdiff(b, g).max()), int(cv2.absdiff(g, r).max()))


def _to_gray(image: np.ndarray, where: str, colour=None) -> np.ndarray:
    """Single-channel frame.

    A frame stored in colour whose channels agree (grey saved as RGB) is grey.  A
    frame whose channels differ is refused unless ``colour`` names the conversion:
    a far-infrared camera's false-colour palette is not luminance, so converting it
    silently would give the detector intensities it was not trained on.
    """
    if image.ndim == 3:
        n = image.shape[2]
        if n not in (1, 3, 4):
            raise InputFormatError(f"{where}: expected 1, 3 or 4 channels, got {n}")
        if n == 1:
            image = image[:, :, 0]
        elif isinstance(colour, int):
            if colour >= min(n, 3):
                raise InputFormatError(f"{where}: --channel {colour}, but the frame has "
                                       f"channels 0..{min(n, 3) - 1}")
            image = image[:, :, colour]
        else:
            if colour is None and _channel_spread(image) > _GREY_TOLERANCE:
                raise InputFormatError(
                    f"{where}: a colour frame (its channels differ): a far-infrared "
                    "false-colour palette is not luminance; name the conversion: "
                    "--channel N (0 blue, 1 green, 2 red, as OpenCV orders them) or "
                    "--palette-to-grey (luminance), or colour=N / 'luminance'"
                )
            image = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY if n == 3
                                 else cv2.COLOR_BGRA2GRAY)
    if image.dtype not in (np.uint8, np.uint16):
        raise InputFormatError(f"{where}: expected 8-bit or 16-bit pixels, got {image.dtype}")
    return np.ascontiguousarray(image)


def read_png_size(path) -> tuple[int, int]:
    """``(height, width)`` of a PNG from its header, without decoding it.

    Raises :class:`~tunnelsense.exceptions.InputFormatError` naming the file when it
    is not a PNG or is too short.
    """
    with open(path, "rb") as f:
        head = f.read(24)
    if len(head) < 24 or head[:8] != _PNG_SIGNATURE or head[12:16] != b"IHDR":
        raise InputFormatError(f"{path}: not a PNG file (bad signature or header)")
    width, height = struct.unpack(">II", head[16:24])
    return int(height), int(width)


def read_image(path, *, colour=None) -> np.ndarray:
    """Decode one frame: a 2-D ``uint8`` or ``uint16`` array.

    A colour image whose channels agree is grey; one whose channels differ is refused
    unless ``colour`` names the conversion (a channel index, or ``"luminance"``).  A missing file raises
    ``FileNotFoundError``; an empty, truncated or corrupt file, an image larger than
    OpenCV decodes, or pixels other than 8- or 16-bit raise
    :class:`~tunnelsense.exceptions.InputFormatError` naming the file.

    Parameters
    ----------
    path : str or Path
        An image file OpenCV can decode (PNG, TIFF, JPEG, BMP, PGM).

    Returns
    -------
    image : ndarray of shape (height, width), uint8 or uint16
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: frame file not found")
    data = np.fromfile(path, dtype=np.uint8)
    if data.size == 0:
        raise InputFormatError(f"{path}: empty file, expected an image")
    if data[:8].tobytes() == _PNG_SIGNATURE and data.tobytes().rfind(b"IEND") < 0:
        # libpng may hand back a partly decoded frame for a truncated file.
        raise InputFormatError(
            f"{path}: truncated PNG (no IEND chunk at the end of the file)"
        )
    try:
        image = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    except cv2.error as exc:  # e.g. a header stating more pixels than OpenCV allows
        raise InputFormatError(
            f"{path}: OpenCV refused the image ({_cv_reason(exc)}); expected an image "
            "of at most 2**20 pixels a side and 2**30 in all"
        ) from None
    if image is None:
        raise InputFormatError(f"{path}: corrupt image, OpenCV could not decode it")
    return _to_gray(image, str(path), check_colour(colour))


def _cv_reason(exc: cv2.error) -> str:
    """The short reason in an OpenCV error message (after ``error: (code:kind)``)."""
    text = str(exc).strip()
    return text.rsplit(") ", 1)[-1] if ") " in text else text


def open_video(path) -> cv2.VideoCapture:
    """Open a video file with OpenCV, raising a clear error when it cannot."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: video file not found")
    try:
        capture = cv2.VideoCapture(str(path))
    except cv2.error as exc:
        raise InputFormatError(
            f"{path}: OpenCV cannot open this file as a video ({_cv_reason(exc)})"
        ) from None
    if not capture.isOpened():
        raise InputFormatError(f"{path}: OpenCV cannot open this file as a video")
    return capture


def read_video_frame(path, index: int, *, colour=None) -> np.ndarray:
    """Decode frame ``index`` (0-based) of a video file as a 2-D array."""
    capture = open_video(path)
    try:
        if index and not capture.set(cv2.CAP_PROP_POS_FRAMES, index):
            raise InputFormatError(f"{path}: cannot seek to frame {index}")
        ok, image = capture.read()
    finally:
        capture.release()
    if not ok or image is None:
        raise InputFormatError(
            f"{path}: cannot decode frame {index} (the video ends earlier)"
        )
    return _to_gray(image, f"{path} frame {index}", check_colour(colour))


def stated_frame_count(capture: cv2.VideoCapture) -> int:
    """The number of frames the video's header states (0 when it does not say)."""
    value = capture.get(cv2.CAP_PROP_FRAME_COUNT)
    return int(value) if math.isfinite(value) and value > 0 else 0


def video_length_error(path, n_decoded: int, n_stated: int, hint: str = ""):
    """The error for a video that ends before its header's frame count, or None.

    OpenCV's frame count is exact for most files but only an estimate (duration times
    frame rate) for some containers, so a shortfall of up to 1 % of the stated count,
    and at least one frame, is tolerated.  A header that states no count (0) is not
    checked, nor is a video longer than its header says.

    Parameters
    ----------
    path : str or Path
        The video file, named in the message.
    n_decoded : int
        The frames OpenCV could read.
    n_stated : int
        The frames the header states (:func:`stated_frame_count`).
    hint : str, default=""
        Appended to the message.

    Returns
    -------
    error : InputFormatError or None
    """
    if n_stated <= 0 or n_decoded >= n_stated - max(1, n_stated // 100):
        return None
    return InputFormatError(
        f"{path}: the video ends after {n_decoded} frames, but its header states "
        f"{n_stated} (truncated or damaged file){hint}"
    )


def iter_video(path, *, check_length=True, colour=None):
    """Yield the frames of a video file one by one, decoding sequentially.

    Parameters
    ----------
    path : str or Path
        A video file OpenCV can open.
    check_length : bool, default=True
        Whether to raise, after the last decodable frame, when the video ends before
        the number of frames its header states (see :func:`video_length_error` for
        the tolerance).  Pass ``False`` for a container whose count is a poor
        estimate.
    colour : int, "luminance" or None, default=None
        How a colour frame becomes grey (see :func:`read_image`).

    Yields
    ------
    image : ndarray of shape (height, width)
        Grey frames, in order.

    Raises
    ------
    InputFormatError
        The video ends before the number of frames its header states; raised after
        the frames before were yielded.
    """
    colour = check_colour(colour)
    capture = open_video(path)
    try:
        stated = stated_frame_count(capture)
        n = 0
        while True:
            ok, image = capture.read()
            if not ok or image is None:
                break
            n += 1
            yield _to_gray(image, f"{path} frame {n - 1}", colour)
    finally:
        capture.release()
    error = video_length_error(path, n, stated, "; the frames before were processed")
    if check_length and error is not None:
        raise error
