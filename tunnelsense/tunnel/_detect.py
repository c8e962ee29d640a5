"""Running the indicator detector over whole tours, as the command does.

:func:`detect_to_files` is ``detect tunnel``: frames streamed through the fitted pipeline
(:func:`stream_detect`), results and their ``.clusters.csv`` companion written as each
frame is final, an interrupted run resumed by replay.
"""

from __future__ import annotations

import contextlib
import itertools
from pathlib import Path

import cv2
import numpy as np

from tunnelsense._payload import FRAME_RATE
from tunnelsense._records import FrameRecord, FrameSequence, decode_once
from tunnelsense._streaming import StreamingPipeline
from tunnelsense.io._images import iter_video, open_video, read_video_frame
from tunnelsense.io._results import (
    CLUSTERS_HEADER,
    RESULT_LINE,
    cluster_lines,
    clusters_path,
    mot_result_lines,
)
from tunnelsense.io._sources import decode_ahead, open_tour
from tunnelsense.io._video_out import VideoOutput, source_frame_rate
from tunnelsense.io._writer import ResultsWriter
from tunnelsense.plotting._detections import draw_detections
from tunnelsense.tunnel._keypoints import check_served_depth
from tunnelsense.tunnel._kmeans import blas_threads

__all__ = [
    "detect_to_files",
    "detect_tour",
    "open_frames",
    "stream_detect",
]




def detect_tour(model, frames, *, progress=None, chunk=256):
    """Run a fitted indicator pipeline over frames, stages 1-4 in chunks.

    Parameters
    ----------
    model : Pipeline
        From :func:`~tunnelsense.tunnel.make_indicator_pipeline`, fitted.
    frames : FrameSequence
    progress : Progress or None, default=None
        Its ``update(done)`` is called after each chunk.
    chunk : int, default=256
        Frames per chunk of the first four stages (bounds their memory).

    Returns
    -------
    records : FrameSequence
        The output of ``model.predict(frames)``.

    Examples
    --------
    >>> from tunnelsense import to_xy
    >>> from tunnelsense.datasets import make_tunnel_tour
    >>> from tunnelsense.tunnel import detect_tour, make_indicator_pipeline
    >>> X, y, _ = to_xy(make_tunnel_tour(60, random_state=0, first_indicator_m=20.0))
    >>> model = make_indicator_pipeline(random_state=0).fit(X, y)
    >>> records = detect_tour(model, X, chunk=16)
    >>> [r.key for r in records] == [r.key for r in model.predict(X)]
    True
    """
    head, tail = model[:-2], model[-2:]
    parts = []
    for lo in range(0, len(frames), chunk):
        parts.append(head.transform(frames[lo:lo + chunk]))
        if progress is not None:
            progress.update(min(lo + chunk, len(frames)))
    return tail.predict(FrameSequence.concat(parts))


def open_frames(source, *, colour=None, missing_frames="raise"):
    """The frames of a source, read lazily, and their number.

    A MOTChallenge or image folder gives records that decode their PNG on access; a
    video file is decoded sequentially, records built on the fly.  The first frame is
    decoded here, so that frames that cannot be read as ``colour`` says are refused
    before any output is written.  ``missing_frames`` is :func:`open_tour`'s.

    Returns
    -------
    frames : iterable of FrameRecord
    total : int
        Number of frames (for a video, as its header states).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from tunnelsense.datasets import make_tunnel_tour
    >>> from tunnelsense.io import write_tour
    >>> from tunnelsense.tunnel._detect import open_frames
    >>> folder = pathlib.Path(tempfile.mkdtemp()) / "tour"
    >>> _ = write_tour(make_tunnel_tour(5, random_state=0), folder)
    >>> frames, total = open_frames(folder)
    >>> total, next(frames).frame
    (5, 1)
    """
    source = Path(source)
    if not source.is_file():
        tour = open_tour(source, colour=colour, ground_truth=False,
                         missing_frames=missing_frames)
        if not len(tour):
            return iter(tour.frames), 0
        first = decode_once(tour.frames[0])  # decoded here and not again
        return itertools.chain([first], itertools.islice(tour.frames, 1, None)), len(tour)
    capture = open_video(source)
    total = int(capture.get(cv2.CAP_PROP_FRAME_COUNT) or 0)
    fps = float(capture.get(cv2.CAP_PROP_FPS) or 0.0)
    capture.release()
    if total > 0:
        read_video_frame(source, 0, colour=colour)
    # the header's frame rate, like a tour's (none: the stages' reference rate)
    payload = {FRAME_RATE: fps} if np.isfinite(fps) and fps > 0 else {}
    frames = (FrameRecord(source.stem, i, image, dict(payload))
              for i, image in enumerate(iter_video(source, colour=colour), 1))
    return frames, total


@contextlib.contextmanager
def opencv_threads(n):
    """A context in which OpenCV's functions use at most ``n`` threads (process-wide,
    as OpenCV's setting is; the earlier setting is restored on the way out).

    The detector calls OpenCV on every cluster's small window and patch (median
    filters, connected components): with a pool of threads, each call pays for waking
    and joining them, more than the work itself, and the pool contends with the
    reader threads decoding the next frames.  No result depends on it.

    Examples
    --------
    >>> import cv2
    >>> before = cv2.getNumThreads()
    >>> with opencv_threads(1):
    ...     cv2.getNumThreads()
    1
    >>> cv2.getNumThreads() == before
    True
    """
    before = cv2.getNumThreads()
    cv2.setNumThreads(int(n))
    try:
        yield
    finally:
        cv2.setNumThreads(before)


#: Frames :func:`detect_to_files` passes through the per-frame stages at once: each
#: stage's fixed cost of a call is shared by them, the results are the same, and a
#: frame is written at most this many frames later.
DETECT_CHUNK = 4


def _chunks(items, size):
    """``items`` in lists of ``size`` (the last one shorter)."""
    items = iter(items)
    while held := list(itertools.islice(items, size)):
        yield held


def stream_detect(model, frames, *, progress=None, n_threads=0, stages_in_readers=False,
                  chunk=1):
    """Run a fitted indicator pipeline online; yield the frames as they are final.

    Parameters
    ----------
    model : Pipeline
        From :func:`~tunnelsense.tunnel.make_indicator_pipeline`, fitted.
    frames : iterable of FrameRecord
        In frame order within each tour.
    progress : Progress or None, default=None
    n_threads : int, default=0
        Reader threads decoding the next frames while this one is detected (0: none).
    stages_in_readers : bool or int, default=False
        Whether the reader threads also run each frame through the stages that look
        at one frame alone (keypoints, verifier, clusters, appearance), this thread
        then linking and verifying the trajectories only (True); or through the
        first this many of them (an int: 1, the keypoints), this thread running the
        others.  The results are the same either way.  It spreads the work over
        idle cores; on a machine whose cores are busy it is slower (the readers
        hold the interpreter lock in turns, and the system suspends one that holds
        it while the others wait).
    chunk : int, default=1
        Frames fed to this thread's stages at once
        (:meth:`StreamingPipeline.push_many`; not with ``stages_in_readers=True``):
        each stage's fixed cost of a call is shared by them.  The results are the
        same; a frame is yielded up to ``chunk - 1`` frames later.

    Yields
    ------
    record : FrameRecord
        As ``model.predict`` gives them, in input order, each as soon as every
        trajectory through it has ended (in-memory images are released).

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import to_xy
    >>> from tunnelsense.datasets import make_tunnel_tour
    >>> from tunnelsense.tunnel import make_indicator_pipeline, stream_detect
    >>> X, y, _ = to_xy(make_tunnel_tour(60, random_state=0, first_indicator_m=20.0))
    >>> model = make_indicator_pipeline(random_state=0).fit(X, y)
    >>> streamed = list(stream_detect(model, iter(X), n_threads=1))
    >>> all(np.array_equal(a.payload["detections"], b.payload["detections"])
    ...     for a, b in zip(streamed, model.predict(X), strict=True))
    True
    """
    if isinstance(stages_in_readers, bool | np.bool_):
        every, steps = bool(stages_in_readers), 0
    elif isinstance(stages_in_readers, int | np.integer) and stages_in_readers >= 0:
        every, steps = False, int(stages_in_readers)
    else:
        raise ValueError("stages_in_readers must be a bool or a non-negative int; got "
                         f"{stages_in_readers!r}")
    stream = StreamingPipeline(model, prepare_steps=(
        None if every else steps if n_threads > 0 else 0))
    push, prepared = stream.push, False
    if n_threads > 0 and stream.prepared_steps > 0:
        # the (first) stages that keep no state run in the reader threads beside the
        # decode; this thread runs the others and links the tracks
        frames = decode_ahead(frames, n_threads=n_threads, then=stream.prepare)
        push, prepared = stream.push_prepared, True
    elif n_threads > 0:
        frames = decode_ahead(frames, n_threads=n_threads)
    # one frame's matrix products are small: BLAS threads would only contend with
    # the reader threads; so would OpenCV's on a cluster's small windows and patches
    with blas_threads(1), opencv_threads(1):
        if chunk > 1 and not every:
            done = 0
            for held in _chunks(frames, chunk):
                yield from stream.push_many(held, prepared=prepared)
                done += len(held)
                if progress is not None:
                    progress.update(done)
        else:
            for k, record in enumerate(frames, 1):
                yield from push(record)
                if progress is not None:
                    progress.update(k)
        yield from stream.close()


def detect_to_files(model, source, out, *, resume=False, overwrite=False, n_threads=0,
                    progress=None, draw=None, draw_every=1, draw_video=None,
                    colour=None, stages_in_readers=False, missing_frames="raise"):
    """Detect indicators in a tour or video, writing results as frames are final.

    ``out`` (MOTChallenge results) and its ``.clusters.csv`` companion are written
    line by line and flushed after every frame, so an interrupted run keeps its
    lines; ``resume=True`` replays the source and appends the rest.

    Parameters
    ----------
    model : Pipeline
        A fitted indicator pipeline.
    source : str or Path
        MOTChallenge folder, image folder or video file.
    out : str or Path
        The results file.
    resume, overwrite : bool, default=False
        Continue an interrupted ``out``; replace an existing one.
    n_threads : int, default=0
        Reader threads (see :func:`stream_detect`).
    stages_in_readers : bool or int, default=False
        The reader threads also run the per-frame stages, or the first this many
        (see :func:`stream_detect`).
    progress : Progress or None, default=None
        Its total is set to the number of frames, then updated after each frame.
    draw : str, Path or None, default=None
        A folder to draw every ``draw_every``-th frame into
        (:func:`tunnelsense.plotting.draw_detections`), as ``000001.png``...
    draw_every : int, default=1
    draw_video : str, Path or None, default=None
        A ``.mp4`` or ``.avi`` file to draw every frame into, at the source's frame
        rate (``cv2.VideoWriter``); it is not checked for overwriting here.  Written
        beside under a temporary name and renamed when the run ends, early or not.
    colour : int, "luminance" or None, default=None
        How colour frames become grey: refused (None), one channel, or luminance
        (see :func:`~tunnelsense.io.read_image`).
    missing_frames : {"raise", "gap"}, default="raise"
        Frame files missing from a MOTChallenge folder: refused, or read as gaps in
        time (the frames a recorder kept, each under its number; see
        :func:`~tunnelsense.io.read_tour`).

    Returns
    -------
    facts : dict
        ``frames``, ``detections``, ``trajectories`` (indicator trajectories),
        ``resumed_lines``, ``drawn`` (bytes of each picture drawn) and
        ``video_frames`` (frames in ``draw_video``).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from tunnelsense import to_xy
    >>> from tunnelsense.datasets import make_tunnel_tour
    >>> from tunnelsense.io import write_tour
    >>> from tunnelsense.tunnel import detect_to_files, make_indicator_pipeline
    >>> tour = make_tunnel_tour(60, random_state=0, first_indicator_m=20.0)
    >>> X, y, _ = to_xy(tour)
    >>> model = make_indicator_pipeline(random_state=0).fit(X, y)
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = write_tour(tour, folder / "tour")
    >>> facts = detect_to_files(model, folder / "tour", folder / "tour.txt")
    >>> facts["frames"], sorted(p.name for p in folder.glob("tour.*"))
    (60, ['tour.clusters.csv', 'tour.txt'])
    """
    if draw_every < 1:
        raise ValueError(f"draw_every must be at least 1; got {draw_every}")
    frames, total = open_frames(source, colour=colour, missing_frames=missing_frames)
    first = next(frames, None)
    if first is not None:  # a frame of another bit depth: refused, nothing written
        check_served_depth(model, first, source)
        frames = itertools.chain([first], frames)
    if progress is not None:
        progress.set_total(total)
    images = {}
    drawing = draw is not None or draw_video is not None
    if drawing and Path(source).is_file():
        frames = _keep_images(frames, images)  # video frames are decoded once
    released = stream_detect(model, frames, progress=progress, n_threads=n_threads,
                             stages_in_readers=stages_in_readers, chunk=DETECT_CHUNK)
    if drawing:
        pictures = draw_detections(_in_own_pixels(_with_images(released, images)))
    else:
        pictures = ((r, None) for r in released)
    ids = set()
    # Everything that can fail before the first frame comes first; the results file
    # (the one a fleet takes as the mark of a finished tour) is opened last.
    with contextlib.ExitStack() as stack:
        video = (stack.enter_context(VideoOutput(draw_video,
                                                 fps=source_frame_rate(source)))
                 if draw_video is not None else None)
        if draw is not None:
            Path(draw).mkdir(parents=True, exist_ok=True)
        with contextlib.ExitStack() as opening:  # results closed after clusters
            clusters = opening.enter_context(ResultsWriter(
                clusters_path(out), header=CLUSTERS_HEADER, resume=resume,
                overwrite=overwrite))
            results = stack.enter_context(ResultsWriter(
                out, resume=resume, overwrite=overwrite, line_pattern=RESULT_LINE))
            stack.enter_context(opening.pop_all())
        facts = {"frames": 0, "detections": 0, "resumed_lines": results.resumed_lines,
                 "drawn": [], "video_frames": 0}
        for r, pic in pictures:
            if draw_video is not None:
                video.write(pic)
                facts["video_frames"] = video.frames
            lines = mot_result_lines(r)
            for line in lines:
                results.write(line)
            for line in cluster_lines(r):
                clusters.write(line)
            results.flush()
            clusters.flush()
            facts["frames"] += 1
            facts["detections"] += len(lines)
            ids.update(np.asarray(r.payload["detections"]).reshape(-1, 6)[:, 4].tolist())
            if draw is not None and (r.frame - 1) % draw_every == 0:
                target = Path(draw) / f"{r.frame:06d}.png"
                if not cv2.imwrite(str(target), pic):
                    raise OSError(f"{target}: OpenCV could not write the picture")
                facts["drawn"].append(target.stat().st_size)
    facts["trajectories"] = len(ids)
    return facts


def _keep_images(frames, images):
    for r in frames:
        images[r.frame] = r.image
        yield r


def _with_images(records, images):
    for r in records:
        image = images.pop(r.frame, None)
        if image is None:
            yield r
            continue
        yield FrameRecord(r.tour, r.frame, image, r.payload)


def _in_own_pixels(records):
    """Records to draw: the frame's own image (decoded again from its file, or kept)
    with the cluster rectangles mapped back from the detector's pixels when the
    detector resampled the frame (``payload["frame_scale"]``)."""
    for r in records:
        sx, sy = r.payload.get("frame_scale", (1.0, 1.0))
        if (sx, sy) == (1.0, 1.0):
            yield r
            continue
        boxes = np.asarray(r.payload["cluster_boxes"], np.float64).reshape(-1, 4)
        yield FrameRecord(r.tour, r.frame, r.source, {
            **r.payload, "cluster_boxes": boxes / np.array([sx, sy, sx, sy])})
