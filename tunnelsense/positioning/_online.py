"""The detector and the positioner together, online: one frame in, its position out."""

from __future__ import annotations

from tunnelsense.exceptions import InputFormatError
from tunnelsense.positioning._tables import check_odometry

__all__ = ["locate_online"]


def locate_online(model, frames, odometry, positioner, *, on_position=None,
                  progress=None):
    """Detect indicators frame by frame and give each frame's chainage at once.

    Each frame goes through the fitted detector's stream; the frames it releases
    (their trajectories have ended) carry the detections the positioner needs, and
    the frame's odometry sample gives its position before the next frame is read.
    A fix is used as soon as the detector has released every frame of its
    trajectory: as a delayed measurement, from the frame the camera passed the sign.

    Parameters
    ----------
    model : Pipeline
        A fitted indicator pipeline (:func:`tunnelsense.tunnel.make_indicator_pipeline`).
    frames : iterable of FrameRecord
        The tour's frames, in order.
    odometry : DataFrame
        ``frame, stamp, speed, yaw_rate``, a row for every frame.
    positioner : TunnelPositioner
        Fitted (it holds the indicator map).
    on_position : callable or None, default=None
        Called with ``(frame, stamp, chainage, sigma)`` as soon as a frame's position
        is known (before the next frame is read).
    progress : Progress or None, default=None

    Returns
    -------
    positions : DataFrame
        ``frame, stamp, chainage, sigma``: what was known at each frame, or, with
        ``positioner.smooth``, the smoothed estimate given every fix.
    fixes : DataFrame
        The fix of every trajectory (:attr:`PositionStream.fixes`).
    """
    from tunnelsense._streaming import StreamingPipeline

    odo = check_odometry(odometry)
    rows = {int(f): (t, v, w) for f, t, v, w in odo.itertuples(index=False)}
    detector = StreamingPipeline(model)
    stream = positioner.start_stream()
    until = 0  # the detector's output is final up to this frame
    for k, record in enumerate(frames, 1):
        released = detector.push(record)
        until = released[-1].frame if released else until
        sample = rows.get(int(record.frame))
        if sample is None:
            raise InputFormatError(f"odometry: no row for frame {record.frame}")
        position = stream.push(record.frame, *sample, detections=released, until=until)
        if on_position is not None:
            on_position(position)
        if progress is not None:
            progress.update(k)
    stream.add_detections(detector.close())
    return stream.close(), stream.fixes
