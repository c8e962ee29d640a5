"""Motion verification (sections 3.6-3.7): the measures of a trajectory's path.

:func:`pearson_r` (eq. 5) and :func:`straightness` measure how well a trajectory's
centres fit a line, :func:`curve_fit_r` and :func:`motion_fit_r` a quadratic path
or motion, :func:`path_travel` and :func:`approach_fraction` how far it travels and
how much of its range the camera covers, :func:`approach_r` how steadily its
rectangles grow, :func:`focus_offset` where its path comes from,
:func:`inward_offset` whether it heads for the focus.  Array in, number out.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "approach_fraction",
    "approach_r",
    "curve_fit_r",
    "focus_offset",
    "grows",
    "inward_offset",
    "motion_fit_r",
    "path_travel",
    "pearson_r",
    "straightness",
    "thirds_shift",
]


def thirds_shift(a) -> float:
    """From the mean of a trajectory's first third to that of its last third: the
    shift of the values ``a`` along it (its centres' coordinates, its heights);
    0 for fewer than two values.

    Examples
    --------
    >>> thirds_shift([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    4.0
    """
    a = np.asarray(a, dtype=np.float64)
    if len(a) < 2:
        return 0.0
    k = max(len(a) // 3, 1)
    return float(a[-k:].mean() - a[:k].mean())


def pearson_r(x, y) -> float:
    """Pearson correlation coefficient of the points ``(x_i, y_i)`` (eq. 5).

    0 when either coordinate does not vary (a still cluster has no line; fewer than
    two distinct positions).

    Examples
    --------
    >>> pearson_r([0, 1, 2, 3], [5, 3, 1, -1])
    -1.0
    >>> pearson_r([1, 1, 1], [0, 1, 2])
    0.0
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    x = x - x.mean()
    y = y - y.mean()
    sxx, syy = float(x @ x), float(y @ y)
    scale = max(sxx, syy, 1.0)
    if sxx <= 1e-12 * scale or syy <= 1e-12 * scale:
        return 0.0
    return float(np.clip((x @ y) / np.sqrt(sxx * syy), -1.0, 1.0))


def straightness(x, y) -> float:
    """How well the points ``(x_i, y_i)`` fit a line, whatever its direction.

    ``1 - lambda_min / lambda_max`` of the points' covariance matrix: 1 for points
    on a line, 0 for points spread alike in every direction (or fewer than two
    distinct positions).  Unlike Pearson's r, which is 0 for a perfectly straight
    horizontal or vertical line because one coordinate does not vary, it treats every
    orientation alike.

    Examples
    --------
    >>> straightness([0, 1, 2, 3], [5, 5, 5, 5])  # horizontal: Pearson r is 0 here
    1.0
    >>> round(straightness([0, 1, 0, 1], [0, 0, 1, 1]), 6)
    0.0
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if len(x) < 2:
        return 0.0
    low, high = np.linalg.eigvalsh(np.cov(x, y, bias=True))
    if high <= 1e-12:
        return 0.0
    return float(np.clip(1.0 - max(low, 0.0) / high, 0.0, 1.0))


def curve_fit_r(x, y) -> float:
    """Multiple correlation of a quadratic path through the points ``(x_i, y_i)``.

    Pearson's r (eq. 5) generalized from a line to a parabola: ``y`` is fitted by
    ``a0 + a1 x + a2 x^2`` by least squares and ``R = sqrt(1 - SS_res / SS_tot)``;
    the same with ``x`` and ``y`` swapped, and the larger ``R`` is returned.  A path
    that bends smoothly (an indicator's image path in a curving tunnel) keeps ``R``
    close to 1 where a line fits it ever worse the longer the trajectory; as with
    Pearson's r, a vehicle ahead that jitters in place, or drifts up and down the
    image while keeping its column (approaching, receding), gets ``R`` far from 1,
    because neither coordinate is a function of the other.  A parabola passes
    exactly through any three points, so each way round the fit counts only when
    the abscissa takes at least four distinct values: a cluster hopping between
    two or three fixed spots (stuck pixels near one another, linked into one
    trajectory) is no path, however exactly a parabola joins its spots.  0 for
    fewer than four points, fewer than four distinct values of both coordinates,
    or when a coordinate does not vary.

    Examples
    --------
    >>> t = [0., 1, 2, 3, 4, 5, 6, 7]
    >>> round(curve_fit_r(t, [0.05 * v * v for v in t]), 6)  # a bending path
    1.0
    >>> import numpy as np
    >>> a = np.arange(8) * np.pi / 4  # points around a circle: no path
    >>> round(curve_fit_r(np.cos(a), np.sin(a)), 3)
    0.0
    >>> curve_fit_r([331., 331, 319, 331, 318, 319], [258., 258, 258, 258, 252, 258])
    0.0
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if len(x) < 4:
        return 0.0
    best = 0.0
    for u, v in ((x, y), (y, x)):
        if len(np.unique(u)) < 4:  # a parabola joins any three spots exactly
            continue
        u = u - u.mean()
        v = v - v.mean()
        scale = float(np.abs(u).max())
        total = float(v @ v)
        if scale <= 1e-9 or total <= 1e-12 * max(scale * scale, 1.0):
            continue
        u = u / scale
        design = np.column_stack([np.ones_like(u), u, u * u])
        coef, *_ = np.linalg.lstsq(design, v, rcond=None)
        resid = v - design @ coef
        best = max(best, 1.0 - float(resid @ resid) / total)
    return float(np.sqrt(np.clip(best, 0.0, 1.0)))


def motion_fit_r(t, x, y) -> float:
    """Multiple correlation of a trajectory's motion in time: both coordinates of
    the points ``(x_i, y_i)`` at times (frame numbers) ``t_i`` fitted by quadratics
    in time.

    ``x`` and ``y`` are each fitted by ``a0 + a1 t + a2 t^2`` by least squares and
    ``R = sqrt(1 - (SS_res,x + SS_res,y) / (SS_tot,x + SS_tot,y))``: the share of
    the points' whole scatter that a smooth motion explains.  Unlike
    :func:`curve_fit_r`, which asks whether one coordinate is a function of the
    other (and so measures the residual against the spread of that coordinate
    alone), it does not depend on the direction of the motion: a short, nearly
    horizontal stretch of a path, whose small vertical spread the camera's body
    pitch (every image point moving up and down by the same angle) swamps, still
    fits a smooth motion in time.  A cluster jittering in place, whatever the shape
    of its jitter, fits no motion in time (``R`` near 0).  Over a long stretch of an
    approaching sign's path (its image position grows as the inverse of its
    distance) a quadratic in time fits worse than the path's shape does.  A ratio
    of scatters: the same at any resolution and focal length.  0 for fewer than four
    points, fewer than three distinct times, or points that do not move.

    Examples
    --------
    >>> t = [0., 1, 2, 3, 4, 5, 6, 7]
    >>> x = [300 - 2 * v for v in t]
    >>> y = [200 + (1 if v % 2 else -1) * 0.8 for v in t]  # pitch wiggle, flat path
    >>> round(curve_fit_r(x, y), 3) < 0.5, round(motion_fit_r(t, x, y), 2)
    (True, 0.99)
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)  # jitter in place
    >>> motion_fit_r(t, 320 + rng.normal(0, 2, 8), 240 + rng.normal(0, 2, 8)) < 0.7
    True
    """
    t = np.asarray(t, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if len(t) < 4 or len(np.unique(t)) < 3:
        return 0.0
    u = t - t.mean()
    u = u / float(np.abs(u).max())
    design = np.column_stack([np.ones_like(u), u, u * u])
    points = np.column_stack([x - x.mean(), y - y.mean()])
    total = float((points * points).sum())
    scale = float(np.abs(points).max())
    if total <= 1e-12 * max(scale * scale, 1.0):
        return 0.0
    coef, *_ = np.linalg.lstsq(design, points, rcond=None)
    resid = points - design @ coef
    return float(np.sqrt(np.clip(1.0 - float((resid * resid).sum()) / total, 0.0, 1.0)))


def path_travel(x, y, h) -> float:
    """How far a trajectory travels, in units of its own size: the distance between
    the mean centre of its first third and that of its last third, over the median
    rectangle height.

    An object the camera approaches moves away from the vanishing point as it grows:
    its travel relative to its size is its offset from the line of sight relative to
    its size times the relative change of its distance, whatever the camera's
    resolution or focal length (about 0.5 or more over ten frames for a sign on the
    wall at 60 km/h, several over its whole path).  Something that keeps its place
    in the image (the far end of a curving row of lamps, which the view follows)
    travels by the jitter of its rectangle only, a small fraction of its height,
    however straight that jitter lines up.  0 for fewer than two points.

    Examples
    --------
    >>> round(path_travel([0, 3, 6, 9, 12, 15], [0, 1, 2, 3, 4, 5], [10] * 6), 3)
    1.265
    >>> round(path_travel([5, 6, 5, 6, 5, 6], [9, 10, 9, 10, 9, 10], [16] * 6), 3)
    0.0
    """
    if len(x) < 2:
        return 0.0
    d = np.hypot(thirds_shift(x), thirds_shift(y))
    return float(d / max(float(np.median(np.asarray(h, dtype=np.float64))), 1e-9))


def approach_fraction(h) -> float:
    """How much of its range a trajectory's object covered: ``1 - h_first / h_last``,
    where ``h_first`` and ``h_last`` are the median rectangle heights of its first
    and last thirds.

    An object of fixed size seen at range ``Z`` is ``f H / Z`` pixels tall, so
    ``1 - h_first / h_last = (Z_first - Z_last) / Z_first``: the fraction of the
    first range the camera travelled towards it (from the middle of the first third
    to that of the last), whatever the focal length, the resolution, the object's
    size or the frame rate.  In a third of a second at 80 km/h the camera covers
    about 0.15 of a sign's range from 50 m, and half of it from 15 m.  A cluster that keeps its range
    (a vehicle ahead, a jitter in place) covers about 0, up or down by its
    rectangle's jitter.  Negative when the object recedes; 0 for fewer than two
    points or heights that are not positive.

    Examples
    --------
    >>> approach_fraction([20, 21, 20, 30, 31, 32, 40, 39, 40])  # range halved
    0.5
    >>> approach_fraction([16, 17, 16, 17, 16, 17])
    0.0
    """
    h = np.asarray(h, dtype=np.float64)
    n = len(h)
    if n < 2:
        return 0.0
    k = max(n // 3, 1)
    first, last = float(np.median(h[:k])), float(np.median(h[-k:]))
    if first <= 0 or last <= 0:
        return 0.0
    return float(1.0 - first / last)


def _path_or_motion_r(x, y, t):
    return max(curve_fit_r(x, y), motion_fit_r(t, x, y))


#: the measures of ``PCCVerifier(criterion=...)``, each of ``(x, y, t)``
_MEASURES = {
    "pearson": lambda x, y, t: pearson_r(x, y),
    "principal": lambda x, y, t: straightness(x, y),
    "quadratic": lambda x, y, t: curve_fit_r(x, y),
    "quadratic-motion": _path_or_motion_r,
}


def approach_r(t, h) -> float:
    """How steadily a trajectory's object approaches: minus Pearson's r between the
    times ``t`` (frame numbers) and the inverse rectangle heights ``1 / h``.

    An object of fixed size at range ``Z`` is ``f H / Z`` pixels tall, so ``1 / h``
    is proportional to its range, which falls linearly in time as the camera
    drives toward it at a steady speed: 1 for a steady approach, -1 for a steady
    recession, near 0 for an object that keeps its range.  A rotation of the
    camera (vibration, pitch, yaw) moves every image point but changes no size,
    so a far sign whose positions the camera's shake scatters still approaches
    steadily.  A ratio of sizes: the same at any focal length, resolution or
    sign size.  0 for fewer than three points or heights that do not change or
    are not positive.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(10.0)
    >>> round(approach_r(t, 700.0 / (40.0 - 0.8 * t)), 3)  # driving toward a sign
    1.0
    >>> approach_r(t, [12.0] * 10)  # a vehicle ahead keeping its distance
    0.0
    """
    t = np.asarray(t, dtype=np.float64)
    h = np.asarray(h, dtype=np.float64)
    if len(t) < 3 or np.any(h <= 0):
        return 0.0
    return 0.0 - pearson_r(t, 1.0 / h)  # 0.0, not -0.0, when it keeps its range



def focus_offset(x, y, width, height) -> float:
    """Where a trajectory's path can come from: how near its line passes the
    frame's centre, in units of half the frame.

    An object the camera approaches along the road moves away from the focus of
    expansion (where the road goes, near the frame's middle) along a line through
    it: the line of its centres -- their principal axis, in the frame's
    coordinates over half its ``width`` and ``height`` (0 at the centre, 1 on the
    border) -- passes the centre at about the focus's own offset, a few tenths
    at most (the camera's yaw and pitch; a curve or a crest turns the camera and
    slides every point alike).  A mark burned into the picture (a grey-scale bar
    at the edge, a clock's text) keeps its place while its thresholded rectangle
    grows and shrinks with the frame's grey levels: its centres slide along the
    mark, whose line passes the centre at the mark's own offset.  A far sign's
    path is short and its rectangle small and noisy, but the sign itself is near
    the focus, so any line through it passes near the centre.  Nothing is
    extrapolated from the rectangles' heights (which change too little on a far
    sign for that, while the camera's turning moves it).  A ratio of lengths in
    the image, the same at any resolution; the focus's own offset grows with the
    focal length (``f tan(yaw) / (width / 2)``).  A path jittering in place has
    no direction: its axis, and so its offset, may fall anywhere between 0 and
    its mean centre's (``min_travel`` rejects such a path).  The offset of the
    mean centre for a still path, ``inf`` for no points.

    Examples
    --------
    >>> z = np.array([60.0, 40, 30, 20, 12])  # a sign 4 m left, 0.3 m up
    >>> round(focus_offset(320 - 700 * 4 / z, 240 - 700 * 0.3 / z, 640, 480), 6)
    0.0
    >>> bar = ([628.0, 628.2, 628.1, 628.3], [230.0, 236, 240, 246])  # at the edge
    >>> round(focus_offset(*bar, 640, 480), 3)
    0.963
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if len(x) == 0:
        return float("inf")
    u = (x - width / 2) / (width / 2)
    v = (y - height / 2) / (height / 2)
    mu, mv = float(u.mean()), float(v.mean())
    du, dv = u - mu, v - mv
    cov = np.array([[du @ du, du @ dv], [du @ dv, dv @ dv]])
    if np.trace(cov) <= 1e-18:  # a still path: where it is
        return float(np.hypot(mu, mv))
    _, vecs = np.linalg.eigh(cov)
    eu, ev = vecs[:, 1]  # the principal direction
    return float(abs(mu * ev - mv * eu))


def grows(h) -> bool:
    """Whether a trajectory's object grows: the mean rectangle height of its last
    third above that of its first.

    An object the camera approaches grows, however slowly (a far sign from a
    crawling queue by a pixel); one the camera falls behind shrinks, and one that
    keeps its distance grows or shrinks by its rectangle's jitter.  False for fewer
    than two points.

    Examples
    --------
    >>> grows([4, 4, 4, 5, 4, 5]), grows([9, 8, 8, 7, 6, 6])
    (True, False)
    """
    return thirds_shift(h) > 0


def inward_offset(x, y, width, height) -> float:
    """How far a trajectory still is from the frame's centre as it heads for it:
    the mean of its centres projected on its direction of motion, negated, in
    units of half the frame's ``width`` and ``height`` (0 at the centre, 1 on the
    border).

    The direction of motion is that from the mean centre of its first third to
    that of its last third (as in :func:`path_travel`).  An object the camera
    approaches moves away from the focus of expansion: relative to a focus at
    ``F`` its motion ``D`` and its place ``P`` have ``D . (P - F) > 0``, so its
    inward offset is below ``-D . F / |D|``, at most the focus's own offset from
    the centre (the camera's yaw and pitch, ``f tan(yaw) / (width / 2)``; a sign
    near the focus, far away, may head for the frame's centre while it leaves the
    focus).  An object the camera falls behind (a vehicle ahead pulling away, its
    warm wheels or exhaust) shrinks toward the focus: its inward offset is about
    its distance from the focus, up to 1 and more at the frame's border.  One that
    keeps its distance keeps its place (:func:`path_travel`).  Negative for a path
    moving outward; 0 for fewer than two points or a path whose thirds coincide.
    A ratio of lengths in the image, the same at any resolution, frame rate and
    speed.

    Examples
    --------
    >>> z = np.array([60.0, 40, 30, 20, 12])  # a sign 4 m left, 0.3 m up: outward
    >>> round(inward_offset(320 - 700 * 4 / z, 240 - 700 * 0.3 / z, 640, 480), 3)
    -0.366
    >>> z = z[::-1]  # a tail light 1 m right, 0.5 m down, pulling away: inward
    >>> round(inward_offset(320 + 700 * 1 / z, 240 + 700 * 0.5 / z, 640, 480), 2)
    0.11
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    n = len(x)
    if n < 2:
        return 0.0
    u = (x - width / 2) / (width / 2)
    v = (y - height / 2) / (height / 2)
    du, dv = thirds_shift(u), thirds_shift(v)
    norm = float(np.hypot(du, dv))
    if norm <= 1e-12:
        return 0.0
    return float(-(u.mean() * du + v.mean() * dv) / norm)
