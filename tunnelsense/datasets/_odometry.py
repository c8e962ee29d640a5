"""Where the camera was: true chainage, wheel/IMU odometry and the indicator map.

Dead reckoning in a tunnel integrates the vehicle's wheel speed and yaw rate; its error
grows with the distance driven.  The emergency-telephone indicators stand at surveyed
positions (every 200 m), so each one the camera passes can reset that error
(Wang et al., 2013, section 1).  This module gives, for a simulated tour, the three
tables a positioning system works with:

* ``positions.csv`` -- ``frame,stamp,chainage``: the true chainage (metres along the
  tunnel's axis from the tour's start) of the camera at each frame;
* ``odometry.csv`` -- ``frame,stamp,speed,yaw_rate``: what the vehicle's odometry
  reports, with a scale error, a bias and noise;
* ``indicators.csv`` -- ``id,chainage,side``: the surveyed indicator map (``id`` is
  the indicator's ground-truth id in ``gt/gt.txt``).

Odometry noise comes from its own random stream, derived from the tour's seed, so the
frames and ground truth of a tour do not depend on it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from sklearn.utils import check_random_state

from tunnelsense._records import Tour

__all__ = [
    "INDICATORS_FILE",
    "ODOMETRY_FILE",
    "POSITIONS_FILE",
    "TourKinematics",
    "make_tunnel_kinematics",
    "make_tunnel_odometry",
]

POSITIONS_FILE = "positions.csv"
ODOMETRY_FILE = "odometry.csv"
INDICATORS_FILE = "indicators.csv"

#: Odometry errors the tour writer uses (see :func:`make_tunnel_odometry`).
ODOMETRY_DEFAULTS = {
    "scale_error": 0.03,
    "speed_bias": 0.05,
    "speed_noise": 0.1,
    "yaw_bias": 0.002,
    "yaw_noise": 0.005,
}


@dataclass(frozen=True, eq=False)
class TourKinematics:
    """The true motion of a simulated camera and the indicators it drives past.

    Parameters
    ----------
    stamps : ndarray of shape (n_frames,)
        Time of each frame (s), from 0.
    chainage : ndarray of shape (n_frames,)
        Arc length along the tunnel from the tour's start (m) at each frame.
    speed : ndarray of shape (n_frames,)
        Speed (m/s) held from each frame to the next.
    curvature : float
        Signed curvature of the tunnel (1/m, > 0 curves right); the yaw rate is
        ``speed * curvature``.
    indicator_chainage : ndarray of shape (n_indicators,)
        Chainage of each indicator (m), increasing.
    indicator_ids : ndarray of shape (n_indicators,)
        Their ids (the ground-truth ids of the indicators' boxes).
    seed : int
        The tour's seed; the odometry's noise is drawn from a stream derived from it.
    side : str or ndarray of str, default="left"
        The tunnel wall the indicators stand on ("left" or "right"), one for all or
        one per indicator.
    """

    stamps: np.ndarray
    chainage: np.ndarray
    speed: np.ndarray
    curvature: float
    indicator_chainage: np.ndarray
    indicator_ids: np.ndarray
    seed: int
    side: str | np.ndarray = "left"

    def positions(self) -> pd.DataFrame:
        """The true chainage per frame: ``frame, stamp, chainage``."""
        return pd.DataFrame({
            "frame": np.arange(1, len(self.stamps) + 1, dtype=np.int64),
            "stamp": np.asarray(self.stamps, np.float64),
            "chainage": np.asarray(self.chainage, np.float64),
        })

    def write(self, path) -> list[Path]:
        """Write the tour's three tables into the folder ``path``."""
        return write_companions(self, path)

    def indicator_map(self) -> pd.DataFrame:
        """The surveyed indicator map: ``id, chainage, side``."""
        return pd.DataFrame({
            "id": np.asarray(self.indicator_ids, np.int64),
            "chainage": np.asarray(self.indicator_chainage, np.float64),
            "side": self.side,
        })


def write_companions(kinematics, path) -> list[Path]:
    """Write ``positions.csv``, ``odometry.csv`` and ``indicators.csv`` into ``path``.

    The odometry has the default errors (:data:`ODOMETRY_DEFAULTS`), drawn from the
    stream derived from the tour's seed.
    """
    positions, odometry, indicators = make_tunnel_odometry(kinematics)
    path = Path(path)
    written = []
    for name, table in (
        (POSITIONS_FILE, positions),
        (ODOMETRY_FILE, odometry),
        (INDICATORS_FILE, indicators),
    ):
        table.to_csv(path / name, index=False, lineterminator="\n")
        written.append(path / name)
    return written


def with_kinematics(tour: Tour, kinematics: TourKinematics) -> Tour:
    """``tour`` carrying ``kinematics`` as ``tour.kinematics`` (same class, same data).

    :func:`tunnelsense.io.write_tour` then writes the three tables beside the
    MOTChallenge files.
    """
    object.__setattr__(tour, "kinematics", kinematics)  # Tour is frozen, not slotted
    return tour


def _odometry_stream(seed):
    # a child of the tour's seed sequence: independent of the renderer's generator,
    # which is seeded with the seed itself
    return np.random.default_rng(np.random.SeedSequence(int(seed)).spawn(1)[0])


def _check_error(name, value, lo, hi):
    v = float(value)
    if not (lo <= v <= hi):
        raise ValueError(f"{name} must be in [{lo}, {hi}]; got {value!r}")
    return v


def make_tunnel_odometry(
    tour,
    *,
    scale_error=ODOMETRY_DEFAULTS["scale_error"],
    speed_bias=ODOMETRY_DEFAULTS["speed_bias"],
    speed_noise=ODOMETRY_DEFAULTS["speed_noise"],
    yaw_bias=ODOMETRY_DEFAULTS["yaw_bias"],
    yaw_noise=ODOMETRY_DEFAULTS["yaw_noise"],
    random_state=None,
):
    """True positions, simulated odometry and the indicator map of a simulated tour.

    The odometry reports ``speed * (1 + scale_error) + speed_bias`` plus white noise
    of ``speed_noise`` (a wheel-speed sensor with a wrong tyre radius), and the yaw
    rate ``speed * curvature + yaw_bias`` plus white noise of ``yaw_noise`` (a
    gyro).  Integrated, its distance is off by ``scale_error`` of the distance
    driven, plus ``speed_bias`` times the time.

    Parameters
    ----------
    tour : Tour or TourKinematics
        A tour from :func:`make_tunnel_tour` (its ``kinematics``), or
        :func:`make_tunnel_kinematics`.
    scale_error : float, default=0.03
        Relative error of the wheel speed (0.03: reads 3 % too much).
    speed_bias : float, default=0.05
        Constant speed offset (m/s).
    speed_noise : float, default=0.1
        Standard deviation of the speed's white noise per frame (m/s).
    yaw_bias : float, default=0.002
        Constant gyro offset (rad/s).
    yaw_noise : float, default=0.005
        Standard deviation of the yaw rate's white noise per frame (rad/s).
    random_state : int, RandomState instance or None, default=None
        Seed of the noise; None draws from a stream derived from the tour's seed (so
        a tour always gets the same odometry, and its frames do not change).

    Returns
    -------
    positions : DataFrame
        ``frame, stamp, chainage`` (the truth).
    odometry : DataFrame
        ``frame, stamp, speed, yaw_rate``; the speed of a frame holds until the next.
    indicators : DataFrame
        ``id, chainage, side``: the surveyed map.

    Examples
    --------
    >>> from tunnelsense.datasets import make_tunnel_kinematics, make_tunnel_odometry
    >>> truth = make_tunnel_kinematics(2000.0, random_state=0)
    >>> positions, odometry, indicators = make_tunnel_odometry(truth, scale_error=0.03)
    >>> list(odometry.columns)
    ['frame', 'stamp', 'speed', 'yaw_rate']
    >>> round(float(indicators["chainage"].diff().iloc[1]), 6)
    200.0
    """
    kin = getattr(tour, "kinematics", tour)
    if not isinstance(kin, TourKinematics):
        raise TypeError(
            "tour must be a simulated tour (make_tunnel_tour) or TourKinematics; a "
            "tour read from disk has its positions.csv, odometry.csv and "
            "indicators.csv beside it"
        )
    scale_error = _check_error("scale_error", scale_error, -0.5, 0.5)
    speed_bias = _check_error("speed_bias", speed_bias, -5.0, 5.0)
    speed_noise = _check_error("speed_noise", speed_noise, 0.0, 10.0)
    yaw_bias = _check_error("yaw_bias", yaw_bias, -1.0, 1.0)
    yaw_noise = _check_error("yaw_noise", yaw_noise, 0.0, 1.0)
    rng = (
        _odometry_stream(kin.seed)
        if random_state is None
        else np.random.default_rng(check_random_state(random_state).randint(2**31 - 1))
    )
    n = len(kin.stamps)
    speed = np.asarray(kin.speed, np.float64)
    v = speed * (1.0 + scale_error) + speed_bias + rng.normal(0.0, 1.0, n) * speed_noise
    yaw = speed * kin.curvature + yaw_bias + rng.normal(0.0, 1.0, n) * yaw_noise
    positions = kin.positions()
    odometry = positions[["frame", "stamp"]].assign(speed=v, yaw_rate=yaw)
    return positions, odometry, kin.indicator_map()


def make_tunnel_kinematics(
    distance_m,
    *,
    speed_kmh=(60.0, 100.0),
    indicator_spacing_m=200.0,
    first_indicator_m=None,
    start_chainage_m=0.0,
    frame_rate=30.0,
    curve_radius_m=math.inf,
    indicator_side="left",
    random_state=None,
):
    """The motion of a camera through a long tunnel, without rendering its frames.

    The speed varies smoothly within ``speed_kmh`` as in :func:`make_tunnel_tour`;
    indicators stand every ``indicator_spacing_m``, or, given a range, at gaps drawn
    uniformly from it (a map whose irregular spacing identifies where one is).  With
    :func:`simulate_indicator_detections` it stands in for a rendered tour when a
    tour of many kilometres would take too long to render.

    The tunnel's chainage starts at 0; the tour starts ``start_chainage_m`` into it
    (a log started mid-tunnel), so the indicators also stand behind the camera's
    start, and the chainages of the positions and the map are the tunnel's.

    Parameters
    ----------
    distance_m : float
        Distance to drive (m, > 0).
    speed_kmh : (float, float) or float, default=(60.0, 100.0)
        Speed range.
    indicator_spacing_m : float or (float, float), default=200.0
        Distance between indicators; a range ``(low, high)`` draws each gap
        uniformly from it.
    first_indicator_m : float or None, default=None
        Chainage of the first indicator; None draws it in ``[20, 20 + spacing)``
        (``spacing`` the range's low end).
    start_chainage_m : float, default=0.0
        Chainage of the camera at the first frame (m, >= 0).
    frame_rate : float, default=30.0
        Frames per second.
    curve_radius_m : float, default=inf
        Signed radius of the tunnel (> 0 curves right).
    indicator_side : {"left", "right", "random"}, default="left"
        The wall the indicators stand on; "random" draws each one's side (left or
        right, even odds) from a stream of its own, so the motion and the map's
        chainages are those of the same seed with one side.
    random_state : int, RandomState instance or None, default=None

    Returns
    -------
    kinematics : TourKinematics
    """
    distance_m = _check_error("distance_m", distance_m, 1.0, 1e6)
    lo, hi = (speed_kmh, speed_kmh) if np.ndim(speed_kmh) == 0 else speed_kmh
    lo = _check_error("speed_kmh", lo, 1.0, 300.0)
    hi = _check_error("speed_kmh", hi, lo, 300.0)
    if np.ndim(indicator_spacing_m) == 0:
        gap_lo = gap_hi = _check_error("indicator_spacing_m", indicator_spacing_m,
                                       20.0, 1e5)
    else:
        gap_lo, gap_hi = (float(v) for v in indicator_spacing_m)
        gap_lo = _check_error("indicator_spacing_m", gap_lo, 20.0, 1e5)
        gap_hi = _check_error("indicator_spacing_m", gap_hi, gap_lo, 1e5)
    start = _check_error("start_chainage_m", start_chainage_m, 0.0, 1e7)
    if indicator_side not in ("left", "right", "random"):
        raise ValueError("indicator_side must be 'left', 'right' or 'random'; got "
                         f"{indicator_side!r}")
    seed = int(check_random_state(random_state).randint(0, 2**31 - 1))
    rng = np.random.default_rng(seed)
    base = rng.uniform(lo, hi)
    # enough frames at the lowest speed; cut after the distance is driven
    n_max = int(distance_m / (lo / 3.6) * frame_rate) + 2
    t = np.arange(n_max) / frame_rate
    wobble = np.zeros(n_max)
    for period in (20.0, 45.0):
        wobble += np.sin(2 * np.pi * t / (period * rng.uniform(0.8, 1.25))
                         + rng.uniform(0, 6.3))
    speed = np.clip(base + min(4.0, (hi - lo) / 2) * wobble, lo, hi) / 3.6
    s = np.concatenate([[0.0], np.cumsum(speed[:-1] / frame_rate)])
    n = int(np.searchsorted(s, distance_m, side="right"))
    s = start + s
    first = rng.uniform(20.0, 20.0 + gap_lo) if first_indicator_m is None else float(
        first_indicator_m)
    end = s[n - 1] + 300.0
    if gap_hi == gap_lo:
        k = int(math.floor((end - first) / gap_lo)) + 1
        ind = first + gap_lo * np.arange(max(k, 0))
    else:
        # irregular gaps: from a stream of their own, so the motion is the same
        gaps = np.random.default_rng([seed, 1]).uniform(
            gap_lo, gap_hi, int((end - first) / gap_lo) + 2)
        ind = first + np.concatenate([[0.0], np.cumsum(gaps)])
        ind = ind[ind <= end]
    kappa = 0.0 if math.isinf(curve_radius_m) else 1.0 / float(curve_radius_m)
    side = indicator_side
    if side == "random":  # a stream of its own: the map's chainages do not change
        side = np.where(np.random.default_rng([seed, 2]).random(len(ind)) < 0.5,
                        "left", "right")
    return TourKinematics(t[:n], s[:n], speed[:n], kappa, ind,
                          np.arange(1, len(ind) + 1), seed, side)
