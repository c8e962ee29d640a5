"""The fields of a run's ``scans.npz``: ranges, stamps, geometry and run information.

Each check names the file and the field, and says what was expected.
"""

from __future__ import annotations

import json

import numpy as np

from tunnelsense._records import (
    GEOMETRY_FIELDS,
    LaserGeometry,
    geometry_problem,
)
from tunnelsense.exceptions import InputFormatError

__all__ = [
    "SCALARS",
    "check_fields",
    "check_geometry",
    "check_ranges",
    "check_stamps",
    "read_info",
    "to_metres",
]

SCALARS = GEOMETRY_FIELDS


def _as_float64(values) -> np.ndarray:
    """``values`` as float64; what float64 cannot hold becomes +-inf, silently."""
    with np.errstate(over="ignore"):
        return np.asarray(values).astype(np.float64)


def to_metres(ranges, range_max, scale):
    """Ranges as C-ordered float64 metres, narrower floats' no-returns kept (+inf)."""
    with np.errstate(over="ignore", invalid="ignore"):
        if scale != 1.0:
            ranges = ranges.astype(np.float64) * scale
        elif ranges.dtype.kind == "f" and ranges.dtype != np.float64:
            # ROS ranges are float32: float32(8.191) widens to 8.19099998..., below
            # the float64 range_max. Mark no-returns in the file's own precision.
            limit = np.asarray(range_max).astype(ranges.dtype)
            ranges = np.where(ranges >= limit, np.inf, ranges)
        return np.ascontiguousarray(ranges, dtype=np.float64)


def check_fields(npz_path, data, others) -> None:
    missing = [k for k in ("ranges", "stamps", *SCALARS) if k not in data]
    if missing:
        holds = (
            f"; it holds no .npy member of those names (members: "
            f"{', '.join(others[:5])}{', ...' if len(others) > 5 else ''})"
            if others
            else ""
        )
        raise InputFormatError(
            f"{npz_path}: lacks field(s) {', '.join(missing)}{holds}"
        )


def check_ranges(npz_path, ranges, range_unit) -> None:
    if len(ranges.shape) != 2 or ranges.dtype.kind not in "fiu":
        raise InputFormatError(
            f"{npz_path}: ranges must be a numeric array of shape (n_scans, n_beams); "
            f"got {ranges.dtype} of shape {ranges.shape}"
        )
    if ranges.shape[0] == 0:
        raise InputFormatError(
            f"{npz_path}: ranges has 0 scans; a run holds at least one"
        )
    if ranges.shape[1] == 0:
        raise InputFormatError(f"{npz_path}: ranges has 0 beams per scan")
    if ranges.dtype.kind in "iu" and range_unit == "m":
        raise InputFormatError(
            f"{npz_path}: ranges are integers ({ranges.dtype}); ROS ranges are metres "
            "as floats. If they are millimetres, read them with range_unit='mm' "
            "(command line: --range-unit mm)"
        )


def check_stamps(npz_path, stamps, n_scans) -> np.ndarray:
    """Stamps as float64 seconds, finite and non-decreasing, spanning some time.

    Equal stamps are a clock coarser than the scan period (75 scans/s on a 20 ms
    clock steps by 0 and 20 ms), which the street detector and the census read
    as it is; stamps that decrease are scans out of order, and a run of two or
    more scans all at one time has no time to turn scans into metres.
    """
    if stamps.shape != (n_scans,):
        raise InputFormatError(
            f"{npz_path}: stamps must have shape ({n_scans},) to match ranges; "
            f"got {stamps.shape}"
        )
    if stamps.dtype.kind not in "fiu":
        raise InputFormatError(
            f"{npz_path}: stamps must be numbers (seconds); got {stamps.dtype}"
        )
    stamps = _as_float64(stamps)
    if not np.all(np.isfinite(stamps)):
        raise InputFormatError(f"{npz_path}: stamps contain NaN or infinity")
    bad = np.flatnonzero(np.diff(stamps) < 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise InputFormatError(
            f"{npz_path}: stamps must not decrease; scan {i} (t={float(stamps[i])!r}) "
            f"comes before scan {i - 1} (t={float(stamps[i - 1])!r})"
        )
    if n_scans > 1 and stamps[-1] == stamps[0]:
        raise InputFormatError(
            f"{npz_path}: stamps must span some time; all {n_scans} scans are at "
            f"t={float(stamps[0])!r}"
        )
    return stamps


def _one_finite_number(npz_path, data, k) -> float:
    value = data[k]
    number = _as_float64(value) if value.dtype.kind in "fiu" else None
    if number is None or number.size != 1 or not np.isfinite(number).all():
        shown = np.array2string(value, threshold=6) if value.size else repr(value)
        raise InputFormatError(
            f"{npz_path}: {k} must be one finite number; got {shown} "
            f"({value.dtype}, shape {value.shape})"
        )
    return float(number.reshape(()))


def check_geometry(npz_path, data, n_beams) -> LaserGeometry:
    """The run's geometry; refuses impossible values and a wrong ``angle_max``."""
    scalars = {k: _one_finite_number(npz_path, data, k) for k in SCALARS}
    problem = geometry_problem(scalars)
    if problem is not None:
        raise InputFormatError(f"{npz_path}: {problem}")
    if "angle_max" in data:
        _check_angle_max(npz_path, scalars, _one_finite_number(npz_path, data,
                                                               "angle_max"), n_beams)
    return LaserGeometry(**scalars)


def _check_angle_max(npz_path, scalars, angle_max, n_beams) -> None:
    start, step = scalars["angle_min"], scalars["angle_increment"]
    n_described = (angle_max - start) / step + 1  # Python floats: inf, no warning
    if not abs(n_described - n_beams) <= 0.25:
        shown = f"{n_described:.0f}" if abs(n_described) < 1e12 else f"{n_described:.3g}"
        raise InputFormatError(
            f"{npz_path}: angle_min, angle_max and angle_increment describe "
            f"{shown} beams, but ranges has {n_beams}"
        )


def read_info(npz_path, data) -> dict:
    if "info_json" not in data:
        return {}
    value = data["info_json"]
    if value.dtype.kind not in "US" or value.size != 1:
        raise InputFormatError(
            f"{npz_path}: info_json must be one JSON string; got {value.dtype} of "
            f"shape {value.shape}"
        )
    text = _text_of(npz_path, value.reshape(()))
    try:
        info = json.loads(text)
    except (ValueError, RecursionError) as exc:  # JSONDecodeError, too many digits
        raise InputFormatError(
            f"{npz_path}: info_json is not valid JSON ({exc})"
        ) from None
    if not isinstance(info, dict):
        raise InputFormatError(
            f"{npz_path}: info_json must hold a JSON object; got {type(info).__name__}"
        )
    return info


def _text_of(npz_path, value) -> str:
    """A 0-d string array as text: bytes are UTF-8, code points valid Unicode."""
    if value.dtype.kind == "S":
        try:
            return value.item().decode("utf-8")
        except UnicodeDecodeError as exc:
            raise InputFormatError(
                f"{npz_path}: info_json is not UTF-8 text ({exc})"
            ) from None
    codes = np.frombuffer(value.tobytes(), dtype=value.dtype.str[0] + "u4")
    if np.any((codes > 0x10FFFF) | ((codes >= 0xD800) & (codes <= 0xDFFF))):
        raise InputFormatError(
            f"{npz_path}: info_json holds code points that are not Unicode characters"
        )
    return str(value.item())
