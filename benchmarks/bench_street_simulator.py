"""Speed of the laser street simulator (issue 3: 4,000 scans in at most 10 s, one core).

Run: ``python benchmarks/bench_street_simulator.py [--repeats 5]``

Every figure is the median over the repeats, measured in this run beside two peers:

* ``savez_compressed``: writing the same ranges to an in-memory ``.npz`` (the cost of
  merely storing the run), and
* ``per-beam loop``: a naive pure-Python ray caster (one beam, one box at a time) over
  the same cross-sections, timed on a subset of scans and scaled to the whole run.
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import io  # noqa: E402
import math  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from tunnelsense.datasets import STREET_SCENARIOS, make_street_scans  # noqa: E402
from tunnelsense.datasets._street import _simulate  # noqa: E402
from tunnelsense.datasets._street_shapes import cross_sections as _cross_sections  # noqa: E402

N_SCANS = 4000
LOOP_SCANS = 200  # scans ray-cast by the naive loop


def naive_ray_cast(sim, scans):
    """Pure Python: every beam against every box of its scan (ground not included)."""
    objects, stamps, x = sim["objects"], sim["stamps"], sim["x"]
    rows, _, boxes = _cross_sections(objects, stamps, x)
    angles = sim["geometry"].angles(sim["ranges"].shape[1])
    out = np.full((len(scans), len(angles)), np.inf)
    for k, i in enumerate(scans):
        H, roll = sim["height"][i], sim["roll"][i]
        mine = boxes[rows == i].tolist()
        for j, a in enumerate(angles):
            c, s = math.cos(a + roll), math.sin(a + roll)
            best = math.inf
            for y0, y1, z0, z1, _ in mine:
                t0, t1 = y0 / c, y1 / c
                if abs(s) > 1e-12:
                    u0, u1 = (z0 - H) / s, (z1 - H) / s
                    t0, t1 = max(t0, min(u0, u1)), min(t1, max(u0, u1))
                elif not z0 <= H <= z1:
                    continue
                if t0 <= t1 and t1 > 0 and t0 < best:
                    best = t0
            out[k, j] = best
    return out


def median_time(fn, repeats):
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    print(f"{N_SCANS} scans, median of {args.repeats} repeats, one thread\n")
    head = (f"{'scenario':<9} {'simulate s':>10} {'scans/s':>9} {'savez s':>8} "
            f"{'sim/savez':>9} {'loop s (est.)':>13} {'loop/sim':>8} {'<=10 s':>6}")
    print(head)
    print("-" * len(head))
    for scenario in STREET_SCENARIOS:
        t_sim = median_time(
            lambda sc=scenario: make_street_scans(N_SCANS, scenario=sc, random_state=0),
            args.repeats)
        sim = _simulate(N_SCANS, scenario, 0)

        def save(r=sim["ranges"]):
            np.savez_compressed(io.BytesIO(), ranges=r)

        t_save = median_time(save, args.repeats)
        subset = np.linspace(0, N_SCANS - 1, LOOP_SCANS).astype(int)
        t_loop = median_time(lambda s=sim, i=subset: naive_ray_cast(s, i), max(1, args.repeats // 2))
        t_loop *= N_SCANS / LOOP_SCANS
        print(f"{scenario:<9} {t_sim:>10.2f} {N_SCANS / t_sim:>9.0f} {t_save:>8.2f} "
              f"{t_sim / t_save:>9.2f} {t_loop:>13.1f} {t_loop / t_sim:>8.1f} "
              f"{'yes' if t_sim <= 10 else 'NO':>6}")


if __name__ == "__main__":
    main()
