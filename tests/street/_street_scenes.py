"""Hand-built laser scans for the street tests: boxes beside a flat road.

An object is a box: along-track interval ``[s0, s1]`` (m), near face at ``depth`` (m),
``width`` deep, bottom ``bottom`` and a top height that may vary along the track
(``top`` a number or a callable of the along-track offset into the object; ``depth``
and ``width`` may be callables too: a body standing obliquely, see :func:`oblique_car`).  Each scan
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


def cast(geom, n_beams, boxes, s, tilt=0.0, wet=False):
    """Ranges of one scan at along-track position ``s`` (``wet``: the road returns
    nothing)."""
    theta = geom.angles(n_beams) + tilt  # true beam angles
    h = geom.mount_height
    c, sn = np.cos(theta), np.sin(theta)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where((sn < 0) & (not wet), -h / sn, np.inf)  # road
        for b in boxes:
            if not (b["s0"] <= s <= b["s1"]):
                continue
            top = b["top"](s - b["s0"]) if callable(b["top"]) else b["top"]
            off = s - b["s0"]
            d0 = b["depth"](off) if callable(b["depth"]) else b["depth"]
            w = b.get("width", 1.7)
            d1 = d0 + (w(off) if callable(w) else w)
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


def oblique_car(s0, near, *, length=4.4, width=1.8, angle=45.0, top=1.45):
    """A car in a bay at ``angle`` degrees to the kerb as a box whose depth and
    width follow its cross-section: the corner nearest the road at ``near`` (m
    deep), the car's end pointing back along the track, its flank forward; the
    footprint starts at ``s0`` along the track."""
    a = np.deg2rad(angle)
    c, s = np.cos(a), np.sin(a)
    # corners of the footprint (along, depth): nearest, end's far corner, flank's
    # far corner, the corner opposite the nearest
    xa, ya = width * s, near
    xb, yb = 0.0, near + width * c
    xc, yc = xa + length * c, near + length * s
    xd, yd = xb + length * c, yb + length * s
    lo_x, lo_y = [xb, xa, xc], [yb, ya, yc]
    hi_x, hi_y = [xb, xd, xc], [yb, yd, yc]

    def depth(off):
        return np.interp(off, lo_x, lo_y)

    def deep(off):
        return max(np.interp(off, hi_x, hi_y) - depth(off), 0.05)

    return dict(s0=s0, s1=s0 + xc, depth=depth, width=deep,
                top=lambda off: top * float(np.interp(off, [0, 0.6, xc - 0.6, xc],
                                                      [0.5, 1, 1, 0.5])))


def make_run(boxes, labels, *, n_scans, speed=11.0, rate=75.0, tilt=0.0, name="r",
             n_beams=361, mount_height=2.0, wet=()):
    """A run past ``boxes``; ``wet``: along-track intervals ``(s0, s1)`` where the
    road returns nothing (a wet road)."""
    geom = geometry(n_beams, mount_height)
    stamps = np.arange(n_scans) / rate
    ranges = np.stack([cast(geom, n_beams, boxes, speed * t, tilt,
                            any(a <= speed * t <= b for a, b in wet))
                       for t in stamps])
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
