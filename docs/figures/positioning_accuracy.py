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
* ``--memory``: the online stream's time per frame and memory on tours of 3k, 30k
  and 300k frames (``tracemalloc``: what the stream holds at the end and at its
  peak, the final rows drained every 1,024 frames as ``position --model`` does).
* ``--lock``: tours that start mid-tunnel on maps with irregular gaps (150-250 m),
  with no start: the passes until the lock, wrong locks, the error after the lock;
  and with a start 10 m off (sigma 20 m).  Each also with the sign's size in the
  image given (focal length and sign height: the box growth then measures the
  odometry's scale), and with it believed 2 % off.
* ``--speed``: ``position --model`` beside ``detect tunnel`` on one rendered tour,
  alternating in one run (``--frames``, default 3,000), medians and their ratio.

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
from _positioning_lock import lock  # noqa: E402

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
    size = _box_growth_scale(det, odometry, positions, 800.0 * 1.0)  # the renderer's
    print(f"  scale from the box growth (f H = 800 px x 1 m, the renderer's), relative "
          f"to the true scale: mean {size.mean():+.1%}, sd {size.std():.1%} "
          f"({len(size)} trajectories)")
    shutil.rmtree(root, ignore_errors=True)


def _box_growth_scale(det, odometry, positions, size):
    """Each trajectory's scale from its box growth (``scale_from_slope``), relative
    to the tour's true scale (true distance / odometry distance) less 1."""
    from tunnelsense.positioning import detection_table, scale_from_slope

    d = dead_reckoning(odometry)
    s = positions["chainage"].to_numpy()
    c_true = (s[-1] - s[0]) / (d[-1] - d[0])
    frames = odometry["frame"].to_numpy()
    out = []
    for _, g in detection_table(det).groupby("track_id"):
        h = g["bb_height"].to_numpy()
        keep = h >= 8.0
        c, _ = scale_from_slope(np.interp(g["frame"].to_numpy()[keep], frames, d),
                                h[keep], size)
        if np.isfinite(c):
            out.append(c / c_true - 1.0)
    return np.asarray(out)


def _stream_run(pos, rows, frames, tracks, heights):
    """Push a tour through a fresh stream; drain it every 1,024 frames."""
    stream, n_fixes = pos.start_stream(), 0
    for k, (f, t, v, a, b) in enumerate(rows, 1):
        stream._advance(f, t, v)
        if b > a:
            stream._add_rows(frames[a:b], tracks[a:b], heights[a:b])
        stream._finish(f)
        if k % 1024 == 0:
            stream.drain()
            n_fixes += int(stream.drain_fixes()["accepted"].sum())
    return stream, n_fixes


def memory(sizes=(3_000, 30_000, 300_000), repeats=3, kmh=None):
    """Time per frame and memory of the online stream, flat in the tour's length."""
    import tracemalloc

    print(f"stream time (median of {repeats}) and memory held at the end and at the "
          "peak")
    print(f"{'frames':>8} {'km/h':>5} {'us/frame':>9} {'held KB':>8} {'peak KB':>8} "
          f"{'fixes':>6}")
    for n in sizes:
        # 80 km/h; slower where the tour would pass the simulator's 1,000 km
        v = min(80.0, 0.95e6 / (n / 30.0) * 3.6) if kmh is None else float(kmh)
        distance = n / 30.0 * v / 3.6
        truth = make_tunnel_kinematics(distance, speed_kmh=v, random_state=0)
        _, odometry, indicators = make_tunnel_odometry(truth, random_state=0)
        det = simulate_indicator_detections(truth, random_state=0)
        odometry = odometry.iloc[:n]
        det = det[det["frame"] <= n]
        pos = TunnelPositioner().fit(indicators)
        frames = det["frame"].to_numpy()
        starts = np.searchsorted(frames, odometry["frame"].to_numpy()).tolist()
        ends = np.searchsorted(frames, odometry["frame"].to_numpy(), "right").tolist()
        tracks, heights = det["id"].tolist(), det["bb_height"].tolist()
        frames = frames.tolist()
        rows = list(zip(odometry["frame"].tolist(), odometry["stamp"].tolist(),
                        odometry["speed"].tolist(), starts, ends, strict=True))

        args = (pos, rows, frames, tracks, heights)
        times = []
        for _ in range(repeats):  # time without tracemalloc (it slows allocation)
            t0 = time.perf_counter()
            _stream_run(*args)
            times.append(time.perf_counter() - t0)
        tracemalloc.start()
        base = tracemalloc.get_traced_memory()[0]
        stream, n_fixes = _stream_run(*args)
        held, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        stream.close()
        print(f"{n:>8} {v:>5.0f} {1e6 * np.median(times) / n:>9.1f} "
              f"{(held - base) / 1024:>8.0f} "
              f"{(peak - base) / 1024:>8.0f} {n_fixes:>6}")




def speed(n_frames, repeats=3, seed=0):
    """``position --model`` beside ``detect tunnel`` on one tour, in one run."""
    from tunnelsense._cli import main as cli
    from tunnelsense.datasets import make_tunnel_tour
    from tunnelsense.io import write_tour

    root = Path(tempfile.mkdtemp(prefix="bench-position-speed-"))
    write_tour(make_tunnel_tour(600, random_state=seed + 100), root / "train")
    write_tour(make_tunnel_tour(n_frames, random_state=seed, first_indicator_m=60.0,
                                speed_kmh=(80.0, 100.0)), root / "tour")
    model = str(root / "m.skops")
    cli(["train", "tunnel", str(root / "train"), "--model", model, "--quiet",
         "--jobs", "1"])
    tour = str(root / "tour")
    commands = {
        "detect tunnel": ["detect", "tunnel", "--model", model, tour, "--out",
                          str(root / "r.txt"), "--quiet", "--force"],
        "position --model": ["position", tour, "--model", model, "--out",
                             str(root / "p.csv"), "--quiet", "--force"],
    }
    times = {k: [] for k in commands}
    cpu = {k: [] for k in commands}
    for _ in range(repeats):  # alternating, so both see the same machine load
        for name, args in commands.items():
            t0, c0 = time.perf_counter(), time.process_time()
            assert cli(args) == 0
            times[name].append(time.perf_counter() - t0)
            cpu[name].append(time.process_time() - c0)
    print(f"{n_frames} frames, {repeats} runs each, alternating (wall and CPU time of "
          "the process, reader threads included):")
    for what, table in (("wall", times), ("CPU", cpu)):
        med = {k: float(np.median(v)) for k, v in table.items()}
        for name, v in table.items():
            print(f"  {what:4} {name:17} median {med[name]:6.2f} s  "
                  f"({', '.join(f'{t:.2f}' for t in v)})")
        pairs = np.divide(table["position --model"], table["detect tunnel"])
        print(f"  {what:4} ratio position --model / detect tunnel: "
              f"{med['position --model'] / med['detect tunnel']:.3f} (of medians); "
              f"median of the pairs {np.median(pairs):.3f} "
              f"({', '.join(f'{r:.3f}' for r in pairs)})")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--rendered", action="store_true",
                        help="also a rendered 2-km tour with the real detector")
    parser.add_argument("--only-rendered", action="store_true")
    parser.add_argument("--memory", action="store_true", help="only the stream's "
                        "time and memory from 3k to 300k frames")
    parser.add_argument("--lock", action="store_true", help="only lock-on and a start "
                        "10 m off, on --seeds tours from --first-seed")
    parser.add_argument("--first-seed", type=int, default=1000, help="first seed of "
                        "the --lock tours (evaluation seeds: never used to choose a "
                        "setting; the settings were chosen on 5000-5299 and 6000-6199)")
    parser.add_argument("--harder", action="store_true", help="--lock tours with "
                        "scale errors of 2-4 %% (instead of 1-4 %%)")
    parser.add_argument("--failures", action="store_true", help="--lock tours with "
                        "one of the first three signs missed and a false alarm in the "
                        "first 600 m (lock-on only)")
    parser.add_argument("--side", default="left", choices=["left", "random"],
                        help="--lock maps: the indicators' wall (random: each on "
                        "either)")
    parser.add_argument("--speed", action="store_true", help="only position --model "
                        "beside detect tunnel on one rendered tour")
    parser.add_argument("--frames", type=int, default=3000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    print(machine())
    if args.speed:
        speed(args.frames, args.repeats)
        return
    if args.memory:
        memory()
        return
    if args.lock:
        lock(list(range(args.first_seed, args.first_seed + args.seeds)),
             (0.02, 0.04) if args.harder else (0.01, 0.04), args.failures, args.side)
        return
    if not args.only_rendered:
        statistical(list(range(args.seeds)))
    if args.rendered or args.only_rendered:
        rendered(0)


if __name__ == "__main__":
    main()
