"""How far an estimated chainage is from the truth, beside dead reckoning alone."""

from __future__ import annotations

import numpy as np
import pandas as pd

from tunnelsense.positioning._tables import (
    check_indicator_map,
    check_odometry,
    check_positions,
)

__all__ = ["dead_reckoning", "errors_table", "format_errors", "position_errors"]


def dead_reckoning(odometry, *, initial_chainage=0.0) -> np.ndarray:
    """The chainage per frame from the odometry alone (its speed integrated).

    Examples
    --------
    >>> import pandas as pd
    >>> from tunnelsense.positioning import dead_reckoning
    >>> odo = pd.DataFrame({"frame": [1, 2, 3], "stamp": [0.0, 0.5, 1.0],
    ...                     "speed": [20.0, 10.0, 10.0], "yaw_rate": 0.0})
    >>> dead_reckoning(odo).tolist()
    [0.0, 10.0, 15.0]
    """
    odo = check_odometry(odometry)
    dt = np.diff(odo["stamp"].to_numpy())
    steps = odo["speed"].to_numpy()[:-1] * dt
    return float(initial_chainage) + np.concatenate([[0.0], np.cumsum(steps)])


def position_errors(truth, estimate, odometry=None, indicator_map=None) -> dict:
    """Errors of a position estimate against the true positions.

    Parameters
    ----------
    truth : DataFrame
        ``frame, stamp, chainage`` (``positions.csv``).
    estimate : DataFrame
        ``frame, stamp, chainage, sigma``, the same frames.
    odometry : DataFrame or None, default=None
        With it, the same figures for dead reckoning alone.
    indicator_map : DataFrame or None, default=None
        With it, the error at each frame where the camera passes an indicator.

    Returns
    -------
    errors : dict
        ``max``, ``rms`` and ``final`` absolute error (m) over the frames with a
        position (``locked``; all of them when the estimate started from a known
        chainage), ``within_2_sigma`` (the fraction of those frames whose error is
        within twice the estimate's sigma); ``lock``: the first locked frame, the
        time (s) and distance (m) from the start to it and the indicators passed
        by then (``passes``), or None when it never locked; ``passes``: per
        indicator passed, its id, chainage, frame and the error there (None before
        the lock); ``dead_reckoning``: ``max``, ``rms``, ``final`` (and per pass)
        for the odometry alone, started from the true chainage.
    """
    truth = check_positions(truth, "truth")
    est = check_positions(estimate, "estimate", sigma=True)
    if not np.array_equal(truth["frame"].to_numpy(), est["frame"].to_numpy()):
        raise ValueError("estimate: its frames are not those of the true positions")
    s = truth["chainage"].to_numpy()
    err = est["chainage"].to_numpy() - s
    locked = est["locked"].to_numpy()
    out = _summary(err[locked])
    out["within_2_sigma"] = (float(np.mean(np.abs(err[locked]) <= 2 * est["sigma"]
                                           .to_numpy()[locked])) if locked.any()
                             else None)
    out["locked_fraction"] = float(locked.mean())
    out["lock"] = None
    if locked.any():
        k = int(np.argmax(locked))
        out["lock"] = {"frame": int(truth["frame"].iloc[k]),
                       "time_s": float(truth["stamp"].iloc[k] - truth["stamp"].iloc[0]),
                       "distance_m": float(s[k] - s[0]), "passes": None}
    dr_err = None
    if odometry is not None:
        odo = check_odometry(odometry)
        if not np.array_equal(odo["frame"].to_numpy(), truth["frame"].to_numpy()):
            raise ValueError("odometry: its frames are not those of the true positions")
        dr_err = dead_reckoning(odo, initial_chainage=s[0]) - s
        out["dead_reckoning"] = _summary(dr_err)
    if indicator_map is not None:
        table = check_indicator_map(indicator_map)
        if out["lock"] is not None:
            c = table["chainage"].to_numpy()
            out["lock"]["passes"] = int(np.sum((c >= s[0]) & (c <= s[k])))
        rows = []
        for oid, c in zip(table["id"], table["chainage"], strict=True):
            if not s[0] <= c <= s[-1]:
                continue
            k = int(np.argmin(np.abs(s - c)))
            row = {"id": int(oid), "chainage": float(c),
                   "frame": int(truth["frame"].iloc[k]),
                   "error": float(err[k]) if locked[k] else None}
            if dr_err is not None:
                row["dead_reckoning_error"] = float(dr_err[k])
            rows.append(row)
        out["passes"] = rows
        out["max_at_passes"] = max((abs(r["error"]) for r in rows
                                    if r["error"] is not None), default=None)
    return out


def _summary(err):
    err = np.asarray(err, np.float64)
    if not len(err):
        return {"max": None, "rms": None, "final": None}
    return {"max": float(np.max(np.abs(err))), "rms": float(np.sqrt(np.mean(err**2))),
            "final": float(err[-1])}


def errors_table(errors) -> pd.DataFrame:
    """The per-pass errors of :func:`position_errors` as a table."""
    return pd.DataFrame(errors.get("passes", []))


def format_errors(errors, title=None) -> str:
    """:func:`position_errors` as a short text report (what the command line prints)."""
    dr = errors.get("dead_reckoning")
    lines = [] if title is None else [title]
    if "passes" in errors:
        lines.append("indicator passes" + ("  (error m: fused, dead reckoning)" if dr
                                           else "  (error m)"))
        for p in errors["passes"]:
            extra = f"  {p['dead_reckoning_error']:+9.2f}" if dr else ""
            fused = "    -  " if p["error"] is None else f"{p['error']:+7.2f}"
            lines.append(f"  id {p['id']:>4}  chainage {p['chainage']:9.1f} m  frame "
                         f"{p['frame']:>6}  {fused}{extra}")
    lock = errors.get("lock")
    if lock is None:
        lines.append("never locked on: no chainage written")
    elif lock["time_s"] > 0:
        passes = "" if lock["passes"] is None else f", {lock['passes']} indicators passed"
        lines.append(f"locked on at frame {lock['frame']} ({lock['time_s']:.1f} s, "
                     f"{lock['distance_m']:.0f} m from the start{passes}); the errors "
                     "below are after the lock")
    lines.append(f"{'':22}{'fused':>10}" + (f"{'dead reckoning':>17}" if dr else ""))
    for key, text in (("max", "maximum error (m)"), ("rms", "RMS error (m)"),
                      ("final", "final error (m)")):
        fused = f"{'-':>10}" if errors[key] is None else f"{errors[key]:10.2f}"
        lines.append(f"  {text:20}{fused}" + (f"{dr[key]:17.2f}" if dr else ""))
    if errors["within_2_sigma"] is not None:
        lines.append(f"  within 2 sigma      {100 * errors['within_2_sigma']:9.1f} %")
    return "\n".join(lines)
