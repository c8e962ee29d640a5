"""Which wall a sign stands on, from its trajectory's boxes.

A sign at lateral offset ``X`` (m, > 0 right of the camera) and depth ``Z`` appears
``f X / Z`` pixels right of the image's centre, and its box is ``h = f H / Z`` pixels
tall (sign height ``H``): the box's centre moves ``X / H`` pixels per pixel of
growth, away from the centre on the sign's own side.  In a curve of radius ``R`` the
wall ahead bends by ``Z**2 / (2 R)``, which adds ``f**2 H / (2 R h)`` (a term in
``1 / h``); a camera yawed off the tunnel's axis, or a principal point off the
image's centre, adds a constant.  Fitting the centre as ``a + b h + c / h`` keeps
both out of ``b``, whose sign is the side: no calibration is needed.
"""

from __future__ import annotations

import math

import numpy as np

from tunnelsense.positioning._defaults import SIDE_MIN_T

__all__ = ["observed_side", "side_code", "side_error_of", "side_statistic"]

#: Codes of a side (``side_code``): unknown 0, left -1, right +1.
_CODES = {"left": -1, "right": 1}


def sides_used(sides, side_error):
    """The walls of the map's indicators (-1, +1; 0 unknown) when the side of a
    pass can tell places apart: both walls named and ``0 < side_error < 0.5``;
    else None (one wall, or none named: the side separates no place)."""
    if sides is None or side_error is None or not 0.0 < float(side_error) < 0.5:
        return None
    sides = np.asarray(sides, np.int64)
    return sides if (sides < 0).any() and (sides > 0).any() else None


def side_code(values) -> np.ndarray:
    """``-1`` for "left", ``+1`` for "right", ``0`` for anything else (unknown).

    Case and surrounding blanks are ignored; an empty or missing entry is unknown.

    Examples
    --------
    >>> from tunnelsense.positioning._side import side_code
    >>> side_code(["left", " Right", "", None]).tolist()
    [-1, 1, 0, 0]
    """
    return np.asarray([_CODES.get(str(v).strip().lower(), 0) if v is not None else 0
                       for v in values], np.int64)


def observed_side(height, centre, *, min_boxes=8, min_t=SIDE_MIN_T,
                  min_noise_px=0.5):
    """The wall a sign stands on, from how its box drifts as it grows.

    Fits the box's horizontal centre ``x = a + b h + c / h`` over its height ``h``
    (``c / h``: a curve; ``a``: the camera's yaw and principal point) and leaves
    out boxes far off the line (a box merged with a lamp for a frame), then fits
    again.  The side is the sign of ``b`` when ``|b|`` is at least ``min_t`` of
    its standard error; otherwise, or with too few boxes, it is unknown.

    Parameters
    ----------
    height : array-like of shape (n,)
        Box heights (px), in the order of the trajectory.
    centre : array-like of shape (n,)
        Horizontal centres of the boxes (px; ``bb_left + bb_width / 2``).  NaN
        entries (no box position given) are left out.
    min_boxes : int, default=8
        Fewest boxes (with a centre) that can tell a side.
    min_t : float, default=3.0
        Least ratio of ``|b|`` to its standard error.
    min_noise_px : float, default=0.5
        Least standard deviation of a box's centre (px) assumed: boxes that fit
        the line exactly (drawn, or rounded alike) do not make any drift certain.

    Returns
    -------
    side : {"left", "right", "unknown"}

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.positioning import observed_side
    >>> z = np.linspace(60.0, 12.0, 40)           # depth (m) as the sign nears
    >>> h = 800.0 * 1.0 / z                       # f = 800 px, sign 1 m tall
    >>> observed_side(h, 320.0 - 800.0 * 3.7 / z)  # 3.7 m left of the camera
    'left'
    >>> observed_side(h, 320.0 + 800.0 * 3.7 / z + 800.0 * z / 400.0)  # right, a curve
    'right'
    >>> observed_side(h[:5], 320.0 - 800.0 * 3.7 / z[:5])
    'unknown'
    """
    t = side_statistic(height, centre, min_boxes=min_boxes, min_noise_px=min_noise_px)
    if not np.isfinite(t) or abs(t) < float(min_t):
        return "unknown"
    return "right" if t > 0 else "left"


def side_statistic(height, centre, *, min_boxes=8, min_noise_px=0.5):
    """The drift of :func:`observed_side` over its standard error, ``b / se(b)``:
    > 0 right, < 0 left; NaN when it cannot be told (too few boxes, heights that
    do not separate the terms).

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.positioning._side import side_statistic
    >>> z = np.linspace(60.0, 12.0, 40)
    >>> bool(side_statistic(800.0 / z, 320.0 - 800.0 * 3.7 / z) < -3.0)
    True
    """
    h = np.asarray(height, np.float64).ravel()
    x = np.asarray(centre, np.float64).ravel()
    if h.shape != x.shape:
        raise ValueError(f"height and centre must have the same length; got {len(h)} "
                         f"and {len(x)}")
    ok = np.isfinite(h) & np.isfinite(x) & (h > 0)
    h, x = h[ok], x[ok]
    keep = np.ones(len(h), bool)
    b, se = 0.0, np.inf
    for _ in range(2):
        if keep.sum() < max(int(min_boxes), 4):
            return math.nan
        fit = _drift(h[keep], x[keep], float(min_noise_px))
        if fit is None:
            return math.nan
        b, se, coef = fit
        hm = np.median(h[keep])
        resid = x - np.column_stack([np.ones_like(h), h / hm, hm / h]) @ coef
        mad = 1.4826 * np.median(np.abs(resid[keep]))
        new = np.abs(resid) <= max(4.0 * mad, 3.0 * float(min_noise_px))
        if np.array_equal(new, keep):
            break
        keep = new
    if not np.isfinite(se) or se <= 0:
        return math.nan
    return float(b / se)


def _drift(h, x, min_noise):
    """Least-squares ``x = a + b' h / hm + c' hm / h``: ``(b, se(b), coef)``, ``b``
    per pixel of height; None when the heights do not separate the terms."""
    hm = float(np.median(h))
    A = np.column_stack([np.ones_like(h), h / hm, hm / h])
    n = len(h)
    try:
        G = np.linalg.inv(A.T @ A)
    except np.linalg.LinAlgError:
        return None
    coef = G @ (A.T @ x)
    rss = float(np.sum((x - A @ coef) ** 2))
    s2 = max(rss / (n - 3), min_noise * min_noise)
    var_b = s2 * G[1, 1]
    if not np.isfinite(var_b) or var_b <= 0:
        return None
    return float(coef[1] / hm), float(np.sqrt(var_b) / hm), coef


def side_error_of(t, side_error, inflation=3.0):
    """Probability that a pass's observed side is the other wall, from its drift's
    t statistic ``t`` (:func:`side_statistic`): the normal tail beyond
    ``|t| / inflation``, and at least ``side_error``.

    ``inflation`` widens the drift's standard error: the boxes' jitter is taken as
    independent from frame to frame, which a real detector's need not be (a box
    that lags as a sign brightens); a drift of three standard errors, the least
    :func:`~tunnelsense.positioning.observed_side` reads, then counts for an error
    of 0.16; once the tail falls below ``side_error`` it is ``side_error`` (at
    0.05: a drift of 5 standard errors or more).  An infinite ``t`` (a
    side given as sure) gives ``side_error``.

    Examples
    --------
    >>> from tunnelsense.positioning._side import side_error_of
    >>> round(side_error_of(3.0, 0.05), 3), side_error_of(9.0, 0.05)
    (0.159, 0.05)
    """
    tail = 0.5 * math.erfc(abs(float(t)) / float(inflation) / math.sqrt(2.0))
    return max(float(side_error), tail)
