"""Keypoint cluster tracking (section 3.5): online linking into trajectories.

A pool of trajectories is kept per tour; the keypoint clusters of each new frame are
the detection responses.  The link likelihood ``P_link(n | T)`` combines the distance
of the response from the position the trajectory's straight-line model predicts, the
scale change (at most ``max_scale_change``, 4 in the paper), the appearance difference
and the time gap; each trajectory links at most one response and each response at most
one trajectory.  The paper solves this assignment greedily (best pair first, until no
pair is left); the Hungarian algorithm is an option.  The math and the stream state
are in :mod:`tunnelsense.tunnel._linking`.
"""

from __future__ import annotations

import numbers

from sklearn.base import BaseEstimator, TransformerMixin

from tunnelsense._payload import (
    CLUSTER_BOXES,
    CLUSTER_HISTOGRAMS,
    CONTINUED_TRACKS,
    CUT_TRACKS,
    ENDED_TRACKS,
    TRACK_IDS,
    boxes_of,
    histograms_of,
)
from tunnelsense._records import FrameSequence, check_frames
from tunnelsense._streaming import StreamingMixin, stream_order
from tunnelsense.tunnel._linking import LinkerStream, link_log_likelihood
from tunnelsense.utils._sklearn_compat import Interval, StrOptions, _fit_context

__all__ = ["TrajectoryLinker", "link_log_likelihood"]


class TrajectoryLinker(StreamingMixin, TransformerMixin, BaseEstimator):
    """Link keypoint clusters of consecutive frames into trajectories (section 3.5).

    Stage 5 of the FIR indicator detector, a frame stage with nothing to learn.  The
    records are processed tour by tour in frame order (whatever order they come in);
    trajectories never cross a tour boundary, and a trajectory that has missed more
    than ``max_gap`` frames (in the tour's frame numbers, so a gap in the records
    counts) ends; so does a trajectory whose duration reaches ``max_track_length``
    frames (the next cluster on the same object starts a new trajectory).
    ``transform`` returns the frames in their input order, each evolved
    with

    * ``payload["track_ids"]``: ndarray of shape (m,), int64 -- the trajectory of
      every keypoint cluster of ``payload["cluster_boxes"]``, numbered 1, 2, ... per
      tour in order of birth;
    * ``payload["ended_tracks"]``: ndarray of int64 -- the trajectories that ended at
      this frame: they cannot link any later frame (they missed more than
      ``max_gap`` frames, or reached ``max_track_length``).  :class:`PCCVerifier`
      decides a trajectory as soon as it has ended, which bounds its memory when
      streaming.  Trajectories still alive at the end of a tour end with it;
    * ``payload["cut_tracks"]``: ndarray of int64 -- those of ``ended_tracks`` that
      reached ``max_track_length`` while their object could still be linked;
    * ``payload["continued_tracks"]``: ndarray of shape (k, 2), int64 -- rows
      ``(track_id, earlier_id)``: the trajectory ``track_id``, born at this frame,
      continues the cut trajectory ``earlier_id`` (its first response is the one the
      cut trajectory, kept as long as it could link, would have linked best); a row
      ``(0, earlier_id)`` when the cut trajectory can link no more.  The
      trajectories and their ids are those without these keys
      (:class:`PCCVerifier` reads them with ``carry_travel``).

    Each trajectory's per-frame appearance decisions stay with its clusters
    (``payload["appearance"]``), where :class:`PCCVerifier` reads them.

    The log-likelihood of linking a response to a trajectory is
    :func:`link_log_likelihood`: position (distance from the position predicted by a
    straight-line fit, in time, of the trajectory's last ``history`` positions), scale
    (at most ``max_scale_change``), appearance (the clusters' histograms,
    ``payload["cluster_histograms"]`` from :class:`WeightedAdaBoost`, when present) and
    time gap.  Distances are measured relative to the cluster's size, as everything in
    the image grows as it approaches.

    Parameters
    ----------
    max_gap : int, default=3
        Largest number of consecutive frames a trajectory may miss and still link.
    max_gap_travel : float or None, default=None
        A trajectory that missed more than ``max_gap`` frames may still link while
        the straight-line fit of its last ``history`` positions (at least three)
        moves it, from its last response, by at most this many times its size: a
        gap measured in the object's own motion rather than in frames.  The keypoint
        grid misses a far, small object while it crosses between grid points, for a
        number of frames inversely proportional to its speed in the image: a
        fraction of a second at highway speeds, seconds in a queue crawling at a
        few km/h or stopping, where ``max_gap`` frames cut a far sign's
        trajectory into pieces too short to show its path.  A ratio of lengths,
        the same at any speed, frame rate, resolution or focal length; the
        trajectory's duration still ends at ``max_track_length``, which must then
        be set (a still object would otherwise bridge forever).  The jitter of
        a nearly still object's positions inflates its fitted speed, which
        shortens the bridge.  ``None`` (the paper's rule) bridges ``max_gap``
        frames whatever the motion.
    max_track_length : int or None, default=300
        Longest duration of a trajectory, in frames (first to last, gaps included);
        a trajectory that reaches it ends and the object's next cluster starts a new
        one.  ``None``: unbounded.  This bounds the delay after which a frame's
        decisions are final and the memory of online detection (a vehicle followed
        for minutes would otherwise hold its frames for minutes).  The default is
        10 s at 30 fps, from the physics of an indicator's passage: a sign of about
        0.5 m seen by an 800 px camera is a cluster (>= 7 px tall) from about 57 m
        away and leaves the image about 10 m before it is passed, so it is in view
        for about 50 m of travel -- less than 10 s above 18 km/h.  In slower traffic
        an indicator's trajectory is cut into 10-s pieces, each still long and
        straight.
    max_scale_change : float, default=4.0
        Largest ratio of the sizes of linked responses (the paper's 4).
    gate : float, default=1.0
        A response farther than ``gate`` times its size (at least ``min_gate`` px)
        from the predicted position cannot link.
    min_gate : float, default=12.0
        Smallest position gate (px): about two keypoint grid steps.
    position_sigma : float, default=0.35
        Standard deviation of the position error, relative to the size.
    scale_sigma : float, default=0.35
        Standard deviation of the log scale change.
    appearance_sigma : float, default=0.3
        Standard deviation of the appearance difference (half the L1 distance of
        the histograms).
    gap_penalty : float, default=1.0
        Log-likelihood lost per missed frame.
    history : int, default=5
        Number of last positions of the straight-line prediction.
    assignment : {"greedy", "hungarian"}, default="greedy"
        ``"greedy"``: the paper's best pair first; ``"hungarian"``: the assignment
        maximizing the sum of log-likelihoods (:func:`scipy.optimize.linear_sum_assignment`).
    frame_rate : float or None, default=30.0
        The frame rate (frames per second) ``max_gap`` and ``max_track_length`` are
        counted in.  A tour's frames carry its frame rate
        (``payload["frame_rate"]``, set by :class:`~tunnelsense.Tour`), and on a tour
        at ``f`` fps both counts are scaled by ``f / frame_rate`` (rounded half up),
        so they keep their duration: ``max_gap=6`` is 6 frames at 30 fps, 2 at
        9 fps, 12 at 60 fps.  Scaled down, ``max_gap`` stays at least 1 and
        ``max_track_length`` at least 7 (or the count itself when smaller), the
        fewest points :class:`PCCVerifier` tests for straightness.  Frames without a
        frame rate (made from a user's arrays) count as being at ``frame_rate``;
        ``None`` counts frames whatever the tour's rate.  A tour's rate is that of
        its first frame.

    Attributes
    ----------
    n_frames_fit_ : int
        Number of frames seen by ``fit``.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import FrameRecord
    >>> from tunnelsense.tunnel import TrajectoryLinker
    >>> img = np.zeros((48, 64), np.uint8)
    >>> X = [FrameRecord("t", f, img, {"cluster_boxes": np.array([[10. + 2 * f, 20, 4, 8]])})
    ...      for f in range(1, 5)]
    >>> [r.payload["track_ids"].tolist() for r in TrajectoryLinker().fit_transform(X)]
    [[1], [1], [1], [1]]
    """

    _parameter_constraints: dict = {
        "max_gap": [Interval(numbers.Integral, 0, None, closed="left")],
        "max_gap_travel": [Interval(numbers.Real, 0, None, closed="left"), None],
        "max_track_length": [Interval(numbers.Integral, 2, None, closed="left"), None],
        "max_scale_change": [Interval(numbers.Real, 1, None, closed="left")],
        "gate": [Interval(numbers.Real, 0, None, closed="neither")],
        "min_gate": [Interval(numbers.Real, 0, None, closed="left")],
        "position_sigma": [Interval(numbers.Real, 0, None, closed="neither")],
        "scale_sigma": [Interval(numbers.Real, 0, None, closed="neither")],
        "appearance_sigma": [Interval(numbers.Real, 0, None, closed="neither")],
        "gap_penalty": [Interval(numbers.Real, 0, None, closed="left")],
        "history": [Interval(numbers.Integral, 2, None, closed="left")],
        "assignment": [StrOptions({"greedy", "hungarian"})],
        "frame_rate": [Interval(numbers.Real, 0, None, closed="neither"), None],
    }

    def __init__(
        self,
        *,
        max_gap=3,
        max_gap_travel=None,
        max_track_length=300,
        max_scale_change=4.0,
        gate=1.0,
        min_gate=12.0,
        position_sigma=0.35,
        scale_sigma=0.35,
        appearance_sigma=0.3,
        gap_penalty=1.0,
        history=5,
        assignment="greedy",
        frame_rate=30.0,
    ):
        self.max_gap = max_gap
        self.max_gap_travel = max_gap_travel
        self.max_track_length = max_track_length
        self.max_scale_change = max_scale_change
        self.gate = gate
        self.min_gate = min_gate
        self.position_sigma = position_sigma
        self.scale_sigma = scale_sigma
        self.appearance_sigma = appearance_sigma
        self.gap_penalty = gap_penalty
        self.history = history
        self.assignment = assignment
        self.frame_rate = frame_rate

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.two_d_array = False
        tags.transformer_tags.preserves_dtype = []
        return tags

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y=None):
        """Validate the frames (nothing is learned).

        Parameters
        ----------
        X : sequence of FrameRecord
            Frames with ``payload["cluster_boxes"]``.
        y : ignored (per-frame boxes are validated if given)

        Returns
        -------
        self : TrajectoryLinker
        """
        self._check_settings()
        records = self._check_records(X, y)
        stream_order(records)
        self.n_frames_fit_ = len(records)
        return self

    def _check_settings(self):
        if self.max_gap_travel is not None and self.max_track_length is None:
            raise ValueError(
                "max_gap_travel needs max_track_length to end a trajectory (an object "
                "standing still bridges any gap): got max_track_length=None; set "
                "max_track_length or max_gap_travel=None")

    _sequence = FrameSequence
    _payload_reads = (CLUSTER_BOXES,)
    _payload_optional = (CLUSTER_HISTOGRAMS,)
    _payload_adds = (TRACK_IDS, ENDED_TRACKS, CUT_TRACKS, CONTINUED_TRACKS)

    def _check_records(self, X, y=None):
        records, _ = check_frames(X, y)
        for i, r in enumerate(records):
            histograms_of(r, i, len(boxes_of(r, i, "TrajectoryLinker")))
        return records

    def _stream_state(self, *, batch=False):
        return LinkerStream(self)

    def transform(self, X):
        """Link the clusters of every tour into trajectories.

        Runs the same state machine as :meth:`start_stream` over each tour's frames in
        frame order, so batch and streaming give identical trajectories.

        Parameters
        ----------
        X : sequence of FrameRecord
            Frames with ``payload["cluster_boxes"]`` (and, optionally,
            ``payload["cluster_histograms"]``).

        Returns
        -------
        X_new : FrameSequence
            The frames in input order, with ``payload["track_ids"]`` and
            ``payload["ended_tracks"]``.
        """
        return super().transform(X)

    def start_stream(self):
        """Link frames online, one at a time (the streaming protocol).

        Returns
        -------
        state : object
            ``state.push(record)`` takes the next frame (frames of a tour in
            increasing order; a record of another tour starts that tour afresh) and
            returns it at once, evolved as :meth:`transform` does; ``state.close()``
            ends the stream and returns ``[]``.  Memory is bounded: at most the live
            trajectories, each keeping its last ``history`` positions.

        Examples
        --------
        >>> import numpy as np
        >>> from tunnelsense import FrameRecord
        >>> from tunnelsense.tunnel import TrajectoryLinker
        >>> img = np.zeros((48, 64), np.uint8)
        >>> X = [FrameRecord("t", 1, img, {"cluster_boxes": np.empty((0, 4))})]
        >>> state = TrajectoryLinker(max_gap=1).fit(X).start_stream()
        >>> for f in (1, 2, 5):
        ...     (out,) = state.push(FrameRecord("t", f, img,
        ...                         {"cluster_boxes": np.array([[10. + f, 20, 4, 8]])}))
        ...     print(f, out.payload["track_ids"], out.payload["ended_tracks"])
        1 [1] []
        2 [1] []
        5 [2] [1]
        """
        return super().start_stream()
