"""Scan records: one laser scan, its geometry, its payload."""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "GEOMETRY_FIELDS",
    "GEOMETRY_RULES",
    "RUN_GT_COLUMNS",
    "RUN_LABELS",
    "LaserGeometry",
    "ScanRecord",
    "geometry_problem",
]


#: Column names of a laser run's ground truth (``gt.csv``).
RUN_GT_COLUMNS = ("id", "first_scan", "last_scan", "label")

#: Object labels of laser runs, and the integer codes used in per-scan targets.
RUN_LABELS = {"parked": 1, "passing": 2}



#: The fields of :class:`LaserGeometry`, in order.
GEOMETRY_FIELDS = ("angle_min", "angle_increment", "range_min", "range_max",
                   "mount_height")

#: Physically possible values of the geometry fields: (test, what is expected).
GEOMETRY_RULES = {
    "angle_increment": (lambda v: v != 0, "a non-zero angle (rad)"),
    "range_min": (lambda v: v >= 0, "a range >= 0 (m)"),
    "range_max": (lambda v: v > 0, "a range > 0 (m)"),
    "mount_height": (lambda v: v > 0, "a height > 0 (m) above the road"),
}


def geometry_problem(values: Mapping) -> str | None:
    """What makes a laser geometry impossible, or None.

    Parameters
    ----------
    values : mapping
        The :data:`GEOMETRY_FIELDS` and their values.

    Returns
    -------
    problem : str or None
        For instance ``"angle_increment is 0.0, expected a non-zero angle (rad)"``.
    """
    floats = {}
    for k in GEOMETRY_FIELDS:
        v = floats[k] = _finite_float(values[k])
        if v is None:
            return f"{k} is {values[k]!r}, expected a finite number"
        test, expected = GEOMETRY_RULES.get(k, (None, None))
        if test is not None and not test(v):
            return f"{k} is {v!r}, expected {expected}"
    if floats["range_min"] >= floats["range_max"]:
        return (
            f"range_min ({floats['range_min']!r}) must be below range_max "
            f"({floats['range_max']!r})"
        )
    return None


def _finite_float(value) -> float | None:
    """``value`` as a finite float, or None if it is not a finite real number."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        return None
    try:
        value = float(value)
    except OverflowError:
        return None
    return value if math.isfinite(value) else None


@dataclass(frozen=True, slots=True)
class LaserGeometry:
    """How the beams of a vertically scanning laser range finder are laid out.

    Field names and units follow ROS ``sensor_msgs/LaserScan`` (radians, metres).

    Parameters
    ----------
    angle_min : float
        Angle of the first beam (rad), measured from the horizontal, positive up.
    angle_increment : float
        Angle between consecutive beams (rad).
    range_min, range_max : float
        Valid range interval (m).  A range ``>= range_max``, NaN or +inf is no return.
    mount_height : float
        Height of the sensor above the road (m).

    Raises
    ------
    ValueError
        A field that is not a finite number, ``angle_increment == 0``,
        ``range_min < 0``, ``range_max <= range_min`` or ``mount_height <= 0``.
    """

    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    mount_height: float

    def __post_init__(self):
        problem = geometry_problem({k: getattr(self, k) for k in GEOMETRY_FIELDS})
        if problem is not None:
            raise ValueError(f"impossible LaserGeometry: {problem}")

    def angles(self, n_beams: int) -> np.ndarray:
        """The beam angles (rad) of a scan of ``n_beams`` beams."""
        return self.angle_min + self.angle_increment * np.arange(n_beams)


@dataclass(frozen=True, slots=True, eq=False)
class ScanRecord:
    """One scan of a laser range finder: identity, ranges, geometry and payload.

    Parameters
    ----------
    run : str
        Name of the run the scan belongs to.
    scan : int
        0-based scan number within the run.
    ranges : ndarray of shape (n_beams,)
        Ranges in metres; NaN, +inf or ``>= geometry.range_max`` mean no return.
    stamp : float
        Time of the scan (s).
    geometry : LaserGeometry
        Beam layout and mounting height.
    payload : dict, default={}
        What the stages computed so far, by name.
    """

    run: str
    scan: int
    ranges: np.ndarray
    stamp: float
    geometry: LaserGeometry
    payload: dict = field(default_factory=dict)

    @property
    def key(self) -> tuple[str, int]:
        """The record's identity ``(run, scan)``."""
        return (self.run, self.scan)

    def evolve(self, **payload) -> ScanRecord:
        """Return a record with the same identity and ranges, payload updated."""
        return ScanRecord(
            self.run,
            self.scan,
            self.ranges,
            self.stamp,
            self.geometry,
            {**self.payload, **payload},
        )

    def __repr__(self):
        keys = ", ".join(self.payload) or "-"
        return (
            f"ScanRecord(run={self.run!r}, scan={self.scan}, "
            f"beams={len(self.ranges)}, payload=[{keys}])"
        )
