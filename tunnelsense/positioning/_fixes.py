"""Where a sign passes the camera, from the image path of its trajectory.

An indicator of height ``H`` at depth ``Z`` is ``h = f H / Z`` pixels tall, so ``1 / h``
falls linearly with the distance driven and reaches 0 where the sign passes the
camera (time to contact).  Fitting ``1 / h`` against the odometry's distance and
extrapolating to 0 gives the odometry distance of the pass -- from the whole
trajectory, not only the last frame the sign is seen (it leaves the image some
9 m before the camera passes it).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from tunnelsense.exceptions import InputFormatError

__all__ = ["DETECTION_TABLE_COLUMNS", "detection_table", "estimate_pass",
           "scale_from_slope"]

#: Columns of :func:`detection_table`.
DETECTION_TABLE_COLUMNS = ("frame", "track_id", "bb_height")


def detection_table(detections) -> pd.DataFrame:
    """The detector's output as a table ``frame, track_id, bb_height``.

    Parameters
    ----------
    detections : DataFrame or sequence of FrameRecord
        A MOTChallenge results table (:func:`tunnelsense.io.read_mot_results`, or
        any table with ``frame``, ``id`` or ``track_id``, and ``bb_height``), or the
        frame records ``make_indicator_pipeline().predict`` returns (their
        ``payload["detections"]``).

    Returns
    -------
    table : DataFrame
        Sorted by frame and track; with ``bb_centre_x`` too (the box's horizontal
        centre, px: the side of the road it is seen on) when the boxes' ``bb_left``
        and ``bb_width`` are given (always in frame records).

    Examples
    --------
    >>> import pandas as pd
    >>> from tunnelsense.positioning import detection_table
    >>> detection_table(pd.DataFrame({"frame": [2, 1], "id": [7, 7],
    ...                               "bb_height": [11.0, 10.0]}))
       frame  track_id  bb_height
    0      1         7       10.0
    1      2         7       11.0
    """
    if isinstance(detections, pd.DataFrame):
        table = detections.rename(columns={"id": "track_id"})
        missing = [c for c in DETECTION_TABLE_COLUMNS if c not in table.columns]
        if missing:
            raise InputFormatError(
                f"detections: a table needs the columns frame, id (or track_id) and "
                f"bb_height; missing {missing}"
            )
        lateral = {"bb_left", "bb_width"} <= set(table.columns)
        if lateral:
            table = table.assign(bb_centre_x=pd.to_numeric(table["bb_left"])
                                 + pd.to_numeric(table["bb_width"]) / 2.0)
        table = table[list(DETECTION_TABLE_COLUMNS)
                      + (["bb_centre_x"] if lateral else [])]
    elif isinstance(detections, Sequence) or hasattr(detections, "__iter__"):
        rows = []
        tours = set()
        for record in detections:
            payload = getattr(record, "payload", None)
            if payload is None or "detections" not in payload:
                raise InputFormatError(
                    "detections: expected frame records from the indicator pipeline's "
                    "predict (payload['detections']) or a results table"
                )
            tours.add(record.tour)
            det = np.asarray(payload["detections"], np.float64).reshape(-1, 6)
            rows.extend((record.frame, int(d[4]), d[3], d[0] + d[2] / 2.0)
                        for d in det)
        if len(tours) > 1:
            raise InputFormatError(
                f"detections: frame records of one tour expected; got {sorted(tours)}"
            )
        table = pd.DataFrame(rows, columns=[*DETECTION_TABLE_COLUMNS, "bb_centre_x"])
    else:
        raise InputFormatError(
            f"detections: expected a table or frame records; got {type(detections)}"
        )
    table = table.astype({"frame": np.int64, "track_id": np.int64,
                          "bb_height": np.float64})
    h = table["bb_height"].to_numpy()
    if not np.all(np.isfinite(h)) or np.any(h <= 0):
        raise InputFormatError("detections: bb_height must be finite and positive")
    return table.sort_values(["frame", "track_id"], kind="stable").reset_index(
        drop=True)


def estimate_pass(distance, height, *, slope=None, noise=None):
    """Odometry distance at which a sign passes the camera, from its box heights.

    Fits ``1 / h = a + b d`` (weighted by ``h**2``: a box's height error is a fixed
    fraction of it) and solves ``a + b d = 0``.  Boxes whose relative error is more
    than four robust standard deviations (and 1 %) off the line -- a box merged with
    a lamp for a frame -- are left out and the line fitted again.

    Parameters
    ----------
    distance : array-like of shape (n,)
        Odometry distance at each detection (m), increasing.
    height : array-like of shape (n,)
        Box height of each detection (px).
    slope : float or None, default=None
        The known ``b = -c / (f H)`` (odometry scale ``c``, focal length ``f`` in px,
        sign height ``H`` in m); None estimates it from the scale growth alone.
    noise : float or None, default=None
        Relative standard deviation of a box's height known from other trajectories
        (the detector's, e.g. 0.03); the variance is computed with at least this
        noise.  A short trajectory's residuals can be small by chance (a dozen boxes,
        some left out as outliers) and its variance then far too small for a pass
        extrapolated metres beyond its last box.  None: the residuals alone.

    Returns
    -------
    pass_distance : float
        NaN when the sign does not approach (``b >= 0``) or there are too few
        detections (fewer than 3, or 2 with a known slope).
    variance : float
        Of ``pass_distance``, from the fit's residuals.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.positioning import estimate_pass
    >>> d = np.arange(0.0, 50.0, 1.0)
    >>> d_pass, var = estimate_pass(d, 800.0 / (60.0 - d))
    >>> round(d_pass, 6)
    60.0
    """
    return _estimate_pass(distance, height, slope, noise)[:2]


def _estimate_pass(distance, height, slope=None, noise=None):
    """:func:`estimate_pass`, and the relative noise of the boxes kept (its square)
    with its degrees of freedom: ``(pass_distance, variance, noise2, dof)``."""
    nan4 = (float("nan"),) * 4
    d = np.asarray(distance, np.float64)
    h = np.asarray(height, np.float64)
    robust = _robust_fit(d, h, slope)
    if robust is None:
        return nan4
    fit, keep = robust
    # the fit's variance per unit weight is the boxes' relative variance over their
    # mean square height (weights h**2 summing to n)
    mean_h2 = float(np.mean(h[keep] ** 2))
    noise2 = fit[4] * mean_h2
    dof = int(keep.sum()) - (1 if slope is not None else 2)
    if noise is not None and float(noise) ** 2 > noise2:
        fit = (*fit[:4], float(noise) ** 2 / mean_h2, *fit[5:])
    return (*_solve(*fit), noise2, dof)


def scale_from_slope(distance, height, size, noise=None, min_dof=20):
    """The odometry's scale factor from the growth of one sign's box height.

    ``1 / h = c (d_pass - d) / (f H)``: the slope of ``1 / h`` against the odometry
    distance is ``-c / (f H)``, so with the sign's size in the image ``f H`` (focal
    length in px times its height in m) known, one trajectory measures the scale
    ``c`` -- before a second sign is passed.  (A ratio of box heights alone gives
    the time to contact, not the scale: the absolute size is what sets it.)

    Parameters
    ----------
    distance, height : array-like of shape (n,)
        Odometry distance (m) and box height (px) of each detection.
    size : float
        ``focal_length_px * sign_height_m``.
    noise : float or None, default=None
        Least relative box-height noise (as in :func:`estimate_pass`).
    min_dof : int, default=20
        Fewest boxes beyond the line's two parameters: a short trajectory (a sign
        already near when the record began) measures the slope poorly, and the
        variance its few residuals give is too often far too small.

    Returns
    -------
    scale, variance : float
        NaN when the sign does not approach or there are too few boxes; the
        variance is the fit's alone (not that of ``size``), times ``dof / (dof - 2)``
        (the variance of Student's t: the boxes' noise is estimated from them).

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.positioning import scale_from_slope
    >>> d = np.arange(0.0, 50.0, 0.5)          # odometry reads 2 % too much
    >>> h = 800.0 * 1.0 / (0.98 * (60.0 - d))  # f = 800 px, H = 1 m
    >>> c, var = scale_from_slope(d, h, 800.0 * 1.0)
    >>> round(c, 6)
    0.98
    """
    d = np.asarray(distance, np.float64)
    h = np.asarray(height, np.float64)
    robust = _robust_fit(d, h, None)
    if robust is None:
        return float("nan"), float("nan")
    (_, b, _, sxx, sigma2, n, _), keep = robust
    if not b < 0 or not np.isfinite(sxx):
        return float("nan"), float("nan")
    if noise is not None:
        sigma2 = max(sigma2, float(noise) ** 2 / float(np.mean(h[keep] ** 2)))
    # a variance from the residuals of few boxes is itself uncertain (Student's t)
    dof = n - 2
    if dof < min_dof:
        return float("nan"), float("nan")
    size = float(size)
    return float(-b * size), float(sigma2 / (n * sxx) * size * size * dof / (dof - 2))


def _robust_fit(d, h, slope):
    """:func:`_fit` without outlying boxes: ``(fit, keep)``, or None."""
    if len(d) < (2 if slope is not None else 3):
        return None
    # a box merged with a lamp now and then is an outlier: start from a line fitted
    # robustly (Theil-Sen), then refit without the boxes whose relative error is far
    # beyond the others' (robust scale, MAD)
    a, b = _theil_sen(d - d[-1], 1.0 / h, slope)
    keep = np.ones(len(d), bool)
    for _ in range(10):
        rel = h * (1.0 / h - a - b * (d - d[-1]))  # relative error of each box
        scale = 1.4826 * np.median(np.abs(rel[keep]))
        new = np.abs(rel) <= max(4.0 * scale, 0.01)
        if new.sum() < (2 if slope is not None else 3):
            return None
        keep, done = new, np.array_equal(new, keep)
        fit = _fit(d[keep], h[keep], d[-1], slope)
        if fit is None:
            return None
        a, b = fit[:2]
        if done:
            break
    return fit, keep


def _theil_sen(x, y, slope):
    """Median of the pairwise slopes (or ``slope``), and the median intercept."""
    if slope is None:
        i, j = np.triu_indices(len(x), 1)
        dx = x[j] - x[i]
        ok = dx != 0
        if not ok.any():
            return 0.0, 0.0
        slope = np.median((y[j] - y[i])[ok] / dx[ok])
    return float(np.median(y - slope * x)), float(slope)


def _fit(d, h, d_ref, slope):
    """Weighted line fit of ``1 / h`` on ``d - d_ref``: ``(a, b, xm, sxx, sigma2, n)``."""
    n = len(d)
    if n < (2 if slope is not None else 3):
        return None
    x = d - d_ref  # relative to the last detection: a well-conditioned fit
    y = 1.0 / h
    w = h * h
    w = w / w.sum()
    if slope is None:
        xm, ym = w @ x, w @ y
        sxx = w @ (x - xm) ** 2
        if sxx <= 0:
            return None
        b = (w @ ((x - xm) * (y - ym))) / sxx
        a = ym - b * xm
        dof = n - 2
    else:
        b = float(slope)
        a = w @ (y - b * x)
        xm, sxx = 0.0, np.inf
        dof = n - 1
    resid = y - a - b * x
    sigma2 = (n * (w @ resid**2)) / max(dof, 1)  # per unit weight (weights sum to n)
    return a, b, xm, sxx, sigma2, n, d_ref


def _solve(a, b, xm, sxx, sigma2, n, d_ref):
    if not b < 0:
        return float("nan"), float("nan")
    # variance of a + b x at x = x*, solved for x*: var(x*) = var(a + b x*) / b^2
    x_star = -a / b
    var_line = sigma2 / n * (1.0 + (x_star - xm) ** 2 / sxx)
    return float(d_ref + x_star), float(var_line / (b * b))
