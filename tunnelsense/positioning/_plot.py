"""A picture of a positioning run: errors of dead reckoning and of the fused estimate."""

from __future__ import annotations

import numpy as np

from tunnelsense.positioning._evaluate import dead_reckoning
from tunnelsense.positioning._tables import check_indicator_map, check_positions

__all__ = ["plot_positioning"]


def plot_positioning(truth, estimate, odometry=None, fixes=None, *,
                     indicator_map=None, ax=None):
    """Plot the chainage error against time: dead reckoning, fused, fixes marked.

    Dead reckoning drifts by metres while the fused error stays within a few tens of
    centimetres, so on a new figure with ``odometry`` a second panel below shows the
    fused error alone, scaled to its error and 2-sigma band from the first fix on
    (before it the estimate is dead reckoning, shown whole in the panel above).

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
        Where to draw (one panel); None makes a new figure (two panels with
        ``odometry``).

    Returns
    -------
    ax : matplotlib Axes
        The panel of every error; the zoomed panel, when drawn, is
        ``ax.figure.axes[1]``.
    """
    import matplotlib.pyplot as plt

    truth = check_positions(truth, "truth")
    est = check_positions(estimate, "estimate", sigma=True)
    zoom = None
    if ax is None and odometry is not None:
        _, (ax, zoom) = plt.subplots(2, 1, figsize=(9, 6), sharex=True,
                                     height_ratios=(3, 2), layout="constrained")
    elif ax is None:
        _, ax = plt.subplots(figsize=(9, 4), layout="constrained")
    t = truth["stamp"].to_numpy()
    s = truth["chainage"].to_numpy()
    err = est["chainage"].to_numpy() - s
    sig = est["sigma"].to_numpy()
    if odometry is not None:
        ax.plot(t, dead_reckoning(odometry, initial_chainage=s[0]) - s, color="0.5",
                label="dead reckoning alone")
    passes = None
    if indicator_map is not None:
        c = check_indicator_map(indicator_map)["chainage"].to_numpy()
        c = c[(c >= s[0]) & (c <= s[-1])]
        passes = np.interp(c, s, t)
    for panel in filter(None, (ax, zoom)):
        _draw_fused(panel, t, err, sig, truth, fixes, passes)
    ax.set_xlim(t[0], t[-1] if len(t) > 1 else t[0] + 1)
    ax.legend(loc="best", fontsize="small")
    if zoom is not None:
        ax.tick_params(labelbottom=False)
        ax.set_xlabel("")
        zoom.set_ylim(*_fused_limits(err, sig))
        zoom.set_ylabel("fused error (m)")
        zoom.set_title("fused estimate, from its first fix", fontsize="small",
                       loc="left")
    return ax


def _fused_limits(err, sig):
    """The zoomed panel's y-limits: the fused error and its 2-sigma band from the
    first fix on (sigma grows under dead reckoning alone, and first drops at a fix;
    before it the error is dead reckoning's, shown whole in the panel above)."""
    drops = np.flatnonzero(np.diff(sig) < 0)
    start = drops[0] + 1 if drops.size else 0
    values = np.concatenate([np.abs(err[start:]), 2 * sig[start:]])
    values = values[np.isfinite(values)]
    top = 1.15 * float(values.max()) if values.size and values.max() > 0 else 1.0
    return -top, top


def _draw_fused(ax, t, err, sig, truth, fixes, passes):
    """The fused error with its 2-sigma band, the fixes and the indicator passes."""
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
    for k, when in enumerate([] if passes is None else passes):
        ax.axvline(when, color="tab:green", ls=":", lw=1,
                   label=None if k else "indicator passed")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("chainage error (m)")
    ax.grid(True, alpha=0.3)
