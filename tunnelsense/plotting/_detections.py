"""The indicator detector's output drawn on its frames, like the paper's figures.

Drawn with OpenCV (no matplotlib needed): ``detect tunnel --draw`` writes these.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["DRAW_COLOURS", "draw_detections"]

#: BGR colours of :func:`draw_detections`, as in the paper's Figs. 1b, 4 and 5.
DRAW_COLOURS = {
    "appearance_positive": (0, 0, 255),  # red rectangle
    "appearance_negative": (0, 200, 0),  # green rectangle
    "trajectory_positive": (0, 255, 255),  # yellow trajectory
    "trajectory_negative": (255, 255, 255),  # white trajectory
}

_LEGEND = (
    ("appearance_positive", "box", "cluster: indicator"),
    ("appearance_negative", "box", "cluster: other"),
    ("trajectory_positive", "line", "trajectory: indicator"),
    ("trajectory_negative", "line", "trajectory: other"),
)


def _legend(pic, frame) -> None:
    """The frame number and the colour key, top left on a dark band."""
    font, size, row = cv2.FONT_HERSHEY_SIMPLEX, 0.35, 12
    width = 8 + max(cv2.getTextSize(t, font, size, 1)[0][0] for *_, t in _LEGEND) + 22
    band = pic[: row * 5 + 6, :width]
    band[:] = (band * 0.35).astype(np.uint8)
    cv2.putText(pic, f"frame {frame}", (4, row), font, size, (255, 255, 255), 1,
                cv2.LINE_AA)
    for k, (key, kind, text) in enumerate(_LEGEND, 2):
        y = row * k
        colour = DRAW_COLOURS[key]
        if kind == "box":
            cv2.rectangle(pic, (5, y - 7), (15, y), colour, 1)
        else:
            cv2.line(pic, (4, y - 3), (16, y - 3), colour, 2)
        cv2.putText(pic, text, (22, y), font, size, (255, 255, 255), 1, cv2.LINE_AA)


def draw_detections(records, *, scale=1, legend=True):
    """Draw the detector's output like the paper's Figs. 1b, 4 and 5.

    Keypoint clusters are drawn as rectangles, red when their appearance label is
    positive and green when negative; trajectories (the centres of their clusters up
    to the frame) as polylines, yellow when the trajectory is positive by motion (the
    vote of :class:`~tunnelsense.tunnel.PCCVerifier`) and white when negative.

    Parameters
    ----------
    records : iterable of FrameRecord
        Output of the indicator pipeline's ``predict`` for one tour, in frame order.
    scale : int, default=1
        Enlarge the frames by this factor (nearest neighbour) before drawing.
    legend : bool, default=True
        Write the frame number and the colour key in the top left corner.

    Yields
    ------
    record : FrameRecord
    picture : ndarray of shape (height * scale, width * scale, 3), uint8 (BGR)

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import FrameRecord
    >>> from tunnelsense.plotting import draw_detections
    >>> r = FrameRecord("t", 7, np.zeros((120, 160), np.uint8), {
    ...     "cluster_boxes": np.array([[60.0, 40.0, 8.0, 16.0]]),
    ...     "appearance": np.array([True]), "track_ids": np.array([1]),
    ...     "trajectory_positive": np.array([True])})
    >>> [(record.frame, picture.shape) for record, picture in draw_detections([r])]
    [(7, (120, 160, 3))]
    """
    history: dict = {}
    for r in records:
        image = r.image
        if image.dtype != np.uint8:
            image = cv2.normalize(image, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
        if scale != 1:
            image = cv2.resize(image, None, fx=scale, fy=scale,
                               interpolation=cv2.INTER_NEAREST)
        pic = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        p = r.payload
        boxes = np.asarray(p.get("cluster_boxes", np.empty((0, 4)))).reshape(-1, 4)
        app = np.asarray(p.get("appearance", np.zeros(len(boxes), bool)))
        tracks = np.asarray(p.get("track_ids", np.zeros(len(boxes), np.int64)))
        tpos = np.asarray(p.get("trajectory_positive", np.zeros(len(boxes), bool)))
        for b, a, t, tp in zip(boxes, app, tracks, tpos, strict=True):
            pts = history.setdefault((r.tour, int(t)), [])
            pts.append(((b[0] + b[2] / 2) * scale, (b[1] + b[3] / 2) * scale))
            colour = DRAW_COLOURS["trajectory_positive" if tp else "trajectory_negative"]
            if len(pts) > 1:
                poly = np.round(np.array(pts)).astype(np.int32).reshape(-1, 1, 2)
                cv2.polylines(pic, [poly], False, colour, 1, cv2.LINE_AA)
            colour = DRAW_COLOURS["appearance_positive" if a else "appearance_negative"]
            x0, y0 = int(round(b[0] * scale)), int(round(b[1] * scale))
            x1 = int(round((b[0] + b[2]) * scale)) - 1
            y1 = int(round((b[1] + b[3]) * scale)) - 1
            cv2.rectangle(pic, (x0 - 2, y0 - 2), (x1 + 2, y1 + 2), colour, 1)
        if legend:
            _legend(pic, r.frame)
        yield r, pic
