"""Hand-built laser scans for the street tests: boxes beside a flat road.

An object is a box: along-track interval ``[s0, s1]`` (m), near face at ``depth`` (m),
``width`` deep, bottom ``bottom`` and a top height that may vary along the track
(``top`` a number or a callable of the along-track offset into the object).  Each scan
casts the beams of a vertical scanner mounted ``mount_height`` above the road at
along-track position ``speed * t``; every scan carries ``speed`` in its payload.
"""

import numpy as np
import pandas as pd

from tunnelsense import LaserGeometry, Run, ScanSequence


def geometry(n_beams=361, mount_height=2.0):
    # beams from straight down (-90 deg) to +30 deg
    inc = np.deg2rad(120.0) / (n_beams - 1)
    return LaserGeometry(np.deg2rad(-90.0), inc, 0.05, 30.0, mount_height)


def cast(geom, n_beams, boxes, s, tilt=0.0):
    """Ranges of one scan at along-track position ``s``."""
    theta = geom.angles(n_beams) + tilt  # true beam angles
    h = geom.mount_height
    c, sn = np.cos(theta), np.sin(theta)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(sn < 0, -h / sn, np.inf)  # road
        for b in boxes:
            if not (b["s0"] <= s <= b["s1"]):
                continue
            top = b["top"](s - b["s0"]) if callable(b["top"]) else b["top"]
            d0, d1 = b["depth"], b["depth"] + b.get("width", 1.7)
            bottom = b.get("bottom", 0.15)
            # near vertical face
            rf = d0 / c
            zf = h + rf * sn
            hit = (c > 0) & (zf >= bottom) & (zf <= top)
            r = np.where(hit & (rf < r), rf, r)
            # top face
            rt = (top - h) / sn
            xt = rt * c
            hit = (rt > 0) & (xt >= d0) & (xt <= d1)
            r = np.where(hit & (rt < r), rt, r)
    return np.where(r > geom.range_max, np.inf, r)


def sedan(s):
    """Top height of a 4.4 m sedan at offset ``s`` along it."""
    return np.interp(s, [0, 0.2, 1.1, 1.6, 2.9, 3.6, 4.2, 4.4],
                     [0.55, 0.8, 0.9, 1.45, 1.45, 1.0, 0.9, 0.55])


def make_run(boxes, labels, *, n_scans, speed=11.0, rate=75.0, tilt=0.0, name="r",
             n_beams=361, mount_height=2.0):
    geom = geometry(n_beams, mount_height)
    stamps = np.arange(n_scans) / rate
    ranges = np.stack([cast(geom, n_beams, boxes, speed * t, tilt) for t in stamps])
    rows = []
    for i, (b, lab) in enumerate(zip(boxes, labels, strict=True)):
        if lab is None:
            continue
        first = int(np.ceil(b["s0"] / speed * rate))
        last = int(np.floor(b["s1"] / speed * rate))
        rows.append((i + 1, first, min(last, n_scans - 1), lab))
    gt = pd.DataFrame(rows, columns=["id", "first_scan", "last_scan", "label"])
    gt = gt.astype({"id": "int64", "first_scan": "int64", "last_scan": "int64",
                    "label": object})
    run = Run.from_arrays(name, ranges, stamps, geom, gt, info={"speed": speed})
    # every scan carries the ego speed, as read_run and a bag's odometry give it
    return Run(run.name, ScanSequence([r.evolve(speed=speed) for r in run.scans]),
               run.gt, run.info)
