"""Scores of the FIR indicator detector: the paper's Table 1 and trajectory figures.

**Which ground truth counts.**  An indicator box counts when it is at least
``min_height`` px tall (default 14, two rows of the keypoint grid: a shorter indicator
may hold no keypoint at all).  Boxes of smaller indicators are *don't care*: a
cluster on one is neither a hit nor a false alarm.

**Matching rule.**  A keypoint cluster lies on an indicator when the centre of its
rectangle lies inside the indicator's box (:func:`tunnelsense.tunnel.centres_in_boxes`).
A cluster's rectangle spans only its grid keypoints, so it is smaller than the
indicator; overlap ratios would punish the grid's coarseness, not the detector.

**Cluster level (Table 1).**  Every keypoint cluster is a detection hypothesis with
the detector's per-cluster decision (``payload["indicator"]``):

* ``total``: clusters on counted indicators;
* ``correct``: those labelled indicator; ``misses = total - correct``;
* ``false_alarms``: clusters on no indicator labelled indicator;
* ``detection_rate = correct / total``;
* ``false_alarm_rate = false_alarms / negatives``, where ``negatives`` is the number of
  clusters on no indicator.  The paper's 22 false alarms at 0.7 % imply about 3,100
  negative clusters (22 / 472 would be 4.7 %), so its rate is over the negatives.

**Trajectory level.**  A positive trajectory (``payload["trajectory_positive"]``)
belongs to the indicator on which most of its clusters lie (any indicator box, counted
or not); when fewer than half of its clusters lie on an indicator it is a false-alarm
trajectory.  ``indicators`` is the number of indicators with at least one counted box,
``detected`` the number of them to which a positive trajectory belongs,
``detection_rate = detected / indicators``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from tunnelsense._payload import FRAME_RATE, inside_boxes

__all__ = [
    "HYPOTHESIS_COLUMNS",
    "gt_from_boxes",
    "hypotheses_from_records",
    "indicator_scores",
    "tunnel_scores",
]

#: Columns of the hypotheses table (:func:`hypotheses_from_records`).
HYPOTHESIS_COLUMNS = (
    "tour",
    "frame",
    "track_id",
    "bb_left",
    "bb_top",
    "bb_width",
    "bb_height",
    "indicator",
    "trajectory_positive",
)

_GT_COLUMNS = ("tour", "frame", "id", "bb_left", "bb_top", "bb_width", "bb_height")


def hypotheses_from_records(records) -> pd.DataFrame:
    """Every keypoint cluster of the detector's output records, as a table.

    Parameters
    ----------
    records : sequence of FrameRecord
        The output of the indicator pipeline's ``predict`` (or of
        :class:`~tunnelsense.tunnel.PCCVerifier`).

    Returns
    -------
    hypotheses : DataFrame with :data:`HYPOTHESIS_COLUMNS`
    """
    keys = ("cluster_boxes", "track_ids", "indicator", "trajectory_positive")
    tours, frames, tracks, boxes, indicator, positive = [], [], [], [], [], []
    for i, r in enumerate(records):
        p = r.payload
        missing = [k for k in keys if k not in p]
        if missing:
            raise ValueError(
                f"records[{i}] ({r.tour!r}, frame {r.frame}) lacks payload {missing}: "
                "score the output of the indicator pipeline's predict"
            )
        b = np.asarray(p["cluster_boxes"], dtype=np.float64).reshape(-1, 4)
        scale = p.get("frame_scale")
        if scale is not None and tuple(scale) != (1.0, 1.0):
            # the detector resampled the frame: back to the frame's own pixels
            b = b / np.array([scale[0], scale[1], scale[0], scale[1]])
        if len(b) == 0:
            continue
        tours += [r.tour] * len(b)
        frames.append(np.full(len(b), r.frame, np.int64))
        tracks.append(np.asarray(p["track_ids"], dtype=np.int64))
        boxes.append(b)
        indicator.append(np.asarray(p["indicator"], dtype=bool))
        positive.append(np.asarray(p["trajectory_positive"], dtype=bool))
    if not boxes:
        return pd.DataFrame({c: pd.Series(dtype=_dtype(c)) for c in HYPOTHESIS_COLUMNS})
    b = np.concatenate(boxes)
    # one table built from whole columns: a table per frame cost 0.5 ms each
    return pd.DataFrame(
        {
            "tour": tours,
            "frame": np.concatenate(frames),
            "track_id": np.concatenate(tracks),
            "bb_left": b[:, 0],
            "bb_top": b[:, 1],
            "bb_width": b[:, 2],
            "bb_height": b[:, 3],
            "indicator": np.concatenate(indicator),
            "trajectory_positive": np.concatenate(positive),
        }
    )


def _dtype(column):
    if column == "tour":
        return object
    if column in ("frame", "track_id"):
        return np.int64
    if column in ("indicator", "trajectory_positive"):
        return bool
    return np.float64


def gt_from_boxes(records, y) -> pd.DataFrame:
    """Indicator ground truth with identities, from per-frame boxes only.

    ``y`` (as :func:`tunnelsense.to_xy` gives it) holds boxes without identities; an
    identity is recovered by linking each box to a box of the tour's previous frame
    that it overlaps once that previous box is grown by half its width and height on
    every side.  An indicator moves less than that between consecutive frames, even
    in its last frame, when it leaves the image and its box jumps as the frame's edge
    clips it (plain overlap counted such a last frame as a second indicator); and
    indicators stand 200 m apart, so the grown boxes of two of them never meet.  At a
    lower frame rate a near sign moves farther than that between frames (at 15 fps,
    more than its width in its last frame), so a box also links to a previous box
    that has a predecessor when it overlaps that box moved on at its last change
    (position and size: constant velocity), grown the same way; the rule holds
    whatever the frame rate while the motion changes smoothly from frame to frame.
    Frame numbers count time: across a gap of ``g`` frame numbers (frames a
    recorder lost) the previous box is moved on ``g`` frames and grown ``g`` times
    as much, up to a gap of a second (``payload["frame_rate"]`` frames, 30 without
    it); a frame whose boxes are exactly those of the previous one is the same
    picture again (a camera's flat-field freeze): its boxes keep their identities,
    and the next new picture is linked across the time since that picture was
    first shown.

    Parameters
    ----------
    records : sequence of FrameRecord
    y : sequence of array-like of shape (k_i, 4)

    Returns
    -------
    gt : DataFrame with columns tour, frame, id, bb_left, bb_top, bb_width, bb_height
    """
    from tunnelsense._streaming import tour_groups

    records = list(records)
    y = [np.asarray(b, dtype=np.float64).reshape(-1, 4) for b in y]
    if len(y) != len(records):
        raise ValueError(f"y has {len(y)} entries for {len(records)} frames")
    grow = 0.5
    rows = []
    for group in tour_groups(records):
        next_id = 1
        prev_frame, prev_boxes, prev_ids = None, np.empty((0, 4)), []
        before = {}  # id -> (its box, frame) in the picture before the previous one
        for i in group.tolist():
            r, b = records[i], y[i]
            if (prev_frame is not None and len(b) and b.shape == prev_boxes.shape
                    and np.array_equal(b, prev_boxes)):
                # the same picture again (a camera's flat-field freeze): the same
                # indicators, and no new position
                rows.extend((r.tour, r.frame, pid, *box.tolist())
                            for box, pid in zip(b, prev_ids, strict=True))
                continue
            ids = []
            used = set()
            gap = None if prev_frame is None else r.frame - prev_frame
            rate = r.payload.get(FRAME_RATE) or 30.0
            linkable = gap is not None and 1 <= gap <= max(rate, 1.0)
            for box in b:
                link = None
                if linkable:
                    for pb, pid in zip(prev_boxes, prev_ids, strict=True):
                        if pid in used:
                            continue
                        # grow the previous box by half its size on every side: an
                        # indicator moves less than that between consecutive frames,
                        # also while it is clipped by the frame's edge
                        if _meets_grown(box, pb, grow * gap) or (
                            pid in before
                            and _meets_grown(box, _moved_on(pb, *before[pid],
                                                            prev_frame, gap),
                                             grow * gap)
                        ):
                            link = pid
                            break
                if link is None:
                    link = next_id
                    next_id += 1
                used.add(link)
                ids.append(link)
                rows.append((r.tour, r.frame, link, *box.tolist()))
            before = (
                {pid: (pb, prev_frame)
                 for pb, pid in zip(prev_boxes, prev_ids, strict=True)}
                if linkable else {}
            )
            prev_frame, prev_boxes, prev_ids = r.frame, b, ids
    return pd.DataFrame(rows, columns=list(_GT_COLUMNS)).astype(
        {"frame": np.int64, "id": np.int64}
    )


def _moved_on(pb, bb, bb_frame, pb_frame, gap):
    """Box ``pb`` (at ``pb_frame``) moved on ``gap`` frames at the velocity of its
    last change, from ``bb`` at ``bb_frame`` (constant velocity)."""
    if gap == 1 and pb_frame - bb_frame == 1:
        return 2 * pb - bb
    return pb + (pb - bb) * (gap / (pb_frame - bb_frame))


def _meets_grown(box, pb, grow):
    """Whether ``box`` overlaps ``pb`` grown by ``grow`` times its size on every
    side (boxes ``(left, top, width, height)``)."""
    gx, gy = grow * abs(pb[2]), grow * abs(pb[3])
    ix = min(box[0] + box[2], pb[0] + pb[2] + gx) - max(box[0], pb[0] - gx)
    iy = min(box[1] + box[3], pb[1] + pb[3] + gy) - max(box[1], pb[1] - gy)
    return ix > 0 and iy > 0


def _match(hyp: pd.DataFrame, gt: pd.DataFrame, min_height: float):
    """Per hypothesis: matched gt id (or -1) and whether that box counts."""
    n = len(hyp)
    gt_id = np.full(n, -1, dtype=np.int64)
    counted = np.zeros(n, dtype=bool)
    if n == 0 or len(gt) == 0:
        return gt_id, counted
    cx = (hyp["bb_left"] + hyp["bb_width"] / 2).to_numpy()
    cy = (hyp["bb_top"] + hyp["bb_height"] / 2).to_numpy()
    g = gt.groupby(["tour", "frame"], sort=False).indices
    keys = list(zip(hyp["tour"].to_numpy(), hyp["frame"].to_numpy(), strict=True))
    gl, gtp = gt["bb_left"].to_numpy(), gt["bb_top"].to_numpy()
    gw, gh = gt["bb_width"].to_numpy(), gt["bb_height"].to_numpy()
    gid = gt["id"].to_numpy()
    for j, key in enumerate(keys):
        idx = g.get(key)
        if idx is None:
            continue
        boxes = np.column_stack((gl[idx], gtp[idx], gw[idx], gh[idx]))
        inside = inside_boxes([cx[j]], [cy[j]], boxes)[0]
        if inside.any():
            hits = idx[inside]
            big = hits[gh[hits] >= min_height]
            k = big[0] if len(big) else hits[0]
            gt_id[j] = gid[k]
            counted[j] = gh[k] >= min_height
    return gt_id, counted


def tunnel_scores(hypotheses, gt, *, min_height=14.0, complete=True) -> dict:
    """The cluster-level table and trajectory-level figures of the FIR detector.

    Parameters
    ----------
    hypotheses : DataFrame
        One row per keypoint cluster (:data:`HYPOTHESIS_COLUMNS`;
        :func:`hypotheses_from_records`).
    gt : DataFrame
        Indicator boxes with identities: columns tour, frame, id, bb_left, bb_top,
        bb_width, bb_height (and optionally ``class``: only class 1 is used).
    min_height : float, default=14.0
        Indicator boxes at least this tall count; smaller ones are don't-care.
    complete : bool, default=True
        Whether ``hypotheses`` holds every cluster (negatives too).  When it holds
        only the detections (a MOTChallenge results file), the number of negatives is
        unknown and ``false_alarm_rate`` is ``None``.

    Returns
    -------
    scores : dict
        ``{"cluster": {"total", "correct", "misses", "false_alarms",
        "detection_rate", "false_alarm_rate"}, "trajectory": {"indicators",
        "detected", "false_alarms", "detection_rate"}}`` (rates in [0, 1]; a rate
        with a zero denominator -- nothing to detect, no negative -- is ``None``:
        0 of 0 is no evidence either way).

    Examples
    --------
    >>> import pandas as pd
    >>> gt = pd.DataFrame({"tour": ["t", "t"], "frame": [1, 2], "id": [1, 1],
    ...     "bb_left": [10., 12], "bb_top": [10., 10], "bb_width": [10., 10],
    ...     "bb_height": [20., 20]})
    >>> hyp = pd.DataFrame({"tour": ["t"] * 3, "frame": [1, 2, 2], "track_id": [1, 1, 2],
    ...     "bb_left": [12., 14, 100], "bb_top": [12., 12, 100], "bb_width": [4., 4, 4],
    ...     "bb_height": [14., 14, 4], "indicator": [True, False, False],
    ...     "trajectory_positive": [True, True, False]})
    >>> s = tunnel_scores(hyp, gt)
    >>> s["cluster"]["total"], s["cluster"]["correct"], s["cluster"]["detection_rate"]
    (2, 1, 0.5)
    >>> s["trajectory"]
    {'indicators': 1, 'detected': 1, 'false_alarms': 0, 'detection_rate': 1.0}
    """
    hyp = hypotheses.reset_index(drop=True)
    if "class" in gt.columns:
        gt = gt[gt["class"] == 1]
    if "tour" not in gt.columns:
        raise ValueError("gt needs a 'tour' column naming the tour of every box")
    gt = gt.reset_index(drop=True)
    gt_id, counted = _match(hyp, gt, float(min_height))
    labelled = hyp["indicator"].to_numpy(dtype=bool)
    on_indicator = gt_id >= 0
    total = int(counted.sum())
    correct = int((counted & labelled).sum())
    negatives = ~on_indicator
    false_alarms = int((negatives & labelled).sum())
    n_neg = int(negatives.sum())
    cluster = {
        "total": total,
        "correct": correct,
        "misses": total - correct,
        "false_alarms": false_alarms,
        "detection_rate": correct / total if total else None,
        "false_alarm_rate": false_alarms / n_neg if n_neg and complete else None,
    }
    # trajectory level
    big = gt[gt["bb_height"] >= min_height]
    indicators = set(zip(big["tour"], big["id"], strict=True))
    pos = hyp["trajectory_positive"].to_numpy(dtype=bool)
    detected, fa = set(), 0
    if pos.any():
        sub = pd.DataFrame(
            {
                "tour": hyp["tour"].to_numpy()[pos],
                "track": hyp["track_id"].to_numpy()[pos],
                "gid": gt_id[pos],
            }
        )
        for (tour, _), g in sub.groupby(["tour", "track"], sort=False):
            ids = g["gid"].to_numpy()
            on = ids[ids >= 0]
            if 2 * len(on) < len(ids):
                fa += 1
                continue
            values, counts = np.unique(on, return_counts=True)
            detected.add((tour, int(values[np.argmax(counts)])))
    n_ind = len(indicators)
    hit = len(detected & indicators)
    trajectory = {
        "indicators": n_ind,
        "detected": hit,
        "false_alarms": fa,
        "detection_rate": hit / n_ind if n_ind else None,
    }
    return {"cluster": cluster, "trajectory": trajectory}


def indicator_scores(records, y, *, min_height=14.0) -> dict:
    """:func:`tunnel_scores` of the detector's output records against per-frame boxes.

    Parameters
    ----------
    records : sequence of FrameRecord
        The output of the indicator pipeline's ``predict``.
    y : sequence of array-like of shape (k_i, 4)
        Per frame, the indicator boxes (:func:`tunnelsense.to_xy`).
    min_height : float, default=14.0

    Returns
    -------
    scores : dict (see :func:`tunnel_scores`)
    """
    records = list(records)
    return tunnel_scores(
        hypotheses_from_records(records), gt_from_boxes(records, y), min_height=min_height
    )
