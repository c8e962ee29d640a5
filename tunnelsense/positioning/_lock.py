"""Locking on to the indicator map without a start: which indicator was just passed.

With no start (a log begun mid-tunnel, GPS lost before the portal, a restart), the
passes alone say where the vehicle is: the odometry distances between them, times
an unknown scale near 1, must match the gaps between the indicators they are.  Each
hypothesis says "this pass was indicator ``j``" and runs its own 1-D Kalman filter
(chainage and odometry scale) over the later passes.  At each pass a hypothesis
branches: "this pass was the indicator nearest ahead" (if within the gate) and
"this pass was false" -- so a false pass near a missed sign, which the right place
could otherwise only explain as that sign 20-60 m off (pulling its scale away for
good), leaves the right place its true explanation.  Its score is the
log-likelihood of the passes: a Gaussian term for a pass it explains, the log of
the false-pass rate for one it does not, the log of the miss rate for an indicator
it skips -- and, when the record's start is known, for each indicator it says the
vehicle drove past unseen before the first pass it explains (:func:`unseen_before`).
Between passes, the odometry driven since the last one is evidence too: a
hypothesis that puts an indicator surely behind the vehicle by now, though no pass
of it came, pays the miss rate for it (:meth:`LockOn.silence`), so the lock can be
taken before the next pass (once the best hypothesis explains one pass more than
``min_passes``).  Hypotheses are anchored at each of the first few passes, so one
false alarm among them does not prevent the lock.

Where the map says which wall each indicator stands on, and on both walls, the side
a pass's trajectory was seen on (:func:`~tunnelsense.positioning.observed_side`) is
a likelihood factor: a hypothesis that explains the pass by an indicator on the
other wall pays ``log(e / (1 - e))``, ``e`` the pass's own error
(:func:`~tunnelsense.positioning._side.side_error_of`: ``side_error`` for a drift
read surely, more for a weak one) -- never a veto, so a side misread does not
lose the right place.  An unknown side (observed or on the map) costs nothing, nor
does a pass taken as false.  On a map whose indicators all stand on one wall the
side separates no place: it is not used.  The side only settles what the spacing
leaves open: a lock it is needed for (the lead without the side terms below
``margin``) must be at a place the spacing alone ranks first (``side_margin``) and
come after ``side_passes`` passes.  A false alarm stands on a wall too: a wrong
stretch that takes it for an indicator, with a missed sign at the right place, can
match the walls of three passes by chance.

The lock is taken when the best hypothesis has explained ``min_passes`` passes and
its score beats every hypothesis that puts the vehicle at another place by
``margin``.  The score is the likelihood of the passes with the scale marginalized
(each hypothesis's Kalman filter: the scale's prior, the odometry between passes,
each pass's own variance), so the margin is a likelihood ratio.  The miss rate it
is computed with should be pessimistic (:class:`TunnelPositioner` uses 0.4): a
missed sign and a false pass near it can make a wrong stretch of the map (with a
scale a few per cent off) explain every pass, and the right place then counts a
miss and a false pass; a lock must not hinge on the detector never missing.  On a
strictly periodic map every interior hypothesis explains the passes equally:
there is no lock, and nothing is guessed.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from tunnelsense.positioning._defaults import SIDE_ERROR
from tunnelsense.positioning._lock_decide import _LockDecision
from tunnelsense.positioning._side import side_error_of, sides_used

__all__ = ["LockOn"]


class LockOn(_LockDecision):
    """Hypotheses over the map, updated pass by pass (see the module's docstring).

    Parameters
    ----------
    chainage : ndarray of shape (n_indicators,)
        The map, increasing.
    scale, scale_sigma : float
        Prior of the odometry's scale factor (true distance / odometry distance).
    fix_sigma : float
        Standard deviation of a pass's chainage (m), added to the pass fit's own.
    gate : float
        Largest Mahalanobis distance of an explained pass.
    miss_rate : float
        Probability that the detector misses an indicator (a pessimistic one: see
        the module's docstring).
    false_pass_rate : float
        False passes per metre (a trajectory of something else that passes).
    margin : float
        Log-likelihood ratio of the lock over the best rival.
    min_passes : int
        Fewest passes the locked hypothesis explains (the anchor included).
    max_anchors : int, default=3
        Hypotheses are anchored at each of the first ``max_anchors`` passes.
    memory : int, default=32
        Passes whose association is remembered (reported at the lock).
    start : float or None, default=None
        Odometry distance where the record begins.  A hypothesis "the first pass it
        explains is indicator ``j``" then also says which indicators the vehicle
        drove past before it, unseen: each pays the miss rate.  None: unknown (after
        a wrong lock), no such term.
    clearance : float, default=60.0
        A sign whose pass comes less than this (m of odometry) after ``start`` may
        have been in view before the record began: it is not counted as missed.
    per_indicator : int, default=8
        Hypotheses kept whose last indicator is the same (the best of them).
    sides : ndarray of int or None, default=None
        The wall of each indicator: -1 left, +1 right, 0 unknown.  None (or a map
        with fewer than two walls named): the side is not used.
    side_error : float or None, default=0.05
        Probability that a pass's observed side is the other wall, for a side read
        surely (the least a pass's own,
        :func:`~tunnelsense.positioning._side.side_error_of`); None (or 0.5): the
        side is not used.
    side_margin : float, default=0.0
        A lock the side terms are needed for (its lead without them below
        ``margin``) also needs a lead of ``side_margin`` without them (to
        rounding): at 0 the side settles the place the spacing already ranks
        first (or level with others), and never lifts one the spacing puts behind
        another.
    side_passes : int, default=4
        Fewest passes seen (false ones included) before a lock the side terms are
        needed for: a wrong stretch matches the walls of three passes by chance
        one time in eight, and a pass more can contradict it.
    """

    def __init__(self, chainage, *, scale, scale_sigma, fix_sigma, gate, miss_rate,
                 false_pass_rate, margin, min_passes, max_anchors=3, memory=32,
                 start=None, clearance=60.0, per_indicator=8, sides=None,
                 side_error=SIDE_ERROR, side_margin=0.0, side_passes=4):
        self.map = np.asarray(chainage, np.float64)
        self.scale, self.scale_sigma = float(scale), float(scale_sigma)
        self.fix_var = float(fix_sigma) ** 2
        self.gate2 = float(gate) ** 2
        self.log_hit = math.log1p(-float(miss_rate))
        self.log_miss = math.log(max(float(miss_rate), 1e-12))
        self.log_false = math.log(max(float(false_pass_rate), 1e-300))
        self.margin = float(margin)
        self.min_passes = int(min_passes)
        self.max_anchors = int(max_anchors)
        self.start = None if start is None else float(start)
        self.clearance = float(clearance)
        self.per_indicator = int(per_indicator)
        # one wall (or side_error None, 0.5): the side separates no place
        self.sides = sides_used(sides, side_error)
        e = 0.5 if self.sides is None else float(side_error)
        self.side_error = e
        self.side_cost = math.log(e / (1.0 - e)) if self.sides is not None else 0.0
        self.side_margin = float(side_margin)
        self.side_passes = int(side_passes)
        self.n_passes = 0
        # why the last decision took no lock the side terms gave: "side_margin",
        # "side_passes" or None
        self.side_withheld = None
        self._last_dist = None
        self._due = math.inf  # odometry distance before which silence() changes nothing
        self._h = {k: np.empty(0) for k in ("s", "c", "p00", "p01", "p11", "score",
                                            "side")}
        self._last = np.empty(0, np.int64)  # last indicator explained
        self._hits = np.empty(0, np.int64)  # passes explained
        self._assign = deque(maxlen=int(memory))  # per pass: (tag, indicator per hyp)

    @property
    def n_hypotheses(self) -> int:
        return len(self._last)

    def _side_terms(self, j, side, side_t=math.inf):
        """The side's log-likelihood term of explaining a pass seen on ``side``
        (-1, +1; 0 unknown; ``side_t``: its drift's t statistic) by indicators
        ``j``."""
        if self.sides is None or not side or not self.side_cost:
            return 0.0
        e = side_error_of(side_t, self.side_error)
        if e >= 0.5:
            return 0.0
        return np.where(self.sides[j] == -int(side), math.log(e / (1.0 - e)), 0.0)

    def add(self, dist, var, q_s=0.0, q_c=0.0, tag=None, side=0, side_t=math.inf):
        """A pass at odometry distance ``dist`` (variance ``var``).

        ``q_s, q_c``: process noise of the chainage and the scale accumulated since
        the previous pass.  ``tag`` is given back with the pass's association at the
        lock; ``side`` the wall its trajectory was seen on (-1 left, +1 right, 0
        unknown) and ``side_t`` how surely (the drift's t statistic,
        :func:`~tunnelsense.positioning._side.side_error_of`).  Returns the lock
        (:meth:`lock`) or None.
        """
        h = self._h
        if self.n_hypotheses:
            delta = float(dist) - self._last_dist
            s, c = h["s"] + h["c"] * delta, h["c"]
            p00 = h["p00"] + 2 * delta * h["p01"] + delta**2 * h["p11"] + q_s
            p01 = h["p01"] + delta * h["p11"]
            p11 = h["p11"] + q_c
            r = self.fix_var + c * c * float(var)
            S = p00 + r
            # the nearest indicator at or after the last one explained
            top = len(self.map) - 1
            i = np.clip(np.searchsorted(self.map, s), min(1, top), top)
            lo = np.maximum(np.maximum(i - 1, 0), self._last)
            hi = np.maximum(i, self._last)
            j = np.where(np.abs(self.map[lo] - s) <= np.abs(self.map[hi] - s), lo, hi)
            res = self.map[j] - s
            m2 = res * res / S
            ok = m2 <= self.gate2
            # an unexplained pass: the indicators surely behind the vehicle now were
            # missed (it is not at the one it should have seen)
            behind = np.searchsorted(self.map, s - np.sqrt(self.gate2 * S)) - 1
            j_false = np.maximum(behind, self._last)
            miss_false = np.maximum(j_false - self._last, 0) * self.log_miss
            skipped = np.maximum(j - self._last - 1, 0)
            gauss = -0.5 * m2 - 0.5 * np.log(2 * np.pi * S) + self.log_hit
            # every hypothesis goes on as "this pass was false" (with the indicators
            # surely behind by now missed); one that explains it also as "this pass
            # was indicator j": a false pass within the gate of the right place
            # must not pull the right place's scale away with no way back
            k0, k1 = p00 / S, p01 / S
            e = np.flatnonzero(ok)
            score = h["score"]
            side_e = self._side_terms(j[e], side, side_t) + np.zeros(len(e))
            h["score"] = np.concatenate([
                score[e] + skipped[e] * self.log_miss + gauss[e] + side_e,
                score + miss_false + self.log_false])
            h["side"] = np.concatenate([h["side"][e] + side_e, h["side"]])
            h["s"] = np.concatenate([s[e] + k0[e] * res[e], s])
            h["c"] = np.concatenate([c[e] + k1[e] * res[e], c])
            h["p00"] = np.concatenate([(p00 - k0 * p00)[e], p00])
            h["p01"] = np.concatenate([(p01 - k0 * p01)[e], p01])
            h["p11"] = np.concatenate([(p11 - k1 * p01)[e], p11])
            self._last = np.concatenate([j[e], j_false])
            self._hits = np.concatenate([self._hits[e] + 1, self._hits])
            self._assign = deque(((t, np.concatenate([a[e], a])) for t, a in self._assign),
                                 maxlen=self._assign.maxlen)
            assign = np.concatenate([j[e], np.full(len(ok), -1)])
        else:
            assign = np.empty(0, np.int64)
        if self.n_passes < self.max_anchors:
            assign = self._spawn(float(dist), float(var), assign, side, side_t)
        self._assign.append((tag, assign))
        self.n_passes += 1
        self._last_dist = float(dist)
        self._prune()
        self._due = -math.inf
        return self.lock()

    def unseen_since(self, dist, margin):
        """Indicators each hypothesis puts surely behind the vehicle at odometry
        distance ``dist``, past the last one it accounts for, though no pass came.

        An indicator is surely behind when its chainage is ``margin`` m and ``gate``
        standard deviations (of the predicted chainage) behind the vehicle: its
        trajectory would have ended, and its pass been given, by then.

        Returns
        -------
        count : ndarray of int, shape (n_hypotheses,)
        """
        h = self._h
        delta = float(dist) - self._last_dist
        s = h["s"] + h["c"] * delta
        var = h["p00"] + 2 * delta * h["p01"] + delta**2 * h["p11"]
        behind = s - math.sqrt(self.gate2) * np.sqrt(np.maximum(var, 0.0)) - margin
        passed = np.searchsorted(self.map, behind, side="right") - 1
        count = np.maximum(passed - self._last, 0)
        # the next indicator of each hypothesis: before the vehicle has driven to it
        # (plus the margin) the count cannot grow
        nxt = np.minimum(self._last + count + 1, len(self.map) - 1)
        ahead = (self.map[nxt] + margin - h["s"]) / np.maximum(h["c"], 1e-6)
        ahead = np.where(self._last + count + 1 < len(self.map), ahead, np.inf)
        self._due = self._last_dist + float(ahead.min()) if len(ahead) else math.inf
        return count

    def silence(self, dist, margin):
        """The lock at odometry distance ``dist``, no pass having come since the
        last one: each hypothesis pays the miss rate for the indicators it puts
        surely behind the vehicle (:meth:`unseen_since`); the best must explain
        ``min_passes + 1`` passes.  The state returned is still that at the last
        pass.  None: no lock (or nothing new since the last call)."""
        if not self.n_hypotheses or self.n_passes < self.min_passes or dist < self._due:
            return None
        return self.lock(self.unseen_since(dist, margin), self.min_passes + 1)

    def _spawn(self, dist, var, assign, side=0, side_t=math.inf):
        """Hypotheses "this pass is indicator j" for every j; earlier passes false."""
        m = len(self.map)
        score = np.full(m, self.n_passes * self.log_false + self.log_hit)
        side_m = self._side_terms(np.arange(m), side, side_t) + np.zeros(m)
        score += side_m
        if self.start is not None:
            score += self.log_miss * unseen_before(self.map, dist - self.start,
                                                   self.scale, self.scale_sigma,
                                                   self.clearance)
        new = {"s": self.map.copy(), "c": np.full(m, self.scale),
               "p00": np.full(m, self.fix_var + self.scale**2 * var),
               "p01": np.zeros(m), "p11": np.full(m, self.scale_sigma**2),
               "score": score, "side": side_m}
        for key, value in new.items():
            self._h[key] = np.concatenate([self._h[key], value])
        self._last = np.concatenate([self._last, np.arange(m)])
        self._hits = np.concatenate([self._hits, np.ones(m, np.int64)])
        self._assign = deque(((t, np.concatenate([a, np.full(m, -1)]))
                              for t, a in self._assign), maxlen=self._assign.maxlen)
        return np.concatenate([assign, np.arange(m)])

    def _prune(self):
        """Forget hypotheses far behind the best (they can no longer win), and all
        but the ``per_indicator`` best of those whose last indicator is the same
        (the branches "that pass was false" would otherwise double them at each
        pass on a map that gives no lock)."""
        score = self._h["score"]
        keep = score >= score.max() - 4 * self.margin - 20.0
        order = np.flatnonzero(keep)[np.argsort(-score[keep], kind="stable")]
        group = order[np.argsort(self._last[order], kind="stable")]
        last = self._last[group]
        first = np.flatnonzero(np.r_[True, last[1:] != last[:-1]])
        rank = np.arange(len(last)) - np.repeat(first, np.diff(np.r_[first, len(last)]))
        keep = np.zeros(len(score), bool)
        keep[group[rank < self.per_indicator]] = True
        if keep.all():
            return
        for key in self._h:
            self._h[key] = self._h[key][keep]
        self._last, self._hits = self._last[keep], self._hits[keep]
        self._assign = deque(((t, a[keep]) for t, a in self._assign),
                             maxlen=self._assign.maxlen)


def unseen_before(chainage, driven, scale, scale_sigma, clearance):
    """Indicators each hypothesis "the pass is indicator ``j``" says were passed unseen.

    The pass came ``driven`` m of odometry after the record began, so at indicator
    ``j`` the record began near ``chainage[j] - scale * driven``.  An indicator
    passed more than ``clearance`` (m of odometry) after that, with two standard
    deviations of the scale to spare, was surely in view: not seeing it is a miss.

    Returns
    -------
    count : ndarray of int, shape (n_indicators,)
    """
    chainage = np.asarray(chainage, np.float64)
    seen_from = chainage - (scale - 2.0 * scale_sigma) * (driven - clearance)
    first = np.searchsorted(chainage, seen_from, side="right")
    return np.maximum(np.arange(len(chainage)) - first, 0)
