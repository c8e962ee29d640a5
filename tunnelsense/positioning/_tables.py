"""The positioning tables: odometry, indicator map, positions; checked and read.

Each table is a CSV file with a header line:

* odometry -- ``frame,stamp,speed,yaw_rate`` (s, m/s, rad/s), frames and stamps
  increasing, frames at most :data:`MAX_FRAME`, stamps at most :data:`MAX_STAMP` s, speeds
  at most :data:`MAX_SPEED`;
  the speed of a frame holds until the next frame;
* indicator map -- ``id,chainage,side`` (m along the tunnel);
* positions -- ``frame,stamp,chainage`` (the truth of a simulated tour), or
  ``frame,stamp,chainage,sigma`` (an estimate).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from tunnelsense.exceptions import InputFormatError
from tunnelsense.io._tables import ROUND_TRIP

__all__ = [
    "ESTIMATE_COLUMNS",
    "check_indicator_map",
    "check_odometry",
    "check_positions",
    "read_indicator_map",
    "read_odometry",
    "read_positions",
]

ODOMETRY_COLUMNS = ("frame", "stamp", "speed", "yaw_rate")
MAP_COLUMNS = ("id", "chainage")
POSITION_COLUMNS = ("frame", "stamp", "chainage")
#: Columns of a position estimate (``TunnelPositioner.predict``).
ESTIMATE_COLUMNS = ("frame", "stamp", "chainage", "sigma", "locked", "scale",
                    "scale_sigma")


def _columns(table, columns, what, *, finite=True):
    if not isinstance(table, pd.DataFrame):
        raise InputFormatError(f"{what}: expected a table (DataFrame); got "
                               f"{type(table).__name__}")
    missing = [c for c in columns if c not in table.columns]
    if missing:
        raise InputFormatError(
            f"{what}: expected the columns {list(columns)}; missing {missing}")
    out = {}
    for c in columns:
        try:
            v = pd.to_numeric(table[c], errors="raise").to_numpy(np.float64)
        except (TypeError, ValueError):
            raise InputFormatError(f"{what}: column {c!r} must hold numbers") from None
        if finite and not np.all(np.isfinite(v)):
            bad = int(np.flatnonzero(~np.isfinite(v))[0])
            raise InputFormatError(f"{what}: row {bad + 1}: {c} is not a finite number")
        out[c] = v
    return out


#: Largest frame number read (a year of video at 30 frames a second is 1e9).
MAX_FRAME = 10**12

#: Largest stamp read, s (UNIX time in seconds is below 2e9 until 2033).
MAX_STAMP = 1e11

#: Largest speed read, m/s (360 km/h: beyond any road vehicle).
MAX_SPEED = 100.0


def _frames(values, what):
    if np.any(values != np.round(values)) or np.any(values < 1):
        raise InputFormatError(f"{what}: frame must be integers >= 1")
    if np.any(values > MAX_FRAME):
        bad = int(np.flatnonzero(values > MAX_FRAME)[0])
        raise InputFormatError(f"{what}: row {bad + 1}: frame {values[bad]:.0f} is "
                               f"beyond {MAX_FRAME}")
    if np.any(np.diff(values) <= 0):
        raise InputFormatError(f"{what}: frames must increase")
    return values.astype(np.int64)


def check_odometry(odometry, what="odometry") -> pd.DataFrame:
    """Check an odometry table: ``frame, stamp, speed, yaw_rate``, in order."""
    v = _columns(odometry, ODOMETRY_COLUMNS, what)
    frame = _frames(v["frame"], what)
    if len(frame) == 0:
        raise InputFormatError(f"{what}: no rows")
    if np.any(np.diff(v["stamp"]) <= 0):
        raise InputFormatError(f"{what}: stamps must increase")
    if np.any(np.abs(v["stamp"]) > MAX_STAMP):
        bad = int(np.flatnonzero(np.abs(v["stamp"]) > MAX_STAMP)[0])
        raise InputFormatError(f"{what}: row {bad + 1}: stamp {v['stamp'][bad]:g} s is "
                               f"beyond {MAX_STAMP:g} s (is it in seconds?)")
    if np.any(v["speed"] < -1.0):
        raise InputFormatError(f"{what}: a negative speed (driving backwards)")
    if np.any(v["speed"] > MAX_SPEED):
        bad = int(np.flatnonzero(v["speed"] > MAX_SPEED)[0])
        raise InputFormatError(f"{what}: row {bad + 1}: speed {v['speed'][bad]:g} m/s "
                               f"is beyond {MAX_SPEED:g} m/s (is it in m/s?)")
    return pd.DataFrame({"frame": frame, "stamp": v["stamp"], "speed": v["speed"],
                         "yaw_rate": v["yaw_rate"]})


def check_indicator_map(indicator_map, what="indicator map") -> pd.DataFrame:
    """Check an indicator map: ``id, chainage`` (and ``side``), sorted by chainage."""
    v = _columns(indicator_map, MAP_COLUMNS, what)
    if len(v["id"]) == 0:
        raise InputFormatError(f"{what}: no indicators")
    ids = v["id"]
    if np.any(ids != np.round(ids)) or len(np.unique(ids)) != len(ids):
        raise InputFormatError(f"{what}: ids must be distinct integers")
    table = pd.DataFrame({"id": ids.astype(np.int64), "chainage": v["chainage"]})
    if "side" in indicator_map.columns:
        table["side"] = indicator_map["side"].astype(str).to_numpy()
    table = table.sort_values("chainage", kind="stable").reset_index(drop=True)
    if np.any(np.diff(table["chainage"].to_numpy()) <= 0):
        raise InputFormatError(f"{what}: two indicators at one chainage")
    return table


def _locked(values, what):
    if values.dtype == bool:
        return values.to_numpy()
    text = values.astype(str).str.strip().str.lower()
    ok = text.isin(["true", "false", "1", "0", "1.0", "0.0"])
    if not ok.all():
        bad = int(np.flatnonzero(~ok.to_numpy())[0])
        raise InputFormatError(f"{what}: row {bad + 1}: locked must be true or false")
    return text.isin(["true", "1", "1.0"]).to_numpy()


def check_positions(positions, what="positions", *, sigma=False) -> pd.DataFrame:
    """Check a positions table: ``frame, stamp, chainage`` (the truth), or an estimate
    ``frame, stamp, chainage, sigma`` with ``sigma=True`` (and ``locked``, ``scale``,
    ``scale_sigma`` when present; chainage and sigma may be empty where not locked).
    """
    if not sigma:
        v = _columns(positions, POSITION_COLUMNS, what)
        v["frame"] = _frames(v["frame"], what)
        return pd.DataFrame(v)
    v = _columns(positions, ESTIMATE_COLUMNS[:4], what, finite=False)
    for c in ("frame", "stamp"):
        if not np.all(np.isfinite(v[c])):
            bad = int(np.flatnonzero(~np.isfinite(v[c]))[0])
            raise InputFormatError(f"{what}: row {bad + 1}: {c} is not a finite number")
    v["frame"] = _frames(v["frame"], what)
    locked = (_locked(positions["locked"], what) if "locked" in positions.columns
              else np.ones(len(v["frame"]), bool))
    for c in ("chainage", "sigma"):
        bad = locked & ~np.isfinite(v[c])
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise InputFormatError(f"{what}: row {k + 1}: {c} is not a finite number "
                                   "(and the row is locked)")
    if np.any(v["sigma"][locked] < 0):
        raise InputFormatError(f"{what}: sigma must be >= 0")
    v["locked"] = locked
    if {"scale", "scale_sigma"} <= set(positions.columns):
        v.update(_columns(positions, ("scale", "scale_sigma"), what, finite=False))
    return pd.DataFrame(v)


def _read(path, what):
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: {what} file not found")
    try:
        return pd.read_csv(path, encoding="utf-8", **ROUND_TRIP)
    except (UnicodeDecodeError, pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise InputFormatError(f"{path}: not a CSV {what} table ({exc})") from None


def read_odometry(path) -> pd.DataFrame:
    """Read ``odometry.csv`` (``frame,stamp,speed,yaw_rate``), checked."""
    return check_odometry(_read(path, "odometry"), str(path))


def read_indicator_map(path) -> pd.DataFrame:
    """Read an indicator map (``id,chainage,side``), checked."""
    return check_indicator_map(_read(path, "indicator map"), str(path))


def read_positions(path, *, sigma=False) -> pd.DataFrame:
    """Read ``positions.csv`` (or an estimate, with ``sigma=True``), checked."""
    return check_positions(_read(path, "positions"), str(path), sigma=sigma)
