"""A 1-D Kalman filter over distance: chainage and the odometry's scale factor.

The state at frame ``k`` is ``x_k = (s_k, c)``: the chainage ``s_k`` of the camera and
the factor ``c`` between true distance and the odometry's distance.  Between frames
the chainage grows by ``c`` times the odometry's increment ``u_k``::

    s_{k+1} = s_k + c u_k,   c_{k+1} = c_k

so the model is linear, with the transition ``F_k = [[1, u_k], [0, 1]]``.  A position
fix says that the chainage at odometry distance ``u`` past frame ``k`` equals the
indicator's surveyed chainage: ``z = s_k + c u``, i.e. ``H = [1, u]``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["forward", "rts_smooth", "transition"]


def transition(u, q_s, q_c):
    """``F`` and ``Q`` of one step with odometry increment ``u``."""
    F = np.array([[1.0, u], [0.0, 1.0]])
    Q = np.array([[q_s, 0.0], [0.0, q_c]])
    return F, Q


def _update(x, P, h, z, r):
    """The Kalman update of ``(x, P)`` with the scalar measurement ``z = h x + v``."""
    s = float(h @ P @ h) + r
    k = P @ h / s
    x = x + k * (z - float(h @ x))
    ikh = np.eye(2) - np.outer(k, h)
    P = ikh @ P @ ikh.T + r * np.outer(k, k)  # Joseph form: stays symmetric, >= 0
    return x, P


def forward(x0, P0, increments, q_s, q_c, fixes, *, start=0):
    """Run the filter over the frames from ``start`` to ``start + len(increments)``.

    Parameters
    ----------
    x0, P0 : ndarray of shape (2,), (2, 2)
        The prior at frame ``start`` (before its fixes).
    increments : ndarray of shape (m,)
        Odometry distance from frame ``start + i`` to the next, for ``i < m``; the
        filter ends at frame ``start + m``.
    q_s, q_c : ndarray of shape (m,)
        Process noise of the chainage and of the scale on each step.
    fixes : dict of int -> list of (u, z, r)
        Measurements per frame: ``z = s_k + c u`` with variance ``r``.
    start : int, default=0

    Returns
    -------
    prior, post : ndarray of shape (m + 1, 2)
    prior_cov, post_cov : ndarray of shape (m + 1, 2, 2)
    """
    m = len(increments)
    prior = np.empty((m + 1, 2))
    post = np.empty((m + 1, 2))
    prior_cov = np.empty((m + 1, 2, 2))
    post_cov = np.empty((m + 1, 2, 2))
    x, P = np.asarray(x0, np.float64), np.asarray(P0, np.float64)
    for i in range(m + 1):
        if i:
            F, Q = transition(increments[i - 1], q_s[i - 1], q_c[i - 1])
            x, P = F @ x, F @ P @ F.T + Q
        prior[i], prior_cov[i] = x, P
        for u, z, r in fixes.get(start + i, ()):  # NaN u: a measurement of the scale
            h = np.array([0.0, 1.0]) if u != u else np.array([1.0, u])
            x, P = _update(x, P, h, z, r)
        post[i], post_cov[i] = x, P
    return prior, post, prior_cov, post_cov


def rts_smooth(increments, prior, post, prior_cov, post_cov):
    """Rauch-Tung-Striebel smoothing of a :func:`forward` pass.

    Returns
    -------
    x, cov : ndarray of shape (m + 1, 2), (m + 1, 2, 2)
        The state given every fix, before and after each frame.
    """
    x = post.copy()
    cov = post_cov.copy()
    for i in range(len(increments) - 1, -1, -1):
        F = np.array([[1.0, increments[i]], [0.0, 1.0]])
        gain = post_cov[i] @ F.T @ np.linalg.pinv(prior_cov[i + 1])
        x[i] = post[i] + gain @ (x[i + 1] - prior[i + 1])
        cov[i] = post_cov[i] + gain @ (cov[i + 1] - prior_cov[i + 1]) @ gain.T
    return x, cov
