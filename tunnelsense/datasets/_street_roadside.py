"""Roadside conditions no scenario uses (off by default): walls, fences and facades
at the back of a narrow footway, hedges tight behind the kerb, parked bicycles.
Their draws come from the stream of those conditions (``aux``), so that a run
without them stays byte for byte as it was."""

from __future__ import annotations

import numpy as np

__all__ = ["bicycles", "tight_hedges", "walls"]


def walls(p, objects, x_lo, x_hi, clear, aux):
    """Garden walls, fences and facades at the back of a narrow footway, 0.1-0.5 m
    behind the kerb and 0.8-2.5 m high, along ``wall_fraction`` of the street in
    stretches of 5-30 m (kept clear of cars up on the footway)."""
    kerb, kh = p["kerb_depth"], p["kerb_height"]
    x = x_lo
    while x < x_hi:
        L = aux.uniform(5.0, 30.0)
        wall = aux.random() < p["wall_fraction"]
        y, h = kerb + aux.uniform(0.1, 0.5), aux.uniform(0.8, 2.5)
        if wall and clear(x, x + L):
            objects.append({"kind": "wall", "label": None, "x0": x, "length": L,
                            "speed": 0.0, "facing": 1.0, "depth_near": y, "width": 0.25,
                            "base": kh, "height": h})
        x += L + aux.uniform(0.0, 3.0) * (not wall)


def tight_hedges(p, objects, x_lo, x_hi, clear, aux):
    """Hedges right at the back of a narrow footway, 0.0-0.3 m behind the kerb, tight
    behind the parked vehicles: 0.8-2.2 m high, 0.6-1.5 m thick, their ragged face
    and top wiggling, along ``tight_hedge_fraction`` of the street in stretches of
    4-25 m (kept clear of cars up on the footway)."""
    kerb, kh = p["kerb_depth"], p["kerb_height"]
    x = x_lo
    while x < x_hi:
        L = aux.uniform(4.0, 25.0)
        hedge = aux.random() < p["tight_hedge_fraction"]
        y, w, h = kerb + aux.uniform(0.0, 0.3), aux.uniform(0.6, 1.5), aux.uniform(0.8, 2.2)
        wiggle = (aux.uniform(0.05, 0.25), aux.uniform(0.02, 0.1),
                  aux.uniform(0, 2 * np.pi), aux.uniform(1.5, 5.0))
        if hedge and clear(x, x + L):
            objects.append({"kind": "hedge", "label": None, "x0": x, "length": L,
                            "speed": 0.0, "facing": 1.0, "depth_near": y, "width": w,
                            "base": kh, "height": h, "wiggle": wiggle})
        x += L + aux.uniform(0.0, 3.0) * (not hedge)


def bicycles(p, objects, x_lo, x_hi, free, clear, aux):
    """Parked bicycles (no vehicle of the census): ``bicycles_per_100m`` of them,
    in groups of 1-4 - 6 in 10 groups at the kerb in a free stretch of the parking
    lane, parallel to it (0.1-0.4 m from the kerb), the rest in a rack on the
    footway at right angles to the kerb (front wheel 0.2-0.5 m behind it), 0.6-0.9 m
    apart.  A bicycle is 1.65-1.85 m long, its handlebar 0.55-0.65 m wide."""
    kerb, kh = p["kerb_depth"], p["kerb_height"]
    n = aux.poisson(p["bicycles_per_100m"] * (x_hi - x_lo) / 100 / 2.5)
    lengths = np.array([b - a for a, b in free])
    for _ in range(n):
        k = int(aux.integers(1, 5))
        L, bar = aux.uniform(1.65, 1.85), aux.uniform(0.55, 0.65)
        across = aux.random() >= 0.6
        pitch = aux.uniform(0.6, 0.9)
        need = k * pitch + (0.0 if across else L)
        if across:
            x0 = aux.uniform(x_lo, x_hi)
            if not clear(x0, x0 + need):
                continue
            y = kerb + aux.uniform(0.2, 0.5)
        else:
            room = np.maximum(lengths - need - 0.4, 0.0)
            if not len(room) or room.sum() <= 0:
                continue
            i = int(aux.choice(len(free), p=room / room.sum()))
            x0 = free[i][0] + 0.2 + aux.uniform(0, room[i])
            y = kerb - aux.uniform(0.1, 0.4) - 0.1
        for j in range(k):
            x = x0 + j * (pitch if across else L + 0.3)
            o = {"kind": "bicycle", "label": None, "x0": x, "speed": 0.0,
                 "facing": 1.0, "base": kh if across else 0.0, "across": across,
                 "bar": bar, "bike_length": L}
            if across:  # the plane cuts it along its length, the bar along the street
                o.update(length=bar, depth_near=y, width=L)
            else:
                o.update(length=L, depth_near=y - bar / 2 + 0.1, width=bar)
            objects.append(o)
