"""The lock-on's decision (mixed into :class:`~tunnelsense.positioning._lock.LockOn`):
the best hypothesis, its lead over any that puts the vehicle at another place (with
the side terms and without), and whether that is a lock.

The hypotheses are held in ``self._h`` (``s``, ``p00``, ``score``, ``side``: the
side terms in the score), ``self._hits`` and ``self._last`` (see ``_lock``).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = []


class _LockDecision:
    """Ranking and lock of :class:`~tunnelsense.positioning._lock.LockOn`."""

    def _elsewhere(self, best):
        """Hypotheses that put the vehicle somewhere else than ``best`` does: more
        than ``gate`` standard deviations (of the two estimates) away."""
        h = self._h
        d = np.abs(h["s"] - h["s"][best])
        return d * d > self.gate2 * (h["p00"] + h["p00"][best])

    def ranking(self, missed=None):
        """``(best, margin)``: the best hypothesis and its lead over any hypothesis
        that puts the vehicle at another place (inf when there is none);
        ``missed``: misses added to each hypothesis's (not kept).
        """
        score = self._h["score"]
        if missed is not None:
            score = score + missed * self.log_miss
        if not len(score):
            return None, 0.0
        best = int(np.argmax(score))
        return best, self._lead(score, best)

    def _lead(self, score, best):
        """Lead of hypothesis ``best``'s ``score`` over any elsewhere (inf: none)."""
        rival = score[self._elsewhere(best)]
        return float(score[best] - rival.max()) if len(rival) else math.inf

    def lead_without_side(self, best, missed=None):
        """The lead of hypothesis ``best`` over any elsewhere, the side terms left
        out (``margin`` of :meth:`ranking` when the side is not used)."""
        score = self._h["score"] - self._h["side"]
        if missed is not None:
            score = score + missed * self.log_miss
        return self._lead(score, best)

    def n_explaining(self):
        """How many places of the map explain the passes within ``margin`` of the best."""
        score = self._h["score"]
        if not len(score):
            return 0
        near = np.flatnonzero(score >= score.max() - self.margin)
        places = 0
        while len(near):
            places += 1
            near = near[self._elsewhere(near[np.argmax(score[near])])[near]]
        return places

    def lock(self, missed=None, min_passes=None):
        """The lock, when one hypothesis explains the passes clearly best; else None.

        ``missed``: misses added to each hypothesis's score for this decision, and
        ``min_passes`` the passes the best must explain then (:meth:`silence`).
        A lock the side terms would give but ``side_margin`` or ``side_passes``
        withholds is recorded in :attr:`side_withheld`.

        Returns
        -------
        lock : dict or None
            ``state`` ``(s, c)`` and ``cov`` (2x2) at the last pass, ``indicator``
            (index of the last indicator explained), ``passes``: ``(tag, index)``
            of each remembered pass (index -1: not explained), ``margin``.
        """
        best, margin = self.ranking(missed)
        least = self.min_passes if min_passes is None else min_passes
        self.side_withheld = None
        if best is None or self._hits[best] < least or margin < self.margin:
            return None
        if self.sides is not None:
            plain = self.lead_without_side(best, missed)
            # (to rounding: on an evenly spaced map the places tie)
            if plain < self.margin:  # the side is needed, and may not settle it
                if plain < self.side_margin - 1e-6:
                    self.side_withheld = "side_margin"
                elif self.n_passes < self.side_passes:
                    self.side_withheld = "side_passes"
                if self.side_withheld:
                    return None
        h = self._h
        return {
            "state": np.array([h["s"][best], h["c"][best]]),
            "cov": np.array([[h["p00"][best], h["p01"][best]],
                             [h["p01"][best], h["p11"][best]]]),
            "indicator": int(self._last[best]),
            "passes": [(t, int(a[best])) for t, a in self._assign],
            "margin": margin,
        }
