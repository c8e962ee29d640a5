"""Frame records: one far-infrared frame, its lazy image source, its payload."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = [
    "MOT_GT_COLUMNS",
    "OBJECT_CLASSES",
    "DecodedImage",
    "FrameRecord",
    "ImageFile",
    "VideoFrame",
    "decode_once",
    "release_image",
]

#: Column names of a MOTChallenge ground-truth file (``gt/gt.txt``).
MOT_GT_COLUMNS = (
    "frame",
    "id",
    "bb_left",
    "bb_top",
    "bb_width",
    "bb_height",
    "conf",
    "class",
    "visibility",
)

#: Class ids of the ground truth of FIR tours.
OBJECT_CLASSES = {1: "indicator", 2: "lamp", 3: "vehicle", 4: "shadow"}


# --------------------------------------------------------------------------------------
# Lazy image sources
# --------------------------------------------------------------------------------------
class ImageFile:
    """A frame stored as an image file, decoded with OpenCV on every access.

    Parameters
    ----------
    path : str or Path
        The image file (PNG, TIFF, ...).
    shape : tuple of int or None, default=None
        The ``(height, width)`` the tour declares; a decoded frame of another size
        raises ``ValueError`` naming the file.
    colour : int, "luminance" or None, default=None
        How a colour frame becomes grey (:func:`tunnelsense.io.read_image`).
    """

    __slots__ = ("colour", "path", "shape")

    def __init__(self, path, shape=None, colour=None):
        self.path = str(path)
        self.shape = None if shape is None else tuple(int(s) for s in shape)
        self.colour = colour

    def __getstate__(self):
        return (self.path, self.shape, self.colour)

    def __setstate__(self, state):
        self.path, self.shape, self.colour = (*state, None)[:3]

    def __repr__(self):
        return f"ImageFile({self.path!r})"

    def load(self) -> np.ndarray:
        from tunnelsense.io._images import read_image  # io imports this module

        image = read_image(self.path, colour=self.colour)
        if self.shape is not None and image.shape != self.shape:
            raise ValueError(
                f"{self.path}: frame is {image.shape[1]}x{image.shape[0]} px, "
                f"expected {self.shape[1]}x{self.shape[0]} px like the rest of its tour"
            )
        return image


class VideoFrame:
    """A frame of a video file, decoded with OpenCV on access (seek, then read)."""

    __slots__ = ("colour", "index", "path")

    def __init__(self, path, index, colour=None):
        self.path = str(path)
        self.index = int(index)
        self.colour = colour

    def __getstate__(self):
        return (self.path, self.index, self.colour)

    def __setstate__(self, state):
        self.path, self.index, self.colour = (*state, None)[:3]

    def __repr__(self):
        return f"VideoFrame({self.path!r}, {self.index})"

    def load(self) -> np.ndarray:
        from tunnelsense.io._images import read_video_frame  # io imports this module

        return read_video_frame(self.path, self.index, colour=self.colour)


def _origin(source):
    return source


def _remade(origin, remake):
    return DecodedImage(origin, None, remake)


class DecodedImage:
    """A lazy image source decoded once, for the length of one pipeline pass.

    The first stage that reads a frame (:class:`~tunnelsense.IntensityKeypointSampler`)
    wraps the frame's lazy source (an :class:`ImageFile`, a :class:`VideoFrame`) in
    one, with the decoded array; the later stages of the same pass read that array
    instead of decoding the file again.  A stage that holds frames for later (the
    online trajectory verifier) keeps :attr:`origin` instead, so memory does not grow
    with the frames held.  No pixels travel to other processes: it pickles (and
    copies) as its origin, or, when its array was made from the origin's pixels
    (``remake``, such as the detector's canonical frame), as the origin and
    ``remake``, which makes the same array again on first access.

    Parameters
    ----------
    origin : lazy source
        The object with a ``load()`` method the array was decoded from.
    array : ndarray or None
        The decoded image; None: ``remake(origin.load())`` on first access.
    remake : callable or None, default=None
        ``remake(pixels) -> array`` when the array is not the origin's pixels
        themselves (picklable, deterministic); None: the array is ``origin.load()``.

    Examples
    --------
    >>> import copy
    >>> from functools import partial
    >>> import numpy as np
    >>> from tunnelsense import DecodedImage
    >>> class Pixels:  # a lazy source: anything with load()
    ...     def load(self):
    ...         return np.array([[10, 20]], np.uint8)
    >>> double = partial(np.multiply, 2)
    >>> src = DecodedImage(Pixels(), double(Pixels().load()), remake=double)
    >>> copy.deepcopy(src).load()  # made again from the origin's pixels
    array([[20, 40]], dtype=uint8)
    """

    __slots__ = ("origin", "_array", "remake")

    def __init__(self, origin, array, remake=None):
        if array is None and remake is None:
            raise ValueError("DecodedImage needs its array or a remake of it")
        self.origin = origin
        self._array = array
        self.remake = remake

    @property
    def array(self) -> np.ndarray:
        """The decoded (or remade) image."""
        if self._array is None:
            self._array = self.remake(self.origin.load())
        return self._array

    def load(self) -> np.ndarray:
        return self.array

    def __reduce__(self):
        if self.remake is None:
            return (_origin, (self.origin,))
        return (_remade, (self.origin, self.remake))

    def __repr__(self):
        return f"DecodedImage({self.origin!r})"


def decode_once(record):
    """The record with its image decoded: a lazy source becomes a :class:`DecodedImage`.

    A record whose image is in memory (an array, or already decoded) is returned as
    it is.
    """
    source = record.source
    if isinstance(source, np.ndarray | DecodedImage):
        return record
    return FrameRecord(
        record.tour, record.frame, DecodedImage(source, source.load()), record.payload
    )


def release_image(source):
    """What a stage holding a frame for later keeps of its image source.

    An in-memory array is dropped (``None``); a decoded lazy source gives back its
    origin, which can decode the image again; a lazy source is kept.
    """
    if isinstance(source, np.ndarray):
        return None
    if isinstance(source, DecodedImage):
        return source.origin
    return source


# --------------------------------------------------------------------------------------
# Records
# --------------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True, eq=False)
class FrameRecord:
    """One frame of far-infrared video: its identity and a payload.

    Stages never change a record; they return a new one with the same identity
    (:meth:`evolve`).

    Parameters
    ----------
    tour : str
        Name of the tour (MOTChallenge sequence) the frame belongs to.
    frame : int
        1-based frame number within the tour.
    source : ndarray or lazy source
        The image as a 2-D ``uint8`` or ``uint16`` array, or an object with a
        ``load()`` method returning it (:class:`ImageFile`, :class:`VideoFrame`), so
        that a tour of 100,000 frames need not sit in memory.
    payload : dict, default={}
        What the stages computed so far, by name (for example ``"keypoints"``).

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import FrameRecord
    >>> r = FrameRecord("tour-a", 1, np.zeros((4, 6), np.uint8))
    >>> r.image.shape
    (4, 6)
    >>> r.evolve(keypoints=np.empty((0, 3))).payload["keypoints"].shape
    (0, 3)
    """

    tour: str
    frame: int
    source: Any
    payload: dict = field(default_factory=dict)

    @property
    def image(self) -> np.ndarray:
        """The frame's image (decoded from disk when the source is lazy)."""
        source = self.source
        return source if isinstance(source, np.ndarray) else source.load()

    @property
    def key(self) -> tuple[str, int]:
        """The record's identity ``(tour, frame)``."""
        return (self.tour, self.frame)

    def evolve(self, **payload) -> FrameRecord:
        """Return a record with the same identity and image, payload updated."""
        return FrameRecord(
            self.tour, self.frame, self.source, {**self.payload, **payload}
        )

    def __repr__(self):
        keys = ", ".join(self.payload) or "-"
        return f"FrameRecord(tour={self.tour!r}, frame={self.frame}, payload=[{keys}])"
