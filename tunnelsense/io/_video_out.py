"""Pictures written as one video file through OpenCV (``detect tunnel --draw-video``).

A video of a tour is a few MB where its frames as PNG files are hundreds.  Frames go
to a temporary file beside the target, renamed to it when the writer is closed, also
when the run stops early: the video then holds the frames drawn so far.
"""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np

from tunnelsense.io._images import open_video
from tunnelsense.io._sources import open_tour

__all__ = ["VIDEO_CODECS", "VideoOutput", "check_video_path", "source_frame_rate"]

#: File suffix -> the FourCC OpenCV encodes it with (both in OpenCV's FFmpeg builds).
VIDEO_CODECS = {".mp4": "mp4v", ".avi": "MJPG"}


def check_video_path(path, what="--draw-video") -> Path:
    """Refuse a video file name whose suffix OpenCV is not asked to encode."""
    path = Path(path)
    if path.suffix.lower() not in VIDEO_CODECS:
        raise ValueError(f"{what} {path}: expected a {' or '.join(VIDEO_CODECS)} file")
    return path


def source_frame_rate(source) -> float:
    """Frames per second of a tour folder (``seqinfo.ini``; 30 for an image folder)
    or a video file (its header)."""
    source = Path(source)
    if not source.is_file():
        return float(open_tour(source).frame_rate)
    capture = open_video(source)
    try:
        return float(capture.get(cv2.CAP_PROP_FPS) or 0.0)
    finally:
        capture.release()


class VideoOutput:
    """Write BGR pictures of one size as a video; a context manager.

    Parameters
    ----------
    path : str or Path
        A ``.mp4`` (MPEG-4 part 2) or ``.avi`` (Motion JPEG) file; checked for
        overwriting by the caller.
    fps : float
        Frames per second of the video.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import cv2, numpy as np
    >>> from tunnelsense.io._video_out import VideoOutput
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "v.mp4"
    >>> with VideoOutput(path, fps=30) as video:
    ...     for k in range(5):
    ...         video.write(np.full((48, 64, 3), 40 * k, np.uint8))
    >>> int(cv2.VideoCapture(str(path)).get(cv2.CAP_PROP_FRAME_COUNT))
    5
    """

    def __init__(self, path, *, fps):
        self.path = check_video_path(path)
        self.fps = float(fps) if fps and np.isfinite(fps) and fps > 0 else 30.0
        self._tmp = self.path.with_name(f".{self.path.name}.partial{self.path.suffix}")
        self._writer = None
        self._size = None
        self.frames = 0

    def write(self, picture) -> None:
        """Append a picture (``(h, w, 3)`` uint8 BGR, or gray ``(h, w)``)."""
        picture = np.asarray(picture)
        if picture.ndim == 2:
            picture = cv2.cvtColor(picture, cv2.COLOR_GRAY2BGR)
        size = (picture.shape[1], picture.shape[0])
        if self._writer is None:
            fourcc = cv2.VideoWriter_fourcc(*VIDEO_CODECS[self.path.suffix.lower()])
            self._writer = cv2.VideoWriter(str(self._tmp), fourcc, self.fps, size)
            if not self._writer.isOpened():
                self._writer = None
                self._tmp.unlink(missing_ok=True)
                raise OSError(f"{self.path}: OpenCV cannot write this video (codec "
                              f"{VIDEO_CODECS[self.path.suffix.lower()]})")
            self._size = size
        elif size != self._size:
            raise ValueError(f"{self.path}: picture {self.frames + 1} is {size[0]}x"
                             f"{size[1]} px, the video {self._size[0]}x{self._size[1]}")
        self._writer.write(np.ascontiguousarray(picture, dtype=np.uint8))
        self.frames += 1

    def close(self) -> None:
        """Finish the video and give it its name (nothing is written without frames)."""
        if self._writer is None:
            return
        self._writer.release()
        self._writer = None
        os.replace(self._tmp, self.path)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
