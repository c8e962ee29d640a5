"""The detector and the positioner together, online: one frame in, its position out."""

from __future__ import annotations

import numpy as np
import pandas as pd

from tunnelsense.exceptions import InputFormatError
from tunnelsense.positioning._tables import ESTIMATE_COLUMNS, check_odometry

__all__ = ["locate_online"]

#: Frames between two takes of the positioner's final rows (its memory stays flat).
_DRAIN = 1024


def locate_online(model, frames, odometry, positioner, *, on_position=None,
                  progress=None, n_threads=0, on_rows=None):
    """Detect indicators frame by frame and give each frame's chainage at once.

    Each frame goes through the fitted detector's stream, as in ``detect tunnel``
    (reader threads decode the next frames meanwhile; one BLAS thread, since one
    frame's matrix products are small); the frames it releases (their trajectories
    have ended) carry the detections the positioner needs, and the frame's odometry
    sample gives its position before the next frame is read.  A fix is used as soon
    as the detector has released every frame of its trajectory: as a delayed
    measurement, from the frame the camera passed the sign.

    Parameters
    ----------
    model : Pipeline
        A fitted indicator pipeline (:func:`tunnelsense.tunnel.make_indicator_pipeline`).
    frames : iterable of FrameRecord
        The tour's frames, in order; frame numbers may skip frames the recorder
        lost (a tour read with ``missing_frames="gap"``).
    odometry : DataFrame
        ``frame, stamp, speed, yaw_rate``, a row for every frame (lost frames
        included: from the first frame on, a lost frame's row gives it a position
        from the odometry alone).
    positioner : TunnelPositioner
        Fitted (it holds the indicator map).  With ``smooth``, the rows are the
        stream's fixed-lag smoother's (the whole-tour smoother is offline:
        ``positioner.predict`` on a results file).
    on_position : callable or None, default=None
        Called with the :class:`Position` of each frame as soon as it is known
        (before the next frame is read; a lost frame's, before the frame after it).
    progress : Progress or None, default=None
    n_threads : int, default=0
        Reader threads decoding the next frames (0: none).
    on_rows : callable or None, default=None
        Called with each block of final rows (a DataFrame) as it is released; the
        rows are then not kept, and the returned table is empty.

    Returns
    -------
    positions : DataFrame
        ``frame, stamp, chainage, sigma, locked, scale, scale_sigma`` of every frame
        (unless ``on_rows`` took them).
    fixes : DataFrame
        The fix of every trajectory (:attr:`PositionStream.fixes`); its
        ``attrs["lock_status"]`` says whether and where the stream locked on.
    """
    from threadpoolctl import threadpool_limits

    from tunnelsense._streaming import StreamingPipeline
    from tunnelsense.io._sources import decode_ahead

    odo = check_odometry(odometry)
    odo_frames = odo["frame"].to_numpy()
    stamps, speeds = odo["stamp"].tolist(), odo["speed"].tolist()
    detector = StreamingPipeline(model)
    stream = positioner.start_stream()
    parts, fixes = [], []
    take = on_rows if on_rows is not None else parts.append
    if n_threads > 0:
        frames = decode_ahead(frames, n_threads=n_threads)
    until = 0  # the detector's output is final up to this frame
    row = 0  # the odometry row of the frame (frames and rows both increase)
    with threadpool_limits(limits=1, user_api="blas"):
        for k, record in enumerate(frames, 1):
            released = detector.push(record)
            if released:
                until = released[-1].frame
            f = int(record.frame)
            if k == 1:
                row = int(np.searchsorted(odo_frames, f, side="left"))
            # frames the recorder lost (a tour read with gaps): their odometry rows
            # still carry the distance driven, and get a position with no detection
            while row < len(odo_frames) and odo_frames[row] < f:
                lost = stream.push(int(odo_frames[row]), stamps[row], speeds[row],
                                   until=until)
                row += 1
                if on_position is not None:
                    on_position(lost)
            if row >= len(odo_frames) or odo_frames[row] != f:
                raise InputFormatError(f"odometry: no row for frame {f}")
            position = stream.push(f, stamps[row], speeds[row],
                                   detections=released or None, until=until)
            row += 1
            if on_position is not None:
                on_position(position)
            if progress is not None:
                progress.update(k)
            if k % _DRAIN == 0:
                rows = stream.drain()
                if len(rows):
                    take(rows)
                fixes.append(stream.drain_fixes())
        stream.add_detections(detector.close())
    rows = stream.close()
    if len(rows) or not parts:
        take(rows)
    fixes = pd.concat([f for f in [*fixes, stream.drain_fixes()] if len(f)] or [
        stream.fixes], ignore_index=True)
    fixes.attrs["lock_status"] = stream.lock_status()
    if on_rows is not None:
        return pd.DataFrame(columns=list(ESTIMATE_COLUMNS)), fixes
    return pd.concat(parts, ignore_index=True), fixes
