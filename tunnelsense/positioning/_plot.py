"""A picture of a positioning run: errors of dead reckoning and of the fused estimate."""

from __future__ import annotations

import numpy as np

from tunnelsense.positioning._evaluate import dead_reckoning
from tunnelsense.positioning._tables import check_indicator_map, check_positions

__all__ = ["plot_positioning"]


def plot_positioning(truth, estimate, odometry=None, fixes=None, *,
                     indicator_map=None, ax=None):
    """Plot the chainage error against time: dead reckoning, fused, fixes marked.

    Parameters
    ----------
    truth : DataFrame
        ``frame, stamp, chainage`` (``positions.csv``).
    estimate : DataFrame
        ``frame, stamp, chainage, sigma`` (``TunnelPositioner.predict``).
    odometry : DataFrame or None, default=None
        With it, the error of dead reckoning alone too.
    fixes : DataFrame or None, default=None
        The fix log (``predict(..., return_fixes=True)``): accepted fixes are marked
        at their pass, rejected ones crossed.
    indicator_map : DataFrame or None, default=None
        With it, the times the camera passes an indicator are drawn as dotted lines.
    ax : matplotlib Axes or None, default=None
        Where to draw; None makes a new figure.

    Returns
    -------
    ax : matplotlib Axes
    """
    import matplotlib.pyplot as plt

    truth = check_positions(truth, "truth")
    est = check_positions(estimate, "estimate", sigma=True)
    if ax is None:
        _, ax = plt.subplots(figsize=(9, 4), layout="constrained")
    t = truth["stamp"].to_numpy()
    s = truth["chainage"].to_numpy()
    err = est["chainage"].to_numpy() - s
    sig = est["sigma"].to_numpy()
    if odometry is not None:
        ax.plot(t, dead_reckoning(odometry, initial_chainage=s[0]) - s, color="0.5",
                label="dead reckoning alone")
    ax.fill_between(t, -2 * sig, 2 * sig, color="tab:blue", alpha=0.2,
                    label="fused, 2 sigma")
    ax.plot(t, err, color="tab:blue", label="fused")
    if fixes is not None and len(fixes):
        by_frame = dict(zip(truth["frame"].to_numpy(), range(len(t)), strict=True))
        for accepted, marker, label in ((True, "o", "fix"), (False, "x", "rejected")):
            sel = fixes[(fixes["accepted"] == accepted) & (fixes["pass_frame"] > 0)]
            k = [by_frame[f] for f in sel["pass_frame"] if f in by_frame]
            if k:
                ax.plot(t[k], err[k], marker, color="tab:red", ms=6, label=label)
    if indicator_map is not None:
        c = check_indicator_map(indicator_map)["chainage"].to_numpy()
        c = c[(c >= s[0]) & (c <= s[-1])]
        for k, when in enumerate(np.interp(c, s, t)):
            ax.axvline(when, color="tab:green", ls=":", lw=1,
                       label=None if k else "indicator passed")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("chainage error (m)")
    ax.legend(loc="best", fontsize="small")
    ax.set_xlim(t[0], t[-1] if len(t) > 1 else t[0] + 1)
    ax.grid(True, alpha=0.3)
    return ax

