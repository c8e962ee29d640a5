"""Keypoint cluster verification by motion and object detection (sections 3.6-3.7).

An indicator on the tunnel wall moves, frame after frame, along a straight image line
away from the vanishing point; vehicles ahead and their warm road patches stay nearly
still or wander.  Each trajectory is fitted with a straight line ``y = a0 + a1 x`` and
the Pearson correlation coefficient ``r`` of the fit (eq. 5) decides.  A keypoint
cluster is an indicator iff its appearance label is positive, its trajectory is at
least ``min_length`` long and ``|r| >= min_r``; a trajectory is positive when more
than ``vote`` (80 %) of the decisions it connects are positive.
"""

from __future__ import annotations

import numbers

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin, _fit_context
from sklearn.utils._param_validation import Interval
from sklearn.utils.validation import check_is_fitted

from tunnelsense._records import FrameSequence, check_frames
from tunnelsense.tunnel._appearance import boxes_of

__all__ = ["PCCVerifier", "pearson_r", "trajectory_r"]

#: Columns of ``payload["detections"]``.
DETECTION_COLUMNS = ("bb_left", "bb_top", "bb_width", "bb_height", "track_id", "score")


def pearson_r(x, y) -> float:
    """Pearson correlation coefficient of the points ``(x_i, y_i)`` (eq. 5).

    0 when either coordinate does not vary (a still cluster has no line; fewer than
    two distinct positions).

    Examples
    --------
    >>> pearson_r([0, 1, 2, 3], [5, 3, 1, -1])
    -1.0
    >>> pearson_r([1, 1, 1], [0, 1, 2])
    0.0
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    x = x - x.mean()
    y = y - y.mean()
    sxx, syy = float(x @ x), float(y @ y)
    scale = max(sxx, syy, 1.0)
    if sxx <= 1e-12 * scale or syy <= 1e-12 * scale:
        return 0.0
    return float(np.clip((x @ y) / np.sqrt(sxx * syy), -1.0, 1.0))


def trajectory_r(x, y, starts) -> np.ndarray:
    """Pearson r of every trajectory, for points grouped in consecutive segments.

    Parameters
    ----------
    x, y : ndarray of shape (n,)
        Positions, trajectory after trajectory.
    starts : ndarray of shape (n_trajectories,)
        Index of the first point of each trajectory (ascending, ``starts[0] == 0``).

    Returns
    -------
    r : ndarray of shape (n_trajectories,)
        As :func:`pearson_r` of each segment.
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    n = np.diff(np.append(starts, len(x)))
    if len(x) == 0:
        return np.zeros(0)
    seg = np.repeat(np.arange(len(starts)), n)
    xm = np.add.reduceat(x, starts) / n
    ym = np.add.reduceat(y, starts) / n
    dx = x - xm[seg]
    dy = y - ym[seg]
    sxx = np.add.reduceat(dx * dx, starts)
    syy = np.add.reduceat(dy * dy, starts)
    sxy = np.add.reduceat(dx * dy, starts)
    scale = np.maximum(np.maximum(sxx, syy), 1.0)
    ok = (sxx > 1e-12 * scale) & (syy > 1e-12 * scale)
    r = np.zeros(len(starts))
    r[ok] = np.clip(sxy[ok] / np.sqrt(sxx[ok] * syy[ok]), -1.0, 1.0)
    return r


def _payload(record, index, key, m, stage, before):
    try:
        value = np.asarray(record.payload[key])
    except KeyError:
        raise ValueError(
            f"X[{index}] ({record.tour!r}, frame {record.frame}) has no "
            f"payload[{key!r}]: {stage} needs frame records that went through "
            f"{before} first"
        ) from None
    if value.shape != (m,):
        raise ValueError(
            f"X[{index}] ({record.tour!r}, frame {record.frame}): payload[{key!r}] "
            f"must have shape ({m},), one entry per cluster; got shape {value.shape}"
        )
    return value


class PCCVerifier(TransformerMixin, BaseEstimator):
    """Verify trajectories by straight-line motion; give the detections (3.6-3.7).

    Stage 6, the last one, of the FIR indicator detector: a frame stage with nothing
    to learn (its thresholds are hyperparameters, for :class:`~sklearn.model_selection.GridSearchCV`).
    It reads, per frame, the clusters' rectangles (``payload["cluster_boxes"]``),
    appearance labels (``payload["appearance"]``) and trajectories
    (``payload["track_ids"]``), gathers every trajectory of every tour, and fits a
    straight line through the centres of its rectangles.

    A cluster is an **indicator** iff its appearance label is positive, its
    trajectory has at least ``min_length`` clusters and ``|r| >= min_r``.  The
    decision uses the whole trajectory, so it is final once the trajectory has ended
    (an online system reports it with that delay).  A **trajectory is positive** when
    more than ``vote`` of its clusters are indicators.  The detections are the clusters
    of positive trajectories -- every one of them, so that a wrong decision on one frame
    is recovered by the others, as the paper puts it.

    ``predict`` (and ``transform``, the same) return the frames in input order, each
    evolved with

    * ``payload["motion_r"]``: (m,) float64 -- Pearson r of each cluster's trajectory;
    * ``payload["trajectory_length"]``: (m,) int64 -- its number of clusters;
    * ``payload["indicator"]``: (m,) bool -- the per-cluster decision (the paper's
      Table 1 is measured on it);
    * ``payload["trajectory_positive"]``: (m,) bool -- whether the cluster's
      trajectory is positive by the vote;
    * ``payload["detections"]``: (k, 6) float64 -- one row per detection,
      ``(bb_left, bb_top, bb_width, bb_height, track_id, score)``, where ``score`` is
      the fraction of the trajectory's clusters that are indicators (> ``vote``).

    Parameters
    ----------
    min_r : float, default=0.95
        Smallest ``|r|`` of an indicator's trajectory.  An indicator moves along a
        straight line through the vanishing point over tens to hundreds of pixels,
        so its centres fit a line with ``|r|`` close to 1 (0.99 and more on simulated
        tours, where the keypoint grid quantizes the centres by up to 3 px); a vehicle
        ahead at nearly constant distance jitters by a few pixels in both directions
        and gets ``|r|`` far from 1.
    min_length : int, default=10
        Fewest clusters of an indicator's trajectory: a third of a second at 30 fps.
        An indicator stays in view for well over a second at motorway speed, while
        a chance alignment of a few jittering positions gives a high ``|r|``
        only on short trajectories.
    vote : float, default=0.8
        A trajectory is positive when more than this fraction of its clusters are
        indicators (the paper's 80 %).

    Attributes
    ----------
    n_frames_fit_ : int
        Number of frames seen by ``fit``.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import FrameRecord
    >>> from tunnelsense.tunnel import PCCVerifier
    >>> img = np.zeros((48, 64), np.uint8)
    >>> X = [FrameRecord("t", f, img, {"cluster_boxes": np.array([[40. - 3 * f, 30 - f, 4, 8]]),
    ...      "appearance": np.array([True]), "track_ids": np.array([1])}) for f in range(1, 13)]
    >>> out = PCCVerifier().fit(X).predict(X)
    >>> out[0].payload["detections"]
    array([[37., 29.,  4.,  8.,  1.,  1.]])
    """

    _parameter_constraints: dict = {
        "min_r": [Interval(numbers.Real, 0, 1, closed="both")],
        "min_length": [Interval(numbers.Integral, 1, None, closed="left")],
        "vote": [Interval(numbers.Real, 0, 1, closed="left")],
    }

    def __init__(self, *, min_r=0.95, min_length=10, vote=0.8):
        self.min_r = min_r
        self.min_length = min_length
        self.vote = vote

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.two_d_array = False
        tags.transformer_tags.preserves_dtype = []
        return tags

    def _gather(self, records):
        boxes, app, tracks = [], [], []
        for i, r in enumerate(records):
            b = boxes_of(r, i, "PCCVerifier")
            m = len(b)
            boxes.append(b)
            app.append(_payload(r, i, "appearance", m, "PCCVerifier", "WeightedAdaBoost").astype(bool))
            tracks.append(
                _payload(r, i, "track_ids", m, "PCCVerifier", "TrajectoryLinker").astype(np.int64)
            )
        return boxes, app, tracks

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y=None):
        """Validate the frames (nothing is learned).

        Parameters
        ----------
        X : sequence of FrameRecord
            Frames with ``cluster_boxes``, ``appearance`` and ``track_ids``.
        y : ignored (per-frame boxes are validated if given)

        Returns
        -------
        self : PCCVerifier
        """
        records, _ = check_frames(X, y)
        self._gather(records)
        self.n_frames_fit_ = len(records)
        return self

    def predict(self, X):
        """Label every cluster and trajectory; give each frame's detections.

        Parameters
        ----------
        X : sequence of FrameRecord

        Returns
        -------
        X_new : FrameSequence
            The frames in input order, evolved as the class docstring says.
        """
        check_is_fitted(self)
        records, _ = check_frames(X)
        boxes, app, tracks = self._gather(records)
        counts = np.fromiter((len(b) for b in boxes), np.intp, len(boxes))
        n = int(counts.sum())
        if n == 0:
            empty = np.empty(0)
            return FrameSequence(
                r.evolve(
                    motion_r=empty,
                    trajectory_length=np.empty(0, np.int64),
                    indicator=np.empty(0, bool),
                    trajectory_positive=np.empty(0, bool),
                    detections=np.empty((0, 6)),
                )
                for r in records
            )
        B = np.concatenate(boxes)
        A = np.concatenate(app)
        T = np.concatenate(tracks)
        rec = np.repeat(np.arange(len(records)), counts)
        tour_names = {}
        tour = np.fromiter(
            (tour_names.setdefault(records[i].tour, len(tour_names)) for i in rec.tolist()),
            np.int64, n,
        )
        frame = np.fromiter((records[i].frame for i in rec.tolist()), np.int64, n)
        order = np.lexsort((frame, T, tour))
        key_t, key_k = tour[order], T[order]
        new = np.ones(n, bool)
        new[1:] = (key_t[1:] != key_t[:-1]) | (key_k[1:] != key_k[:-1])
        starts = np.flatnonzero(new)
        seg = np.cumsum(new) - 1
        lengths = np.diff(np.append(starts, n))
        cx = B[order, 0] + B[order, 2] / 2
        cy = B[order, 1] + B[order, 3] / 2
        r_traj = trajectory_r(cx, cy, starts)
        motion_ok = (lengths >= self.min_length) & (np.abs(r_traj) >= self.min_r)
        indicator_sorted = A[order] & motion_ok[seg]
        fraction = np.add.reduceat(indicator_sorted.astype(np.float64), starts) / lengths
        positive = fraction > self.vote
        # back to input order
        inv = np.empty(n, np.intp)
        inv[order] = np.arange(n)
        seg_in = seg[inv]
        r_in = r_traj[seg_in]
        len_in = lengths[seg_in]
        ind_in = indicator_sorted[inv]
        pos_in = positive[seg_in]
        frac_in = fraction[seg_in]
        out = []
        bounds = np.append(0, np.cumsum(counts))
        for i, r in enumerate(records):
            lo, hi = bounds[i], bounds[i + 1]
            keep = pos_in[lo:hi]
            det = np.column_stack(
                [boxes[i][keep], tracks[i][keep].astype(np.float64), frac_in[lo:hi][keep]]
            )
            out.append(
                r.evolve(
                    motion_r=r_in[lo:hi],
                    trajectory_length=len_in[lo:hi].astype(np.int64),
                    indicator=ind_in[lo:hi],
                    trajectory_positive=keep,
                    detections=det,
                )
            )
        return FrameSequence(out)

    def transform(self, X):
        """The same as :meth:`predict` (so that the stage can sit anywhere)."""
        return self.predict(X)
