"""The street scene: rows of parked vehicles, clutter at the kerb, passing traffic.

Objects are dicts in street coordinates (``x0`` along the street, ``depth_near``
across it, ``speed`` 0 for static objects) laid out along the stretch the run covers.
"""

from __future__ import annotations

import numpy as np

from tunnelsense.datasets._street_roadside import bicycles, tight_hedges, walls

__all__ = ["layout", "passing"]


def _new_vehicle(rng, kind, *, rider=False, van_height=(2.05, 2.6)):
    """Body dimensions of a car, small car, van, long low vehicle or motorbike (metres;
    side profile knots); ``van_height`` the range of a van's roof height."""
    if kind == "long":  # a flatbed lorry, car transporter or trailer: long and low
        L, H = rng.uniform(8.0, 12.0), rng.uniform(1.4, 1.6)
        top_f = [0.0, 0.02, 0.05, 0.95, 1.0]
        top_h = [0.9, H - 0.2, H, H, H - 0.2]
        return {"kind": kind, "length": L, "width": rng.uniform(2.0, 2.3),
                "top_f": top_f, "top_h": top_h, "belt": H - 0.15, "glass_f": (0.0, 0.0),
                "tumble": 0.03, "wheel_radius": 0.45, "axles": (1.5, L - 1.5),
                "clearance": 0.35, "overhang_bottom": 0.45, "corner": 0.1}
    if kind == "caravan":  # a caravan or horse box: a tall box on one axle, a drawbar
        body, bar = rng.uniform(4.0, 6.5), rng.uniform(1.0, 1.4)
        L, H = body + bar, rng.uniform(2.3, 2.7)
        d = bar / L
        top_f = [0.0, d, d + 0.01, d + 0.04, 0.98, 1.0]
        top_h = [0.6, 0.6, H - 0.4, H, H, H - 0.1]
        axle = bar + body * rng.uniform(0.45, 0.6)
        return {"kind": kind, "length": L, "width": rng.uniform(2.1, 2.3),
                "top_f": top_f, "top_h": top_h, "belt": rng.uniform(1.0, 1.2),
                "glass_f": (d + 0.1, d + 0.25), "tumble": 0.02, "wheel_radius": 0.3,
                "axles": (axle, axle), "clearance": rng.uniform(0.3, 0.4),
                "overhang_bottom": 0.4, "corner": 0.1}
    if kind == "motorbike":
        return {"kind": kind, "length": rng.uniform(1.9, 2.2), "width": rng.uniform(0.7, 0.85),
                "rider": rider}
    if kind == "van":
        L, W, H = rng.uniform(4.4, 5.6), rng.uniform(1.85, 2.0), rng.uniform(*van_height)
        belt = rng.uniform(1.0, 1.15)
        top_f = [0.0, 0.03, 0.1, 0.24, 0.97, 1.0]
        top_h = [0.65, 0.95, belt + 0.15, H, H, H - 0.15]
        glass = (0.12, 0.35)
        tumble, R = 0.03, rng.uniform(0.3, 0.34)
    else:
        if kind == "small":  # city cars: short and narrow, as tall as a car
            L, W = rng.uniform(2.5, 3.4), rng.uniform(1.5, 1.65)
            H = rng.uniform(1.45, 1.6)
        else:
            L, W = rng.uniform(3.4, 4.9), rng.uniform(1.6, 1.85)
            H = rng.uniform(1.4, 1.6)
        belt = rng.uniform(0.88, 1.0)
        roof_end = rng.uniform(0.7, 0.9)  # saloon ... hatchback
        tail = 0.05 if roof_end > 0.8 else 0.13
        top_f = [0.0, 0.04, 0.2, 0.3, 0.45, roof_end, 1 - tail, 1.0]
        top_h = [0.6, 0.8, belt, belt + 0.06, H, H, belt + 0.05 + (0.2 if tail < 0.1 else 0),
                 0.7]
        glass = (0.3, roof_end + 0.05)
        tumble, R = rng.uniform(0.1, 0.18), rng.uniform(0.29, 0.33)
    overhang = rng.uniform(0.6, 0.95), rng.uniform(0.55, 0.9)
    return {
        "kind": kind, "length": L, "width": W, "top_f": top_f, "top_h": top_h,
        "belt": belt, "glass_f": glass, "tumble": tumble, "wheel_radius": R,
        "axles": (overhang[0] + R, L - overhang[1] - R), "clearance": rng.uniform(0.14, 0.2),
        "overhang_bottom": rng.uniform(0.25, 0.35), "corner": rng.uniform(0.25, 0.45),
    }


def _across(o, p, rng):
    """Turn a parked motorbike at right angles to the kerb: 0.7-0.85 m along the
    street, 1.9-2.2 m deep across it, a screen at 1.1-1.35 m; with the rear half on
    the footway behind the kerb step (``motorbike_footway_fraction``), else on the
    road at the kerb.  Returns where it stands and its near depth."""
    kerb = p["kerb_depth"]
    deep = o["length"]
    o.update(length=o["width"], width=deep, across=True,
             screen=rng.uniform(1.1, 1.35), rear_out=rng.random() < 0.3,
             kerb=kerb, kerb_height=p["kerb_height"])
    if p["motorbike_footway_fraction"] > 0 and rng.random() < p["motorbike_footway_fraction"]:
        return "across-footway", kerb - deep * rng.uniform(0.4, 0.6)
    return "across-kerb", kerb - rng.uniform(0.05, 0.3) - deep


def _vehicle_kind(rng, van, motorbike, small=0.0, long=0.0, caravan=0.0):
    u = rng.random()
    if u >= 1.0 - caravan:
        return "caravan"
    if u < van:
        return "van"
    if u < van + motorbike:
        return "motorbike"
    if u < van + motorbike + small:
        return "small"
    return "long" if u >= 1.0 - long else "car"


def _angle_into_bay(o, p, aux):
    """Turn a parked car or van into an angled bay: ``bay_angle_deg`` (+-3) from the
    street, nose toward the kerb (4 in 5) or toward the road, its deepest corner
    0.1-0.3 m from the kerb.  ``length`` and ``width`` become the footprint's extent
    along and across the street; returns the along-street pitch of the bays."""
    phi = np.deg2rad(min(p["bay_angle_deg"] + aux.uniform(-3.0, 3.0), 90.0))
    L, W = o["length"], o["width"]
    c, sn = abs(np.cos(phi)), np.sin(phi)
    o.update(car_length=L, car_width=W, bay_angle=phi, nose_in=aux.random() < 0.8,
             length=L * c + W * sn, width=L * sn + W * c)
    # bays 2.4-2.7 m wide at right angles to their axis; one car per bay
    return aux.uniform(2.4, 2.7) / sn


def layout(p, x_lo, x_hi, t_of_x, rng, aux=None):
    """All objects of the street.  Static objects have ``speed`` 0.  ``aux``: the
    random stream of the conditions no scenario uses (angled bays, walls)."""
    kerb, kh = p["kerb_depth"], p["kerb_height"]
    objects, free = [], []
    x = x_lo
    # parked vehicles in nose-to-tail clusters separated by free kerb
    while x < x_hi:
        gap = rng.exponential(p["parked_gap_m"])
        free.append((x, x + gap))
        x += gap
        n = rng.geometric(1.0 / p["parked_cluster_size"])
        row = None  # the whole row at a region boundary: "near" or "far"
        if p["boundary_row_fraction"] > 0 and rng.random() < p["boundary_row_fraction"]:
            row = "near" if rng.random() < 0.5 else "far"
        angled = p["angled_row_fraction"] > 0 and aux.random() < p["angled_row_fraction"]
        end = x
        for k in range(n):
            kind = _vehicle_kind(rng, p["van_fraction"], p["motorbike_fraction"],
                                 p["small_car_fraction"], caravan=p["caravan_fraction"])
            o = _new_vehicle(rng, kind,
                             van_height=(p["van_height_min"], p["van_height_max"]))
            W = o["width"]
            where = "kerb"
            base = 0.0
            if row == "near":  # a row parked away from the kerb: 4.0-4.3 m
                where, y_near = "boundary-near", rng.uniform(4.0, 4.3)
            elif row == "far":  # a row half up on the sidewalk: 6.2-6.6 m
                where, y_near, base = "boundary-far", rng.uniform(6.2, 6.6), kh / 2
            elif kind == "motorbike":
                y_near = kerb - rng.uniform(0.3, 1.0) - W
            elif rng.random() < p["boundary_fraction"]:
                if rng.random() < 0.5:  # badly parked, far from the kerb
                    where, y_near = "boundary-near", rng.uniform(4.0, 4.1)
                else:  # half up on the sidewalk
                    where, y_near, base = "boundary-far", rng.uniform(6.0, 6.15), kh / 2
            else:
                y_near = kerb - rng.uniform(0.1, 0.35) - W
            if (kind == "motorbike" and row is None and p["motorbike_across_fraction"] > 0
                    and rng.random() < p["motorbike_across_fraction"]):
                where, y_near = _across(o, p, rng)
            o.update(label="parked", x0=x, speed=0.0, facing=1.0 if rng.random() < 0.9 else -1.0,
                     depth_near=y_near, base=base, where=where)
            if angled and kind not in ("motorbike", "caravan"):
                pitch = _angle_into_bay(o, p, aux)
                o.update(facing=1.0, where="angled-bay", base=0.0,
                         depth_near=kerb - aux.uniform(0.1, 0.3) - o["width"])
                objects.append(o)
                end = x + o["length"]
                x += pitch  # the next bay (cars at 45 degrees overlap along the street)
                if k == n - 1:
                    x = end
                continue
            if angled and k > 0:  # after an angled car, clear of its footprint
                x = o["x0"] = max(x, end)
            objects.append(o)
            x += o["length"]
            if k < n - 1:
                touching = rng.random() < p["touching_fraction"]
                x += (rng.uniform(0.0, p["touching_gap_m"]) if touching
                      else rng.uniform(p["row_gap_min_m"], p["row_gap_max_m"]))
    free = [(a, b) for a, b in free if b - a > 1.0]
    length = x_hi - x_lo

    def in_free(width):
        """A random x in the free kerb with room for ``width``, or None."""
        room = np.array([max(b - a - width - 0.4, 0.0) for a, b in free])
        if room.sum() <= 0:
            return None
        i = rng.choice(len(free), p=room / room.sum())
        return free[i][0] + 0.2 + rng.uniform(0, room[i])

    def static(kind, x0, L, y_near, W, base, h, **extra):
        objects.append({"kind": kind, "label": None, "x0": x0, "length": L, "speed": 0.0,
                        "facing": 1.0, "depth_near": y_near, "width": W, "base": base,
                        "height": h, **extra})

    # pedestrians: standing at the kerb, walking along the road edge or on the sidewalk
    for _ in range(rng.poisson(p["pedestrians_per_100m"] * length / 100)):
        h, L = rng.uniform(1.5, 1.9), rng.uniform(0.25, 0.4)
        u = rng.random()
        if u < 0.4:
            xp = in_free(L)
            if xp is not None:
                static("pedestrian", xp, L, kerb - rng.uniform(-0.2, 0.8), 0.44, 0.0, h)
            continue
        v = rng.uniform(1.0, 1.8) * rng.choice([-1.0, 1.0])
        if u < 0.7:  # on the road edge, crossing the plane in a free stretch
            xc, y_near, base = in_free(L), kerb - rng.uniform(0.5, 1.2), 0.0
            if xc is None:
                continue
        else:  # on the sidewalk
            xc, y_near, base = rng.uniform(x_lo, x_hi), kerb + rng.uniform(0.3, 1.3), kh
        objects.append({"kind": "pedestrian", "label": None, "x0": xc - v * t_of_x(xc),
                        "length": L, "speed": v, "facing": 1.0, "depth_near": y_near,
                        "width": 0.44, "base": base, "height": h})
    for _ in range(rng.poisson(p["bins_per_100m"] * length / 100)):
        xb = in_free(0.74)
        if xb is not None:
            static("bin", xb, 0.74, kerb - rng.uniform(0.1, 0.7), 0.58, 0.0,
                   rng.uniform(1.0, 1.1))
    for _ in range(rng.poisson(p["bollard_rows_per_100m"] * length / 100)):
        spacing, n = rng.uniform(1.2, 2.0), rng.integers(3, 9)
        xb = in_free(spacing * (n - 1) + 0.15)
        if xb is None:
            continue
        y_near = kerb + rng.uniform(0.02, 0.1)
        for k in range(n):
            static("bollard", xb + k * spacing, 0.15, y_near, 0.15, kh, rng.uniform(0.8, 1.0))
    # sidewalk edge: lamp poles, trees, hedges (kept clear of cars up on the sidewalk)
    blocked = [(o["x0"] - 0.5, o["x0"] + o["length"] + 0.5) for o in objects
               if o.get("where") == "boundary-far"]

    def clear(a, b):
        return all(b < c or a > d for c, d in blocked)

    for xp in np.arange(x_lo + rng.uniform(0, 30), x_hi, 30.0):
        xp = xp + rng.uniform(-3, 3)
        if clear(xp, xp + 0.15):
            static("pole", xp, 0.15, kerb + rng.uniform(0.3, 0.5), 0.14, kh, 6.5)
    for _ in range(rng.poisson(p["trees_per_100m"] * length / 100)):
        L, xt = rng.uniform(3.0, 6.0), rng.uniform(x_lo, x_hi)
        if clear(xt, xt + L):
            static("tree", xt, L, kerb + rng.uniform(0.3, 0.8), rng.uniform(2.5, 4.0), kh,
                   0.0, crown=rng.uniform(3.6, 4.6))
    x = x_lo
    while x < x_hi:
        L = rng.uniform(3.0, 20.0)
        if rng.random() < p["hedge_fraction"] and clear(x, x + L):
            static("hedge", x, L, kerb + rng.uniform(0.4, 0.9), rng.uniform(0.8, 1.5), kh,
                   rng.uniform(0.8, 2.0),
                   wiggle=(rng.uniform(0.05, 0.25), rng.uniform(0.02, 0.1),
                           rng.uniform(0, 2 * np.pi), rng.uniform(1.5, 5.0)))
        x += L + rng.uniform(0.0, 4.0)
    _more_clutter(p, objects, x_lo, x_hi, t_of_x, in_free, rng)
    if p["wall_fraction"] > 0:
        walls(p, objects, x_lo, x_hi, clear, aux)
    if p["tight_hedge_fraction"] > 0:
        tight_hedges(p, objects, x_lo, x_hi, clear, aux)
    if p["bicycles_per_100m"] > 0:
        bicycles(p, objects, x_lo, x_hi, free, clear, aux)
    return objects


def _more_clutter(p, objects, x_lo, x_hi, t_of_x, in_free, rng):
    """Groups of pedestrians, pedestrians walking along the kerb (also in front of
    parked vehicles), rows of wheelie bins and communal bins (none by default)."""
    kerb, length = p["kerb_depth"], x_hi - x_lo

    def person(x0, y_near, speed=0.0):
        objects.append({"kind": "pedestrian", "label": None, "x0": x0,
                        "length": rng.uniform(0.25, 0.4), "speed": speed, "facing": 1.0,
                        "depth_near": y_near, "width": 0.44, "base": 0.0,
                        "height": rng.uniform(1.5, 1.9)})

    def box(kind, x0, L, y_near, W, h):
        objects.append({"kind": kind, "label": None, "x0": x0, "length": L, "speed": 0.0,
                        "facing": 1.0, "depth_near": y_near, "width": W, "base": 0.0,
                        "height": h})

    for _ in range(rng.poisson(p["pedestrian_groups_per_100m"] * length / 100)):
        n = int(rng.integers(2, 6))
        xg = in_free(0.7 * n)
        if xg is None:
            continue
        walking = rng.random() < 0.4
        v = rng.uniform(0.8, 1.4) * rng.choice([-1.0, 1.0]) if walking else 0.0
        y0 = kerb - rng.uniform(0.4, 1.2)
        for k in range(n):
            xk = xg + k * rng.uniform(0.35, 0.7)
            x0 = xk - v * t_of_x(xk) if walking else xk
            person(x0, y0 + rng.uniform(-0.35, 0.35), v)
    for _ in range(rng.poisson(p["kerb_walkers_per_100m"] * length / 100)):
        # walking along the parked rows, between them and the traffic: 4.0-4.3 m
        xc, v = rng.uniform(x_lo, x_hi), rng.uniform(1.0, 1.8) * rng.choice([-1.0, 1.0])
        person(xc - v * t_of_x(xc), rng.uniform(4.0, 4.3), v)
    for _ in range(rng.poisson(p["bin_rows_per_100m"] * length / 100)):
        n = int(rng.integers(1, 5))
        spacing = 0.74 + rng.uniform(0.02, 0.3)
        xb = in_free(spacing * n)
        if xb is None:
            continue
        y_near = kerb - rng.uniform(0.1, 0.7)
        for k in range(n):
            objects.append({"kind": "bin", "label": None, "x0": xb + k * spacing,
                            "length": 0.74, "speed": 0.0, "facing": 1.0,
                            "depth_near": y_near + rng.uniform(-0.05, 0.05),
                            "width": 0.58, "base": 0.0, "height": rng.uniform(1.0, 1.1)})
    for _ in range(rng.poisson(p["communal_bins_per_100m"] * length / 100)):
        L = rng.uniform(1.2, 2.0)
        xb = in_free(L)
        if xb is not None:
            W = rng.uniform(0.8, 1.1)
            box("communal_bin", xb, L, kerb - 0.1 - W - rng.uniform(0.0, 0.3), W,
                rng.uniform(1.25, 1.45))


def passing(p, stamps, v_ego, rng):
    """Vehicles in the lane between the scanner and the parked ones, at other speeds."""
    objects = []
    rate = p["passing_per_min"] / 60.0
    t = stamps[0] - 1.0
    while rate > 0:
        t += rng.exponential(1.0 / rate)
        if t > stamps[-1] + 1.0:
            break
        kind = _vehicle_kind(rng, p["passing_van_fraction"], p["passing_motorbike_fraction"],
                             long=p["passing_long_fraction"])
        o = _new_vehicle(rng, kind, rider=True)
        # relative speed of at least 3.5 m/s, both ways; slower ones still move (>= 2.5 m/s)
        rel = rng.uniform(3.5, 8.0)
        slower_ok = v_ego - rel >= 2.5
        sign = 1.0 if (slower_ok and rng.random() < 0.5) else -1.0
        speed = v_ego - sign * rel
        if kind == "motorbike":
            y_near = rng.uniform(1.8, 3.0)
        else:
            y_near = rng.uniform(1.5, max(1.5, 3.45 - o["width"]))
        o.update(label="passing", speed=speed, facing=1.0, depth_near=y_near, base=0.0,
                 cross_time=t)
        objects.append(o)
        # a later one must not overlap this one in the lane: leave it time to clear
        t += (o["length"] + 2.0) / rel
    return objects
