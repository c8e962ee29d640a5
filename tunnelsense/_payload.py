"""The payload contract between record stages: its keys, their readers and checks.

A stage maps records to records with the same identity and a payload grown by what it
computed (:meth:`~tunnelsense.FrameRecord.evolve`).  What a stage reads and adds is
declared on its class,

* ``_payload_reads``: the keys it needs (a record without one is refused, naming the
  stage that makes it);
* ``_payload_optional``: the keys it uses when present;
* ``_payload_adds``: the keys it sets (every other key passes through unchanged),

and :func:`tunnelsense.utils.check_record_stage` verifies on a simulated tour that a
stage adds exactly what it declares.  The keys are the constants below; stages read
them through the accessors, which check the shapes.  :func:`inside_boxes` is the one
point-in-box rule and :func:`check_image` the one image check of the FIR stages.
"""

from __future__ import annotations

import math

import numpy as np

from tunnelsense.exceptions import InputFormatError

__all__ = [
    "FINISHED_OBJECTS",
    "FRAME_RATE",
    "APPEARANCE",
    "APPEARANCE_SCORE",
    "BEAMS",
    "CLUSTERS",
    "CLUSTER_BOXES",
    "CLUSTER_HISTOGRAMS",
    "CLUSTER_LABELS",
    "CONTINUED_TRACKS",
    "CUT_TRACKS",
    "DETECTIONS",
    "DETECTION_COLUMNS",
    "ENDED_TRACKS",
    "INDICATOR",
    "IN_VIEW",
    "KEYPOINTS",
    "KEYPOINT_BAND",
    "MADE_BY",
    "MOTION_R",
    "OBJECTS",
    "POINTS",
    "SAMPLED_KEYPOINTS",
    "SPEED",
    "TILT",
    "TRACK_IDS",
    "TRAJECTORY_LENGTH",
    "TRAJECTORY_POSITIVE",
    "boxes_of",
    "check_image",
    "continued_tracks_of",
    "cut_tracks_of",
    "ended_tracks_of",
    "frame_image",
    "frame_rate_of",
    "scaled_count",
    "histograms_of",
    "inside_boxes",
    "keypoint_band_of",
    "keypoints_of",
    "per_cluster",
    "read",
    "where",
]

# ------------------------------------------------------------------ FIR frame stages
#: float: frames per second of the frame's tour (set by :class:`~tunnelsense.Tour`;
#: a frame without it, such as one made from a user's array, is taken to be at the
#: rate the stages' frame counts are given in).
FRAME_RATE = "frame_rate"
#: (n, 3) int32 ``(row, col, intensity)`` in raster order; the verifier keeps a subset.
KEYPOINTS = "keypoints"
#: ``(low, high)``: the sampler's intensity band.
KEYPOINT_BAND = "keypoint_band"
#: ``(sx, sy)``: how much the sampler resampled the frame to the training frames' size
#: ((1, 1) when it did not; the detections are mapped back to the frame's own pixels)
FRAME_SCALE = "frame_scale"
#: (n, 3) int32: every keypoint the sampler found (before verification).
SAMPLED_KEYPOINTS = "sampled_keypoints"
#: (n,) intp: the cluster of every keypoint.
CLUSTER_LABELS = "cluster_labels"
#: (m, 4) float64 ``(left, top, width, height)`` per keypoint cluster.
CLUSTER_BOXES = "cluster_boxes"
#: (m,) bool: the appearance label of every cluster.
APPEARANCE = "appearance"
#: (m,) float64: the AdaBoost decision function of every cluster.
APPEARANCE_SCORE = "appearance_score"
#: (m, bins) float64: the histogram of every cluster's rectangle.
CLUSTER_HISTOGRAMS = "cluster_histograms"
#: (m,) int64: the trajectory of every cluster.
TRACK_IDS = "track_ids"
#: (k,) int64: the trajectories that ended at this frame.
ENDED_TRACKS = "ended_tracks"
#: (k,) int64: the trajectories among ``ended_tracks`` that ended at the linker's
#: ``max_track_length`` while their object could still be linked: a later trajectory
#: may continue each (``continued_tracks`` says which, or that none does).
CUT_TRACKS = "cut_tracks"
#: (k, 2) int64, rows ``(track_id, earlier_id)``: the trajectory ``track_id``, which
#: starts at this frame, continues ``earlier_id`` (one of an earlier frame's
#: ``cut_tracks``); ``track_id`` 0 says that no trajectory will continue ``earlier_id``.
CONTINUED_TRACKS = "continued_tracks"
#: (m,) float64: the straightness of every cluster's trajectory.
MOTION_R = "motion_r"
#: (m,) int64: the number of clusters of every cluster's trajectory.
TRAJECTORY_LENGTH = "trajectory_length"
#: (m,) bool: the per-cluster decision.
INDICATOR = "indicator"
#: (m,) bool: whether the cluster's trajectory is positive by the vote.
TRAJECTORY_POSITIVE = "trajectory_positive"
#: (k, 6) float64, one row per detection, columns :data:`DETECTION_COLUMNS`.
DETECTIONS = "detections"
#: Columns of ``payload["detections"]``.
DETECTION_COLUMNS = ("bb_left", "bb_top", "bb_width", "bb_height", "track_id", "score")

# ------------------------------------------------------------------ street scan stage
#: (n, 2) float64: ROI points ``(depth, height)`` of a scan.
POINTS = "points"
#: (n,) int: the beam number of every point.
BEAMS = "beams"
#: (n,) int: the intra-scan cluster of every point.
CLUSTERS = "clusters"
#: (n_clusters,) int64: the object id of every intra-scan cluster.
OBJECTS = "objects"
#: float: the tilt (rad) used for the scan.
TILT = "tilt"
#: (k, 2) int64 ``(object id, label code)`` of the objects in view.
IN_VIEW = "in_view"
#: float (m/s), read when present: the ego speed at the scan.
SPEED = "speed"
#: Object-table rows (:data:`~tunnelsense.street.OBJECT_COLUMNS`) that became final
#: by the time this scan was released (``tuple`` of tuples, in id order).
FINISHED_OBJECTS = "finished_objects"

#: The stage that adds each key (named in the error for a record that lacks it).
MADE_BY = {
    KEYPOINTS: "IntensityKeypointSampler",
    KEYPOINT_BAND: "IntensityKeypointSampler",
    FRAME_SCALE: "IntensityKeypointSampler",
    SAMPLED_KEYPOINTS: "KMeansHistogramVerifier",
    CLUSTER_LABELS: "MSTClusterer",
    CLUSTER_BOXES: "MSTClusterer",
    APPEARANCE: "WeightedAdaBoost",
    APPEARANCE_SCORE: "WeightedAdaBoost",
    CLUSTER_HISTOGRAMS: "WeightedAdaBoost",
    TRACK_IDS: "TrajectoryLinker",
    ENDED_TRACKS: "TrajectoryLinker",
    CUT_TRACKS: "TrajectoryLinker",
    CONTINUED_TRACKS: "TrajectoryLinker",
    MOTION_R: "PCCVerifier",
    TRAJECTORY_LENGTH: "PCCVerifier",
    INDICATOR: "PCCVerifier",
    TRAJECTORY_POSITIVE: "PCCVerifier",
    DETECTIONS: "PCCVerifier",
    POINTS: "ScanClusterer",
    BEAMS: "ScanClusterer",
    CLUSTERS: "ScanClusterer",
    OBJECTS: "ScanClusterer",
    TILT: "ScanClusterer",
    IN_VIEW: "ScanClusterer",
    FINISHED_OBJECTS: "ScanClusterer",
}


def where(record, index) -> str:
    """How errors name a record: ``X[i] (tour, frame f)`` or ``X[i] (run, scan s)``."""
    if hasattr(record, "scan"):
        return f"X[{index}] ({record.run!r}, scan {record.scan})"
    return f"X[{index}] ({record.tour!r}, frame {record.frame})"


def read(record, index, key, stage, *, instead=""):
    """``record.payload[key]``, or a ValueError naming the stage that adds it.

    ``instead`` is appended to the message (another way to give the stage what it
    needs).
    """
    try:
        return record.payload[key]
    except KeyError:
        raise ValueError(
            f"{where(record, index)} has no payload[{key!r}]: {stage} needs frame "
            f"records that went through {MADE_BY[key]} first{instead}"
        ) from None


def _shape_error(record, index, key, expected, got):
    return ValueError(
        f"{where(record, index)}: payload[{key!r}] must have shape {expected}; "
        f"got shape {got}"
    )


def keypoints_of(record, index, stage) -> np.ndarray:
    """The ``(n, 3)`` keypoints ``(row, col, intensity)`` of a record."""
    kp = np.asarray(read(record, index, KEYPOINTS, stage))
    if kp.ndim != 2 or kp.shape[1] != 3:
        raise _shape_error(record, index, KEYPOINTS, "(n, 3) (row, col, intensity)",
                           kp.shape)
    return kp


def keypoint_band_of(record, index, stage, *, instead="") -> tuple:
    """The sampler's intensity band ``(low, high)`` of a record."""
    return tuple(read(record, index, KEYPOINT_BAND, stage, instead=instead))


def boxes_of(record, index, stage) -> np.ndarray:
    """The ``(m, 4)`` cluster boxes ``(left, top, width, height)`` of a record."""
    boxes = np.asarray(read(record, index, CLUSTER_BOXES, stage), dtype=np.float64)
    if boxes.ndim != 2 or boxes.shape[1] != 4:
        raise _shape_error(record, index, CLUSTER_BOXES,
                           "(m, 4) (left, top, width, height)", boxes.shape)
    return boxes


def per_cluster(record, index, key, m, stage) -> np.ndarray:
    """A per-cluster array ``payload[key]`` of shape ``(m,)``: one entry per cluster."""
    value = np.asarray(read(record, index, key, stage))
    if value.shape != (m,):
        raise _shape_error(record, index, key, f"({m},), one entry per cluster",
                           value.shape)
    return value


def histograms_of(record, index, m) -> np.ndarray | None:
    """The ``(m, bins)`` cluster histograms of a record, or None when it has none.

    A record whose histograms do not match its ``m`` clusters is refused (it would
    otherwise link by the wrong appearance, or silently by none).
    """
    hists = record.payload.get(CLUSTER_HISTOGRAMS)
    if hists is None:
        return None
    hists = np.asarray(hists)
    if hists.ndim != 2 or len(hists) != m:
        raise _shape_error(record, index, CLUSTER_HISTOGRAMS,
                           f"({m}, bins), one row per cluster", hists.shape)
    return hists


def cut_tracks_of(record) -> list:
    """The trajectories a record says were cut at ``max_track_length`` (a list of ids)."""
    cut = record.payload.get(CUT_TRACKS)
    return [] if cut is None else np.asarray(cut).reshape(-1).tolist()


def continued_tracks_of(record) -> list:
    """The ``(track_id, earlier_id)`` pairs of a record (a list of int tuples)."""
    pairs = record.payload.get(CONTINUED_TRACKS)
    if pairs is None:
        return []
    return [tuple(p) for p in np.asarray(pairs, dtype=np.int64).reshape(-1, 2).tolist()]


def ended_tracks_of(record) -> list | None:
    """The trajectories that ended at a record (a list of ids), or None when not given."""
    ended = record.payload.get(ENDED_TRACKS)
    if ended is None:
        return None
    return np.asarray(ended).reshape(-1).tolist()


def inside_boxes(x, y, boxes) -> np.ndarray:
    """Which of ``boxes`` hold each point ``(x, y)``: the one point-in-box rule.

    A point is inside ``(left, top, width, height)`` when ``left <= x < left + width``
    and ``top <= y < top + height``.

    Parameters
    ----------
    x, y : array-like of shape (n,)
        Columns and rows of the points.
    boxes : array-like of shape (k, 4)

    Returns
    -------
    inside : ndarray of shape (n, k), bool

    Examples
    --------
    >>> import numpy as np
    >>> inside_boxes([5, 5], [5, 50], np.array([[0, 0, 10, 10.], [0, 40, 10, 20]]))
    array([[ True, False],
           [False,  True]])
    """
    x = np.asarray(x)[:, None]
    y = np.asarray(y)[:, None]
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    return (b[:, 0] <= x) & (x < b[:, 0] + b[:, 2]) & (b[:, 1] <= y) & (y < b[:, 1] + b[:, 3])


def check_image(image, what) -> np.ndarray:
    """``image`` if it is a 2-D ``uint8`` or ``uint16`` array, else a ValueError.

    ``what`` names the image in the message (``"X[3] ('tour', frame 4)"``).
    """
    if (
        isinstance(image, np.ndarray)
        and image.ndim == 2
        and image.dtype in (np.uint8, np.uint16)
    ):
        return image
    desc = (
        f"an array of dtype {image.dtype} and shape {image.shape}"
        if isinstance(image, np.ndarray)
        else type(image).__name__
    )
    raise ValueError(f"{what}: the image must be a 2-D uint8 or uint16 array; got {desc}")


def frame_image(record, index) -> np.ndarray:
    """The record's image, checked by :func:`check_image`."""
    return check_image(record.image, where(record, index))


def frame_rate_of(record):
    """The frame rate (frames per second) a record carries, or None.

    ``payload["frame_rate"]`` when present; absent (or None) means the rate is
    unknown.  A rate that is present but not a positive finite number is refused:
    read as "unknown" it would silently count frames at 30 fps.

    Raises
    ------
    InputFormatError
        If ``payload["frame_rate"]`` is present but not a positive finite number.
    """
    rate = record.payload.get(FRAME_RATE)
    if rate is None:
        return None
    try:
        value = float(rate)
    except (TypeError, ValueError):
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise InputFormatError(
            f'payload["{FRAME_RATE}"] of frame {getattr(record, "frame", "?")}: expected '
            f"a positive finite number of frames per second, got {rate!r}"
        )
    return value


def scaled_count(count, ratio, floor):
    """A count of frames at one frame rate, in frames at another (``ratio`` = new / old).

    ``count * ratio`` rounded half up, but never below ``min(count, floor)``: a count
    scaled down keeps at least ``floor`` frames (or the count itself when smaller),
    so a length whose meaning needs that many points keeps it.  At ``ratio == 1`` the
    count is unchanged; ``ratio > 1`` only scales up.

    Examples
    --------
    >>> from tunnelsense._payload import scaled_count
    >>> scaled_count(10, 1.0, 7), scaled_count(10, 0.3, 7), scaled_count(10, 2.0, 7)
    (10, 7, 20)
    >>> scaled_count(6, 0.3, 1), scaled_count(5, 0.3, 7)
    (2, 5)
    """
    count = int(count)
    if ratio == 1.0:
        return count
    return max(int(math.floor(count * ratio + 0.5)), min(count, int(floor)))
