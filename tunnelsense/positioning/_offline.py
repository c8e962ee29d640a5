"""The whole-tour smoother of :meth:`TunnelPositioner.predict` with ``smooth``: the
Rauch-Tung-Striebel smoother over every frame, with every fix the stream used."""

from __future__ import annotations

import numpy as np
import pandas as pd

from tunnelsense.positioning._filter import forward, rts_smooth
from tunnelsense.positioning._tables import ESTIMATE_COLUMNS

__all__ = []


def smooth_tour(positioner, odometry, fix_list, relocked):
    """The positions table smoothed over the tour.

    ``positioner``: the fitted :class:`TunnelPositioner` (its noise, prior and map);
    ``fix_list``: ``(frame index, u, z, r)`` of every fix the stream used (NaN
    ``u``: a measurement of the scale); ``relocked``: the stream dropped its start
    (the start is then not used: every frame is placed by the fixes).
    """
    p = positioner
    t = odometry["stamp"].to_numpy()
    v = odometry["speed"].to_numpy()
    dt = np.diff(t)
    inc = v[:-1] * dt
    q_s = (float(p.speed_noise) * dt) ** 2
    q_c = (float(p.scale_drift) ** 2 * dt if p.estimate_scale
           else np.zeros_like(dt))
    sc2 = float(p.scale_sigma) ** 2 if p.estimate_scale else 0.0
    fixes = {}
    for k, u, z, r in fix_list:
        fixes.setdefault(k, []).append((u, z, r))
    known = p.initial_chainage is not None and not relocked
    if known:
        x0 = [float(p.initial_chainage), float(p.initial_scale)]
        P0 = np.diag([float(p.initial_sigma) ** 2, sc2])
    else:  # diffuse: every frame placed by the fixes
        lo, hi = p.indicator_chainage_[0], p.indicator_chainage_[-1]
        x0 = [(lo + hi) / 2, float(p.initial_scale)]
        P0 = np.diag([(10.0 * max(hi - lo, 1000.0)) ** 2, sc2])
    prior, post, prior_cov, post_cov = forward(x0, P0, inc, q_s, q_c, fixes)
    x, cov = rts_smooth(inc, prior, post, prior_cov, post_cov)
    n = len(t)
    locked = known or bool(fixes)
    nan = np.full(n, np.nan)
    return pd.DataFrame({
        "frame": odometry["frame"].to_numpy(np.int64), "stamp": t,
        "chainage": x[:, 0] if locked else nan,
        "sigma": np.sqrt(np.maximum(cov[:, 0, 0], 0.0)) if locked else nan,
        "locked": np.full(n, locked),
        "scale": x[:, 1] if locked else nan,
        "scale_sigma": np.sqrt(np.maximum(cov[:, 1, 1], 0.0)) if locked else nan,
    }, columns=list(ESTIMATE_COLUMNS))
