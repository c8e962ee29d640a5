"""The position stream's arithmetic: its rows, the Kalman update of its state, and
the fixed-lag smoother's backward pass over the frames it holds.

A state is ``x = (s, c, P00, P01, P11)``: the chainage, the odometry's scale and
their covariance.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from tunnelsense.positioning._tables import ESTIMATE_COLUMNS

__all__ = ["rows_table"]

_NAN5 = (math.nan,) * 5


class _Rows:
    """Released rows, in fixed-size numpy blocks until taken."""

    def __init__(self):
        self._blocks, self._buf, self._n = [], np.empty((1024, 7)), 0

    def add(self, row):
        if self._n == len(self._buf):
            self._blocks.append(self._buf)
            self._buf, self._n = np.empty((1024, 7)), 0
        self._buf[self._n] = row
        self._n += 1

    def take(self) -> pd.DataFrame:
        a = np.concatenate([*self._blocks, self._buf[:self._n]])
        self._blocks, self._buf, self._n = [], np.empty((1024, 7)), 0
        return rows_table(a)


def rows_table(a) -> pd.DataFrame:
    """An ``(n, 7)`` array of rows as the positions table."""
    a = np.asarray(a, np.float64).reshape(-1, 7)
    return pd.DataFrame({
        "frame": a[:, 0].astype(np.int64), "stamp": a[:, 1], "chainage": a[:, 2],
        "sigma": a[:, 3], "locked": a[:, 4] > 0, "scale": a[:, 5],
        "scale_sigma": a[:, 6]}, columns=list(ESTIMATE_COLUMNS))


def _row(frame, stamp, x):
    """The output row of a state ``x = (s, c, P00, P01, P11)``."""
    s, c, a, _, e = x
    if s != s:  # not locked
        return (frame, stamp, math.nan, math.nan, 0.0, math.nan, math.nan)
    return (frame, stamp, s, math.sqrt(max(a, 0.0)), 1.0, c, math.sqrt(max(e, 0.0)))


def _update(x, u, z, r):
    """Kalman update of ``x = (s, c, P00, P01, P11)`` with ``z = s + c u`` (NaN
    ``u``: a measurement of the scale, ``z = c``)."""
    s, c, a, b, e = x
    if u != u:
        S = e + r
        k0, k1 = b / S, e / S
        res = z - c
        return (s + k0 * res, c + k1 * res, a - k0 * k0 * S, b - k0 * k1 * S,
                e - k1 * k1 * S)
    ha, hb = a + u * b, b + u * e  # P h
    S = ha + u * hb + r
    k0, k1 = ha / S, hb / S
    res = z - (s + u * c)
    return (s + k0 * res, c + k1 * res, a - k0 * k0 * S, b - k0 * k1 * S,
            e - k1 * k1 * S)


class _LaggedRelease:
    """The fixed-lag smoother of :class:`PositionStream` (``smooth``): a
    Rauch-Tung-Striebel pass backwards over the held frames."""

    def _release(self, upto):
        """Smooth the held frames backwards; release those before ``upto``."""
        lo, n, W = self._released, self._n, self._W
        if upto <= lo:
            return
        post, prior, us = self._post, self._prior, self._u
        nxt = post[(n - 1) % W].tolist()  # smoothed state of frame i + 1
        out = []
        for i in range(n - 1, lo - 1, -1):
            sl = i % W
            x = post[sl].tolist()
            if i < n - 1 and x[0] == x[0] and nxt[0] == nxt[0]:
                sn = (i + 1) % W
                A, B, E = prior[sn, 2], prior[sn, 3], prior[sn, 4]
                xp0, xp1 = prior[sn, 0], prior[sn, 1]
                u = us[sn]
                s, c, a, b, e = x
                # G = P F^T M^-1, F = [[1, u], [0, 1]], M the prior covariance at i+1
                m00, m01, m10, m11 = a + b * u, b, b + e * u, e
                det = A * E - B * B
                if E > 0 and det > 1e-12 * A * E:
                    g00 = (m00 * E - m01 * B) / det
                    g01 = (m01 * A - m00 * B) / det
                    g10 = (m10 * E - m11 * B) / det
                    g11 = (m11 * A - m10 * B) / det
                else:  # no scale state
                    g00, g01, g10, g11 = m00 / A, 0.0, 0.0, 0.0
                d0, d1 = nxt[0] - xp0, nxt[1] - xp1
                D00, D01, D11 = nxt[2] - A, nxt[3] - B, nxt[4] - E
                # G D G^T
                t00, t01 = g00 * D00 + g01 * D01, g00 * D01 + g01 * D11
                t10, t11 = g10 * D00 + g11 * D01, g10 * D01 + g11 * D11
                x = (s + g00 * d0 + g01 * d1, c + g10 * d0 + g11 * d1,
                     a + t00 * g00 + t01 * g01, b + t00 * g10 + t01 * g11,
                     e + t10 * g10 + t11 * g11)
            nxt = x
            if i < upto:
                out.append(_row(int(self._fr[sl]), float(self._st[sl]), x))
        for row in reversed(out):
            self._rows.add(row)
        self._released = upto
