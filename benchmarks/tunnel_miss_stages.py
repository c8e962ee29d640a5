"""Which stage loses each missed sign: the FIR detector's misses, stage by stage.

Fits the default detector (or one with ``--set`` overrides) on the plain tuning tour
of ``docs/figures/cross_condition_tunnel_table.py`` and runs it on tours of the
conditions asked for, on TUNING seeds only.  Besides the table's named conditions it
knows five that no issue names (appended to the table's list, so each gets the seed
offset of its place, 10 x index):

* ``camera-2.4m``: camera A mounted 2.4 m high;
* ``pitch-0.3``: camera A with 0.3 deg of body-pitch jitter;
* ``curve-left-1000-heavy``: camera A, heavy traffic in a 1,000 m left curve;
* ``randomized``: the tunnel simulator's randomized scenario;
* ``focal-550-noise6``: camera A with a 550 px focal length and noise sigma 6.

For every sign at least 14 px tall in some frame that no positive trajectory holds,
it prints, over the frames the sign is in view: frames with a sampled keypoint on it,
with a verified keypoint (of those: frames in which the clusters of the sign's
keypoints also hold keypoints off the sign, ``merged``; with one brighter than every
keypoint on the sign, ``merged brighter``, so the contrast box follows the other
object; in which one of those clusters has a box over 1.5 times the sign's width or
height, ``box > 1.5 sign``), with a cluster centred on it, with that cluster's
appearance positive, with that cluster an indicator; and the trajectories of its
clusters (clusters on the sign, length, motion r, positive).  Reading it: no
verified keypoint -> keypoints/verifier; keypoints but no cluster centred on the
sign -> clusters (merged into another object's cluster); clusters but appearance
negative -> appearance; long trajectories with r >= min_r but most clusters not
indicators -> the vote (appearance, or other objects' clusters linked into the
trajectory); short trajectories -> the linker or min_length.

``--false-alarms`` also prints every false-alarm trajectory (positive, fewer than
half of its clusters on a sign): its length and, for a dozen of its clusters, the
frame, the box centre and height (in the frame's pixels), the ground-truth objects
(class, id) the centre lies in and the cluster's appearance decision.

Usage::

    python benchmarks/tunnel_miss_stages.py [--conditions randomized ...]
        [--seeds 101 102 103 104] [--set appearance__core=None] [--false-alarms]
"""

from __future__ import annotations

import argparse
import ast
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "docs" / "figures"))
import cross_condition_tunnel_table as table  # noqa: E402

from tunnelsense import make_indicator_pipeline, to_xy  # noqa: E402
from tunnelsense.metrics import indicator_scores  # noqa: E402

UNNAMED = {
    "camera-2.4m": dict(scenario="light", **{**table.CAMERA_A, "mount_height_m": 2.4}),
    "pitch-0.3": dict(scenario="light", pitch_jitter_deg=0.3, **table.CAMERA_A),
    "curve-left-1000-heavy": dict(scenario="heavy", curve_radius_m=-1000.0,
                                  **table.CAMERA_A),
    "randomized": dict(scenario="randomized"),
    "focal-550-noise6": dict(scenario="light", **{**table.CAMERA_A,
                                                  "focal_length_px": 550.0,
                                                  "noise_sigma": 6.0}),
}
table.CONDITIONS.update(UNNAMED)


def _inside(points, box):
    """Rows of ``(row, col, ...)`` points inside ``(left, top, width, height)``."""
    points = np.asarray(points).reshape(-1, 3)
    left, top, w, h = box
    return ((points[:, 1] >= left) & (points[:, 1] < left + w)
            & (points[:, 0] >= top) & (points[:, 0] < top + h))


def sign_stages(out, gt):
    """Per indicator id: frame counts per stage and its clusters' trajectories."""
    stages = defaultdict(lambda: defaultdict(int))
    tracks = defaultdict(lambda: defaultdict(int))
    about = {}
    by_frame = {f: g for f, g in gt.groupby("frame")}
    for r in out:
        rows = by_frame.get(r.frame)
        if rows is None:
            continue
        p = r.payload
        sx, sy = p.get("frame_scale", (1.0, 1.0))
        boxes = np.asarray(p["cluster_boxes"], np.float64).reshape(-1, 4)
        cx, cy = boxes[:, 0] + boxes[:, 2] / 2, boxes[:, 1] + boxes[:, 3] / 2
        for g in rows.itertuples():
            box = (g.bb_left * sx, g.bb_top * sy, g.bb_width * sx, g.bb_height * sy)
            d = stages[g.id]
            d["in view"] += 1
            d["sampled"] += bool(_inside(p.get("sampled_keypoints", p["keypoints"]),
                                         box).any())
            kp = np.asarray(p["keypoints"]).reshape(-1, 3)
            on_kp = _inside(kp, box)
            d["verified"] += bool(on_kp.any())
            if on_kp.any():
                # what shares the sign's clusters, and how far their boxes spread
                labels = np.asarray(p["cluster_labels"])
                off = np.isin(labels, labels[on_kp]) & ~on_kp
                d["merged"] += bool(off.any())
                d["merged brighter"] += bool(off.any()
                                             and kp[off, 2].max() > kp[on_kp, 2].max())
                own = boxes[np.unique(labels[on_kp])]
                d["box > 1.5 sign"] += bool(((own[:, 2] > 1.5 * box[2])
                                             | (own[:, 3] > 1.5 * box[3])).any())
            on = np.flatnonzero((cx >= box[0]) & (cx < box[0] + box[2])
                                & (cy >= box[1]) & (cy < box[1] + box[3]))
            if not len(on):
                continue
            d["cluster"] += 1
            d["appearance+"] += bool(np.asarray(p["appearance"])[on].any())
            d["indicator"] += bool(np.asarray(p["indicator"])[on].any())
            for j in on.tolist():
                tid = int(p["track_ids"][j])
                tracks[g.id][tid] += 1
                about[tid] = (int(p["trajectory_length"][j]), float(p["motion_r"][j]),
                              bool(p["trajectory_positive"][j]))
    return stages, tracks, about


def false_alarm_tracks(out, gt_all):
    """Per false-alarm trajectory: ``(frame, x, y, height, [(class, id)], appearance)``
    of each of its clusters (the scorer's rule: fewer than half on an indicator)."""
    by_frame = {f: g for f, g in gt_all.groupby("frame")}
    tracks = defaultdict(list)
    for r in out:
        p = r.payload
        sx, sy = p.get("frame_scale", (1.0, 1.0))
        boxes = np.asarray(p["cluster_boxes"], np.float64).reshape(-1, 4)
        for j in np.flatnonzero(np.asarray(p["trajectory_positive"])).tolist():
            left, top, w, h = boxes[j] / (sx, sy, sx, sy)
            cx, cy = left + w / 2, top + h / 2
            g = by_frame.get(r.frame)
            hit = []
            if g is not None:
                m = ((g.bb_left <= cx) & (cx < g.bb_left + g.bb_width)
                     & (g.bb_top <= cy) & (cy < g.bb_top + g.bb_height))
                hit = list(zip(g["class"][m].tolist(), g["id"][m].tolist(),
                               strict=True))
            tracks[int(p["track_ids"][j])].append(
                (r.frame, round(cx), round(cy), round(h), hit,
                 bool(p["appearance"][j])))
    return {t: rows for t, rows in tracks.items()
            if 2 * sum(any(c == 1 for c, _ in row[4]) for row in rows) < len(rows)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--conditions", nargs="*", default=list(UNNAMED))
    ap.add_argument("--seeds", nargs="*", type=int, default=[101, 102, 103, 104])
    ap.add_argument("--frames", type=int, default=600)
    ap.add_argument("--set", nargs="*", default=[], metavar="STEP__PARAM=VALUE")
    ap.add_argument("--false-alarms", action="store_true",
                    help="print what each false-alarm trajectory lies on")
    args = ap.parse_args(argv)
    if any(s >= table.EVAL_TRAIN_SEED for s in args.seeds):
        ap.error("tuning seeds only (below the evaluation seeds)")
    params = {k: ast.literal_eval(v) for k, v in (s.split("=", 1) for s in args.set)}
    X, y, _ = to_xy([table.tour("plain", table.TUNING_TRAIN_SEED, args.frames)])
    model = make_indicator_pipeline(random_state=0, **params).fit(X, y)
    print(f"fitted on plain (seed {table.TUNING_TRAIN_SEED}), overrides {params}")
    for c in args.conditions:
        found = total = fa = 0
        for seed in args.seeds:
            t = table.tour(c, seed, args.frames)
            X, y, _ = to_xy([t])
            out = model.predict(X)
            s = indicator_scores(out, y)["trajectory"]
            found, total, fa = (found + s["detected"], total + s["indicators"],
                                fa + s["false_alarms"])
            gt = t.gt[t.gt["class"] == 1]
            stages, tracks, about = sign_stages(out, gt)
            for gid in sorted(set(gt.loc[gt["bb_height"] >= 14, "id"])):
                if any(about[tid][2] for tid in tracks[gid]):
                    continue
                g = gt[gt["id"] == gid]
                mine = sorted(tracks[gid].items(), key=lambda kv: -kv[1])[:3]
                print(f"  {c} seed {seed} sign {gid}: frames {g.frame.min()}-"
                      f"{g.frame.max()}, {g.bb_height.min():.0f}-{g.bb_height.max():.0f}"
                      " px; " + ", ".join(f"{k} {v}" for k, v in stages[gid].items())
                      + "; trajectories " + "; ".join(
                          f"{n} on it of {about[t][0]}, r {about[t][1]:.3f}"
                          for t, n in mine))
            if args.false_alarms:
                for tid, rows in false_alarm_tracks(out, t.gt).items():
                    print(f"  {c} seed {seed} false alarm {tid}: {len(rows)} "
                          "clusters (frame, x, y, height, on (class, id), appearance)")
                    for row in rows[:: max(1, len(rows) // 12)]:
                        print("     ", row)
        print(f"{c}: {found}/{total}, {fa} false-alarm trajectories", flush=True)


if __name__ == "__main__":
    main()
