"""What a tour folder, video or laser run holds (``tunnelsense info``)."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from tunnelsense._records import OBJECT_CLASSES, Run, Tour
from tunnelsense.io._laser import read_run
from tunnelsense.io._model import describe_model
from tunnelsense.io._rosbag import is_bag
from tunnelsense.io._sources import open_tour

__all__ = ["describe", "format_description", "open_source"]

_MODEL_SUFFIXES = (".skops", ".joblib", ".pkl", ".pickle")


def open_source(source, *, range_unit="m", mount_height=None) -> Tour | Run:
    """Read a tour (MOTChallenge folder, image folder, video) or a laser run.

    Parameters
    ----------
    source : str or Path
        A laser run folder (holding ``scans.npz``) or ``.npz`` file, a ROS bag
        (written with its mount height), or anything
        :func:`~tunnelsense.io.open_tour` reads.
    range_unit : {"m", "mm"}, default="m"
        For a laser run: the unit of ``ranges`` in ``scans.npz`` (see
        :func:`~tunnelsense.io.read_run`).
    mount_height : float, default=None
        For a ROS bag that does not store it: the laser's height above the road (m).

    Returns
    -------
    data : Tour or Run
    """
    source = Path(source)
    if (
        source.is_dir() and (source / "scans.npz").exists()
    ) or source.suffix.lower() == ".npz" or is_bag(source):
        return read_run(source, range_unit=range_unit, mount_height=mount_height)
    return open_tour(source)


def describe(source, *, range_unit="m", mount_height=None) -> dict:
    """Describe a tour or a laser run as a JSON-able dict.

    A model file (``.skops``, ``.joblib``) is described by its model card instead
    (:func:`~tunnelsense.io.describe_model`).  A laser run is read, and checked, as
    :func:`~tunnelsense.io.read_run` reads it.

    Parameters
    ----------
    source : str, Path, Tour or Run
        What to describe.
    range_unit : {"m", "mm"}, default="m"
        For a laser run file: the unit of ``ranges`` in ``scans.npz`` (see
        :func:`~tunnelsense.io.read_run`).
    mount_height : float, default=None
        For a ROS bag that does not store it: the laser's height above the road (m).

    Returns
    -------
    facts : dict
        ``kind`` (``"tunnel"``, ``"street"`` or ``"model"``), ``name``, ``frames`` or
        ``scans``, ``objects`` (class or label name -> number of distinct object ids),
        and the image size and frame rate, or the beams, scan rate and geometry.
    """
    if (
        not isinstance(source, Tour | Run)
        and Path(source).suffix.lower() in _MODEL_SUFFIXES
    ):
        return describe_model(source)
    data = (
        source
        if isinstance(source, Tour | Run)
        else open_source(source, range_unit=range_unit, mount_height=mount_height)
    )
    if isinstance(data, Tour):
        height, width = data.image_shape
        gt = data.gt
        objects = {
            OBJECT_CLASSES.get(int(c), f"class {int(c)}"): int(g["id"].nunique())
            for c, g in gt.groupby("class")
        }
        dtype = str(data.frames[0].image.dtype)
        return {
            "kind": "tunnel",
            "name": data.name,
            "frames": len(data),
            "width": width,
            "height": height,
            "dtype": dtype,
            "frame_rate": data.frame_rate,
            "duration_s": round(len(data) / data.frame_rate, 3)
            if data.frame_rate
            else None,
            "objects": objects,
            "info": _plain(data.info),
        }
    g = data.geometry
    stamps = np.array([r.stamp for r in data.scans])
    rate = (
        float((len(stamps) - 1) / (stamps[-1] - stamps[0]))
        if len(stamps) > 1 and stamps[-1] > stamps[0]
        else None
    )
    return {
        "kind": "street",
        "name": data.name,
        "scans": len(data),
        "beams": int(len(data.scans[0].ranges)),
        "scan_rate": None if rate is None else round(rate, 3),
        "angle_min_deg": round(float(np.degrees(g.angle_min)), 4),
        "angle_increment_deg": round(float(np.degrees(g.angle_increment)), 4),
        "range_max": g.range_max,
        "mount_height": g.mount_height,
        "objects": {
            str(k): int(v["id"].nunique()) for k, v in data.gt.groupby("label")
        },
        "info": _plain(data.info),
    }


#: Decimal numbers in text (an ``.ini`` file's values): given as JSON numbers.
_INTEGER = re.compile(r"[+-]?[0-9]+")
_DECIMAL = re.compile(r"[+-]?(?:[0-9]+\.[0-9]*|\.[0-9]+|[0-9]+)(?:[eE][+-]?[0-9]+)?")


def _plain(value):
    """``value`` as JSON: numbers (also those written as text) as numbers.

    Examples
    --------
    >>> from tunnelsense.io._describe import _plain
    >>> _plain({"seed": "3", "rate": "2.5", "scenario": "light", "n": [1, "x"]})
    {'seed': 3, 'rate': 2.5, 'scenario': 'light', 'n': [1, 'x']}
    """
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if value is None or isinstance(value, bool | int | float):
        return value if not isinstance(value, float) or math.isfinite(value) else None
    text = str(value)
    if _INTEGER.fullmatch(text):
        return int(text)
    return float(text) if _DECIMAL.fullmatch(text) else text


#: The facts each kind's headline already gives (not repeated below it).
_IN_HEADLINE = {"tunnel": ("frames", "width", "height", "dtype", "frame_rate"),
                "street": ("scans", "beams", "scan_rate", "mount_height"),
                "model": ("kind", "path", "format", "bytes", "versions")}
#: Without ``verbose``, a dict of the run information with more entries than this is
#: given as its number of entries.
_CONCISE_ITEMS = 8


def format_description(facts, *, verbose=False) -> str:
    """A description (:func:`describe`) as text: a headline, then one fact per line.

    Nested facts are indented below their key; a list of them is a bulleted list.
    Numbers are given to four significant digits (a tenth above 1000); the facts
    :func:`describe` returns keep every digit.

    Parameters
    ----------
    facts : dict
        From :func:`describe`.
    verbose : bool, default=False
        Give every fact of the run information.  By default a list of records (such
        as the simulated vehicles of a run) and a table of more than eight values
        (such as the simulator's parameters) are given as their numbers of entries.

    Returns
    -------
    text : str

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import Tour
    >>> from tunnelsense.io import describe, format_description
    >>> info = {"seed": 7, "speed_kmh": 84.83302599014033,
    ...         "vehicles": [{"id": 1, "kind": "car"}, {"id": 2, "kind": "truck"}]}
    >>> tour = Tour.from_array("t", np.zeros((2, 8, 10), np.uint8), info=info)
    >>> print(format_description(describe(tour)))
    t: far-infrared tour, 2 frames of 10x8 px (uint8), 30 fps
      objects: none in the ground truth
      duration_s: 0.067
      info:
        seed: 7
        speed_kmh: 84.83
        vehicles: 2 entries (--verbose lists them)
    """
    facts = dict(facts)
    lines = [_headline(facts)]
    if facts["kind"] != "model":
        objects = facts.pop("objects")
        lines.append("  objects: " + (", ".join(
            f"{n} {k}" for k, n in sorted(objects.items())) or "none in the ground truth"))
    for name, version in sorted(facts.get("versions", {}).items()):
        lines.append(f"  trained under {name} {version}")
    shown = {"kind", "name", *_IN_HEADLINE[facts["kind"]]}
    rest = {k: v for k, v in facts.items() if k not in shown}
    if not verbose and isinstance(rest.get("info"), dict):
        rest["info"] = {k: _concise(v) for k, v in rest["info"].items()}
    lines += _tree(rest)
    return "\n".join(lines)


def _concise(value):
    """A record list or a long table as the number of its entries."""
    if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        return f"{len(value)} entries (--verbose lists them)"
    if isinstance(value, dict) and len(value) > _CONCISE_ITEMS:
        return f"{len(value)} values (--verbose lists them)"
    return value


def _number(value) -> str:
    """A fact as text, a float to four significant digits (a tenth above 1000)."""
    if isinstance(value, float) and math.isfinite(value):
        return f"{value:.1f}" if abs(value) >= 1000 else f"{value:.4g}"
    return str(value)


def _tree(facts, indent="  ") -> list[str]:
    """One fact per line; nested dicts (and lists of them) indented below their key."""
    lines = []
    for key, value in facts.items():
        if isinstance(value, dict) and value:
            lines += [f"{indent}{key}:", *_tree(value, indent + "  ")]
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            lines.append(f"{indent}{key}:")
            for item in value:
                sub = _tree(item, indent + "    ")
                lines += [indent + "  - " + sub[0].lstrip(), *sub[1:]]
        elif isinstance(value, list):
            lines.append(f"{indent}{key}: {', '.join(map(_number, value))}")
        else:
            lines.append(f"{indent}{key}: {_number(value)}")
    return lines


def _headline(facts) -> str:
    if facts["kind"] == "model":
        return f"{facts['path']}: {facts['format']} model file, {facts['bytes']} bytes"
    if facts["kind"] == "tunnel":
        return (f"{facts['name']}: far-infrared tour, {facts['frames']} frames of "
                f"{facts['width']}x{facts['height']} px ({facts['dtype']}), "
                f"{facts['frame_rate']:g} fps")
    rate = facts["scan_rate"]
    return (f"{facts['name']}: laser run, {facts['scans']} scans of {facts['beams']} "
            f"beams" + (f", {rate:.4g} scans/s" if rate else "")
            + f", mount height {facts['mount_height']:g} m")
