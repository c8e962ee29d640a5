"""Positioning error of TunnelPositioner beside dead reckoning alone.

Two parts:

* ``statistical`` (default): tours of 1-10 km, odometry scale errors 0.5-5 %, with
  and without detection failures (one missed sign and one false alarm per 2 km).
  Rendering 10 km of video would take many minutes, so the detector's output is
  simulated from the pinhole model (``simulate_indicator_detections``: each sign a
  trajectory from 12 px tall until it leaves the image, box heights with 3 %
  noise); the timing error of its passes is printed beside the real detector's.
* ``--rendered``: a 2-km tour rendered, the real detector trained on another tour
  and run on it, then the positioner (end to end, about 2 minutes).

For each setting, the worst over ``--seeds`` tours: the maximum error of dead
reckoning (DR), of the online filter (what is known at each frame), of the online
filter once two signs have been passed, and of the offline smoother, and the
smoother's worst error at an indicator pass; also the positioner's time per frame.

Run from a source checkout or an unpacked sdist (no extra needed)::

    python docs/figures/positioning_accuracy.py [--seeds 3] [--rendered]

It prints the tables of the Positioning page, the machine and the day.
"""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import shutil  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import machine  # noqa: E402

from tunnelsense.datasets import (  # noqa: E402
    make_tunnel_kinematics,
    make_tunnel_odometry,
    simulate_indicator_detections,
)
from tunnelsense.positioning import (  # noqa: E402
    TunnelPositioner,
    dead_reckoning,
    position_errors,
)


def _run(positions, odometry, indicators, det):
    """Errors of the online filter and of the smoother on one tour."""
    out = {}
    t0 = time.perf_counter()
    online, fixes = TunnelPositioner().fit(indicators).predict(det, odometry,
                                                                return_fixes=True)
    out["us_per_frame"] = 1e6 * (time.perf_counter() - t0) / len(odometry)
    smooth = TunnelPositioner(smooth=True).fit(indicators).predict(det, odometry)
    e_on = position_errors(positions, online, odometry, indicators)
    e_sm = position_errors(positions, smooth, odometry, indicators)
    kept = fixes[fixes["accepted"]]
    err = np.abs(online["chainage"] - positions["chainage"]).to_numpy()
    after = (online["frame"].to_numpy() > kept["pass_frame"].iloc[1]
             if len(kept) > 1 else np.zeros(len(err), bool))
    out.update(
        dr=e_on["dead_reckoning"]["max"], online=e_on["max"],
        online_after_2=float(err[after].max()) if after.any() else np.nan,
        smooth=e_sm["max"], smooth_passes=e_sm["max_at_passes"] or 0.0,
        kept=len(kept), rejected=int((~fixes["accepted"]).sum()),
    )
    return out, fixes


def _pass_timing(fixes, positions, odometry):
    """Odometry-distance error of each kept fix's pass (m)."""
    dr = dead_reckoning(odometry)
    s = positions["chainage"].to_numpy()
    kept = fixes[fixes["accepted"]]
    return kept["pass_distance"].to_numpy() - np.interp(
        kept["indicator_chainage"].to_numpy(), s, dr)


def statistical(seeds):
    print("statistical detector model: worst over", len(seeds), "tours per row\n")
    head = (f"{'km':>4} {'scale':>6} {'failures':>9} {'DR max':>8} {'online':>8} "
            f"{'online>2':>9} {'smooth':>7} {'at pass':>8} {'kept/rej':>9} "
            f"{'us/frame':>9}")
    print(head)
    print("-" * len(head))
    timing = []
    for km in (1, 2, 5, 10):
        for scale in (0.005, 0.01, 0.03, 0.05):
            for failures in (False, True):
                rows = []
                for seed in seeds:
                    truth = make_tunnel_kinematics(1000.0 * km, random_state=seed)
                    positions, odometry, indicators = make_tunnel_odometry(
                        truth, scale_error=scale, random_state=seed)
                    missed, false = [], []
                    if failures:
                        c, ids = truth.indicator_chainage, truth.indicator_ids
                        for k in range(2, len(c) - 3, 10):  # every 2 km
                            missed.append(int(ids[k]))
                            false.append(float(c[k + 2] + 57.0))
                    det = simulate_indicator_detections(
                        truth, missed=missed, false_alarms=false, random_state=seed)
                    r, fixes = _run(positions, odometry, indicators, det)
                    rows.append(r)
                    if scale == 0.03 and not failures:
                        timing.extend(_pass_timing(fixes, positions, odometry))
                worst = {k: max(r[k] for r in rows) for k in rows[0]}
                kept = min(r["kept"] for r in rows)
                print(f"{km:>4} {100 * scale:>5.1f}% {'1 per 2 km' if failures else '-':>9} "
                      f"{worst['dr']:>8.1f} {worst['online']:>8.2f} "
                      f"{worst['online_after_2']:>9.2f} {worst['smooth']:>7.2f} "
                      f"{worst['smooth_passes']:>8.2f} "
                      f"{kept:>4}/{worst['rejected']:<4} {worst['us_per_frame']:>9.0f}")
    timing = np.asarray(timing)
    print(f"\npass timing error of the statistical detector: mean {timing.mean():+.2f} m, "
          f"sd {timing.std():.2f} m ({len(timing)} passes)")


def rendered(seed):
    from tunnelsense.cli import main
    from tunnelsense.datasets import make_tunnel_tour
    from tunnelsense.io import read_mot_results, write_tour
    from tunnelsense.positioning import (
        read_indicator_map,
        read_odometry,
        read_positions,
    )

    root = Path(tempfile.mkdtemp(prefix="positioning-accuracy-"))
    t0 = time.perf_counter()
    write_tour(make_tunnel_tour(600, random_state=seed + 100), root / "train")
    tour = make_tunnel_tour(2700, random_state=seed, first_indicator_m=60.0,
                            speed_kmh=(80.0, 100.0))
    write_tour(tour, root / "tour")
    t_render = time.perf_counter() - t0
    main(["train", "tunnel", str(root / "train"), "--model", str(root / "m.skops"),
          "--quiet", "--jobs", "1"])
    t0 = time.perf_counter()
    main(["detect", "tunnel", "--model", str(root / "m.skops"), str(root / "tour"),
          "--out", str(root / "r.txt"), "--quiet", "--jobs", "1"])
    t_detect = time.perf_counter() - t0
    positions = read_positions(root / "tour" / "positions.csv")
    odometry = read_odometry(root / "tour" / "odometry.csv")
    indicators = read_indicator_map(root / "tour" / "indicators.csv")
    det = read_mot_results(root / "r.txt")
    r, fixes = _run(positions, odometry, indicators, det)
    timing = _pass_timing(fixes, positions, odometry)
    print(f"\nrendered tour: {len(odometry)} frames, {positions['chainage'].iloc[-1]:.0f} m, "
          f"odometry scale error 3 % (rendered in {t_render:.0f} s, detected in "
          f"{t_detect:.0f} s)")
    print(f"  dead reckoning max {r['dr']:.1f} m; online max {r['online']:.2f} m "
          f"(after two signs {r['online_after_2']:.2f} m); smoothed max "
          f"{r['smooth']:.2f} m, at the passes {r['smooth_passes']:.2f} m; fixes kept "
          f"{r['kept']}, rejected {r['rejected']}")
    print(f"  pass timing error of the real detector: mean {timing.mean():+.2f} m, sd "
          f"{timing.std():.2f} m ({len(timing)} passes)")
    shutil.rmtree(root, ignore_errors=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--rendered", action="store_true",
                        help="also a rendered 2-km tour with the real detector")
    parser.add_argument("--only-rendered", action="store_true")
    args = parser.parse_args()
    print(machine())
    if not args.only_rendered:
        statistical(list(range(args.seeds)))
    if args.rendered or args.only_rendered:
        rendered(0)


if __name__ == "__main__":
    main()
