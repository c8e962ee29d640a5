"""Keypoint cluster verification by motion and object detection (sections 3.6-3.7).

An indicator on the tunnel wall moves, frame after frame, along a straight image line
away from the vanishing point; vehicles ahead and their warm road patches stay nearly
still or wander.  Each trajectory is fitted with a straight line ``y = a0 + a1 x`` and
the Pearson correlation coefficient ``r`` of the fit (eq. 5) decides.  A keypoint
cluster is an indicator iff its appearance label is positive, its trajectory is at
least ``min_length`` long (or, optionally, shorter but showing an approach of
``min_approach``), ``|r| >= min_r`` (or, optionally, its rectangles show a steady
approach, ``min_scale_r``; and, optionally, it travels at least ``min_travel`` times
its own size, its path traces back near the frame's middle,
``max_focus_offset``, and it does not head for the middle from far off,
``max_inward_offset``); a trajectory is positive when more than ``vote`` (80 %) of the
decisions it connects are positive.  The path measures are in
:mod:`tunnelsense.tunnel._pcc_measures`, the stream state in
:mod:`tunnelsense.tunnel._pcc_stream`.
"""

from __future__ import annotations

import numbers

from sklearn.base import BaseEstimator, TransformerMixin

from tunnelsense._payload import (
    APPEARANCE,
    CLUSTER_BOXES,
    CONTINUED_TRACKS,
    CUT_TRACKS,
    DETECTIONS,
    ENDED_TRACKS,
    INDICATOR,
    MOTION_R,
    TRACK_IDS,
    TRAJECTORY_LENGTH,
    TRAJECTORY_POSITIVE,
)
from tunnelsense._records import FrameSequence, check_frames
from tunnelsense._streaming import StreamingMixin
from tunnelsense.tunnel._pcc_stream import (
    PCCStream,
    curve_fit_r,
    focus_offset,
    frame_payload,
    motion_fit_r,
    pearson_r,
    straightness,
)
from tunnelsense.utils._sklearn_compat import Interval, StrOptions, _fit_context

__all__ = ["PCCVerifier", "curve_fit_r", "focus_offset", "motion_fit_r", "pearson_r",
           "straightness"]


class PCCVerifier(StreamingMixin, TransformerMixin, BaseEstimator):
    """Verify trajectories by straight-line motion; give the detections (3.6-3.7).

    Stage 6, the last one, of the FIR indicator detector: a frame stage with nothing
    to learn (its thresholds are hyperparameters, for :class:`~sklearn.model_selection.GridSearchCV`).
    It reads, per frame, the clusters' rectangles (``payload["cluster_boxes"]``),
    appearance labels (``payload["appearance"]``) and trajectories
    (``payload["track_ids"]``), gathers each trajectory of each tour, and, when the
    trajectory ends (``payload["ended_tracks"]`` of :class:`TrajectoryLinker`, or the
    end of its tour), fits a straight line through the centres of its rectangles.
    ``predict`` runs the same state machine over each tour, in frame order, as
    :meth:`start_stream` does online, so both give identical results.

    A cluster is an **indicator** iff its appearance label is positive, its
    trajectory has at least ``min_length`` clusters and ``|r| >= min_r`` (or, with
    ``min_scale_r``, a steady approach; with ``max_focus_offset``, its path's line
    must also pass near the frame's centre; with ``max_inward_offset``, it must
    not head for the centre from far off).  The
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
        so its centres fit a line with ``|r|`` close to 1; a vehicle ahead at nearly
        constant distance jitters by a few pixels in both directions and gets
        ``|r|`` far from 1.
    min_length : int, default=10
        Fewest clusters of an indicator's trajectory, in frames at ``frame_rate``:
        a third of a second at 30 fps.  An indicator stays in view for well over a
        second at motorway speed, while a chance alignment of a few jittering
        positions gives a high ``|r|`` only on short trajectories.  See
        ``min_approach`` for shorter trajectories of a near, fast approach.
    vote : float, default=0.8
        A trajectory is positive when more than this fraction of its clusters are
        indicators (the paper's 80 %).
    min_travel : float, default=0.0
        Least travel of an indicator's trajectory in units of its own size
        (:func:`~tunnelsense.tunnel._pcc_measures.path_travel`: the distance between
        the mean centres of its first and last thirds over its median rectangle
        height); 0, the paper's, checks nothing.  A sign the camera approaches moves
        away from the vanishing point as it grows; a bright object that keeps its
        place in the image (the far end of a curving row of lamps, which the view
        follows) only jitters, however well the jitter fits a path.  A ratio of
        lengths in the image, so it holds at any resolution and focal length.
    min_approach : float or None, default=None
        Least fraction of its range the camera covers towards the object of a
        trajectory shorter than ``min_length`` (after scaling to the tour's frame
        rate) for it to count as long enough:
        :func:`~tunnelsense.tunnel._pcc_measures.approach_fraction`, ``1 - h_first /
        h_last`` of its rectangle heights (medians of its first and last thirds),
        which is ``(Z_first - Z_last) / Z_first`` for an object of fixed size at
        range ``Z``.  Such a trajectory still needs at least 7 points (or
        ``min_length`` when smaller): on fewer a chance alignment of jittering
        positions passes the straightness test too easily.  What tells a sign
        from a chance alignment is how far the camera approached it, not how many
        frames it took: a sign first seen near, at high speed, leaves the image
        within fewer than ``min_length`` frames while its rectangle doubles.  A unit
        of the data (a ratio of heights), the same at any focal length, resolution,
        sign size and frame rate.  ``None``, the paper's rule, accepts no
        trajectory shorter than ``min_length``.
    criterion : {"pearson", "principal", "quadratic", "quadratic-motion"}, \
            default="pearson"
        The path measure compared with ``min_r``: ``"pearson"`` is ``|r|`` of
        eq. 5 (the paper); ``"principal"`` is :func:`straightness`, which does not
        depend on the line's direction. Pearson's r is 0 for a perfectly horizontal
        or vertical line and low for a nearly horizontal one, so a camera mounted
        near the indicators' height (on a truck or bus), which sees them move almost
        horizontally, needs ``"principal"``.  ``"quadratic"`` is :func:`curve_fit_r`,
        the multiple correlation of a quadratic path (Pearson's r generalized from
        a line to a parabola): in a curving tunnel the vanishing point moves towards
        the curve's inside as the road turns, and an indicator's image path bends,
        which a straight line fits ever worse the longer the trajectory; a
        quadratic follows the bend, while a vehicle ahead jittering in place or
        drifting up and down the image still fits no path.  ``"quadratic-motion"``
        is the larger of :func:`curve_fit_r` and :func:`motion_fit_r`, the
        multiple correlation of both coordinates fitted by quadratics in time: a
        trajectory that covers only a short, nearly horizontal stretch of a path (a
        far sign, or one cut by the start or end of the stream) has a vertical
        spread that the camera's body pitch, a pixel or so up and down, swamps, so
        no function ``y(x)`` fits it, while its motion in time is smooth; a
        cluster jittering in place fits neither.  ``payload["motion_r"]`` holds the
        chosen measure (signed r for ``"pearson"``).
    min_scale_r : float or None, default=None
        A trajectory whose path measure falls short of ``min_r`` still passes
        the motion check when its object approaches steadily:
        :func:`~tunnelsense.tunnel._pcc_measures.approach_r` (minus Pearson's r
        between time and the inverse rectangle height, which is proportional to
        the object's range) at least this.  A vibrating camera moves every image
        point by the same small angle, independently from frame to frame: a far
        sign's positions scatter by a few pixels about its path, which its
        trajectory then fits poorly, while its size, which no rotation of the
        camera changes, still grows as the camera approaches.  ``min_length`` (or
        ``min_approach``), ``min_travel`` and the vote still apply, and
        ``payload["motion_r"]`` still holds the path measure (below ``min_r`` for
        a trajectory this passes).  In (0, 1].  A ratio of sizes, the same at any
        resolution.  ``None``, the paper's rule, checks the path alone.
    max_focus_offset : float or None, default=None
        Largest distance from the frame's centre at which the line of a
        trajectory's centres may pass, in units of half the frame's width and
        height (:func:`~tunnelsense.tunnel._pcc_measures.focus_offset`: the
        principal axis of its centres; 0 at the centre, 1 on the border).  An
        object the camera approaches moves away from the focus of expansion, along
        a line through it, so its line passes the centre at about the focus's own
        offset: ``f tan(yaw) / (W / 2)`` across and ``f tan(pitch) / (H / 2)`` up
        and down for a lens of ``f`` pixels on a ``W x H`` frame (a curve or a
        crest turns the camera and slides every point alike).  A mark burned into
        the picture (a grey-scale bar, a clock's text) keeps its place while its
        thresholded rectangle grows and shrinks with the frame's grey levels: its
        centres slide along the mark, whose line passes the centre at the mark's
        own offset, near the border.  A far sign's path is short and noisy, but
        the sign is near the focus, so any line through it passes near the
        centre.  A limit ``m`` rejects the signs of a camera pointing more than
        ``atan(m W / (2 f))`` off the direction of travel across, ``atan(m H /
        (2 f))`` up or down; 0.8 (the default detector's): 20.1 and 15.3 degrees
        with a 700 px lens at 640 x 480, 9.7 and 7.3 degrees with 1500 px.
        ``min_length`` (or ``min_approach``), ``min_r`` (or ``min_scale_r``),
        ``min_travel`` and the vote still apply.  ``None`` checks nothing.  The
        frame's size is read from the first frame of each tour (an image file is
        decoded for it when no stage before has).
    max_inward_offset : float or None, default=None
        Largest distance from the frame's centre, in units of half the frame's
        width and height, at which a trajectory heading for the centre may still
        be an indicator
        (:func:`~tunnelsense.tunnel._pcc_measures.inward_offset`: its mean centre
        projected on its direction of motion, from its first third to its last,
        negated).  An object the camera approaches grows and moves away from the
        focus of expansion; a vehicle ahead that pulls away (its warm wheels,
        exhaust or lights) shrinks toward it, along as straight a line through
        the focus, and travels as far, as a sign does.  Relative to a focus ``F``
        an approached object's inward offset is below ``|F|``, the focus's own
        offset from the centre (the camera's yaw and pitch), whatever its speed:
        a sign seen from a crawling queue heads outward as surely, only more
        slowly; a sign the camera backs away from heads inward and is refused.
        A limit ``m`` refuses no sign of a camera pointing less than ``atan(m W
        / (2 f))`` off the direction of travel across and ``atan(m H / (2 f))``
        up or down; 0.3 (the default detector's): 7.8 and 5.9 degrees with a 700
        px lens at 640 x 480 (3.7 and 2.8 with 1500 px); a vehicle's part pulling
        away is refused unless it stays that near the centre.  Only a trajectory
        that does not grow (:func:`~tunnelsense.tunnel._pcc_measures.grows`) is
        refused: on a sharp curve the camera turns, and a far sign on the inside
        of the curve drifts toward the centre (0.44 for a 1 m sign 90 m ahead on
        a 300 m radius, 700 px lens) while it grows.
        Near the centre nothing is refused: a far sign's short path may point
        anywhere there.  A ratio of lengths in the image, the same at any
        resolution, frame rate and speed; the other checks still apply.
        ``None`` checks nothing.  The frame's size is read from the first frame
        of each tour.
    carry_travel : float or None, default=None
        A trajectory that continues one the linker cut at its ``max_track_length``
        (``payload["continued_tracks"]`` of :class:`TrajectoryLinker`) and fails the
        motion check on its own path is checked again on the path it continues:
        the earlier pieces' positions (at most as many as its longest piece holds),
        then its own -- provided it itself travels along that path at least this
        many times its own size
        (:func:`~tunnelsense.tunnel._pcc_stream.carried_travel`).  The linker ends
        a trajectory after ``max_track_length`` frames, a time: at highway speed
        that holds a sign's whole approach, in a queue a short stretch of it, over
        which a far sign moves a fraction of its height against a pixel of jitter
        and the path measure falls around ``min_r``; joined to the stretch before,
        the path is longer by the object's own motion.  A piece that did not move
        (a queue standing still) is not accepted because an earlier piece moved.
        Each piece is still decided when it ends, so the delay and memory of
        online detection stay bounded.  ``min_length`` (or ``min_approach``),
        ``min_r`` (or ``min_scale_r``), ``min_travel`` and ``max_focus_offset`` apply
        to the joined path, the vote to the piece.  A ratio of lengths, the same at
        any resolution.  ``None`` checks every piece on its own.
    frame_rate : float or None, default=30.0
        The frame rate (frames per second) ``min_length`` is counted in.  A tour's
        frames carry its frame rate (``payload["frame_rate"]``, set by
        :class:`~tunnelsense.Tour`), and on a tour at ``f`` fps ``min_length`` is
        scaled by ``f / frame_rate`` (rounded half up), so it keeps its duration
        (10 frames at 30 fps are 20 at 60 fps) -- but scaled down it stays at least
        7 (or ``min_length`` itself when smaller): on fewer points a chance
        alignment of jittering positions passes the straightness test too easily.
        Frames without a frame rate (made from a user's arrays) count as being at
        ``frame_rate``; ``None`` counts frames whatever the tour's rate.  A tour's
        rate is that of its first frame.

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
        "criterion": [StrOptions({"pearson", "principal", "quadratic", "quadratic-motion"})],
        "min_travel": [Interval(numbers.Real, 0, None, closed="left")],
        "min_approach": [Interval(numbers.Real, 0, 1, closed="neither"), None],
        "frame_rate": [Interval(numbers.Real, 0, None, closed="neither"), None],
        "min_scale_r": [Interval(numbers.Real, 0, 1, closed="right"), None],
        "max_focus_offset": [Interval(numbers.Real, 0, None, closed="left"), None],
        "max_inward_offset": [Interval(numbers.Real, 0, None, closed="left"), None],
        "carry_travel": [Interval(numbers.Real, 0, None, closed="left"), None],
    }

    def __init__(self, *, min_r=0.95, min_length=10, vote=0.8, criterion="pearson",
                 min_travel=0.0, min_approach=None, min_scale_r=None,
                 max_focus_offset=None, max_inward_offset=None, carry_travel=None,
                 frame_rate=30.0):
        self.frame_rate = frame_rate
        self.carry_travel = carry_travel
        self.max_inward_offset = max_inward_offset
        self.max_focus_offset = max_focus_offset
        self.min_scale_r = min_scale_r
        self.min_approach = min_approach
        self.min_travel = min_travel
        self.min_r = min_r
        self.min_length = min_length
        self.vote = vote
        self.criterion = criterion

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.two_d_array = False
        tags.transformer_tags.preserves_dtype = []
        return tags

    _sequence = FrameSequence
    _payload_reads = (CLUSTER_BOXES, APPEARANCE, TRACK_IDS)
    _payload_optional = (ENDED_TRACKS, CUT_TRACKS, CONTINUED_TRACKS)
    _payload_adds = (MOTION_R, TRAJECTORY_LENGTH, INDICATOR, TRAJECTORY_POSITIVE, DETECTIONS)

    def _check_records(self, X, y=None):
        records, _ = check_frames(X, y)
        for i, r in enumerate(records):
            frame_payload(r, i)
        return records

    def _stream_state(self, *, batch=False):
        return PCCStream(self, release=not batch)

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
        records = self._check_records(X, y)
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
        return self.transform(X)

    def start_stream(self):
        """Verify frames online, one at a time (the streaming protocol).

        Returns
        -------
        state : object
            ``state.push(record)`` takes the next frame (frames of a tour in
            increasing order; a record of another tour ends every trajectory of the
            previous one) and returns the frames whose decisions are final, in input
            order, evolved as :meth:`predict` does; ``state.close()`` ends every
            trajectory and returns the frames still held.  A frame is final when
            every trajectory through it has ended (``payload["ended_tracks"]`` of
            :class:`TrajectoryLinker`): with the linker's ``max_track_length`` of
            ``L`` frames, a frame is released at most ``L - 1`` frames after it
            arrived, and at most ``L`` frames are held.  Held frames keep their
            payload arrays only: an in-memory image is released (reading ``.image``
            of the returned record then raises); a lazy source (an image file) is
            kept.  ``state.n_waiting`` is the number of frames held.  Frames
            without ``payload["ended_tracks"]`` (not from :class:`TrajectoryLinker`)
            end their trajectories only with the tour: the state then holds the
            whole tour.

        Examples
        --------
        >>> import numpy as np
        >>> from tunnelsense import FrameRecord
        >>> from tunnelsense.tunnel import PCCVerifier
        >>> img = np.zeros((48, 64), np.uint8)
        >>> def frame(f, ended=()):
        ...     return FrameRecord("t", f, img, {"cluster_boxes": np.array([[40. - 3 * f, 30 - f, 4, 8]]),
        ...         "appearance": np.array([True]), "track_ids": np.array([1]),
        ...         "ended_tracks": np.array(ended, np.int64)})
        >>> state = PCCVerifier(min_length=3).fit([frame(1)]).start_stream()
        >>> [len(state.push(frame(f))) for f in (1, 2)]
        [0, 0]
        >>> out = state.push(frame(3, ended=[1]))  # trajectory 1 ends: three frames final
        >>> [(r.frame, r.payload["detections"].shape) for r in out]
        [(1, (1, 6)), (2, (1, 6)), (3, (1, 6))]
        """
        return super().start_stream()
