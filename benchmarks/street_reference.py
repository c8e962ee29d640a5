"""The paper's street method, implemented plainly with NumPy and SciPy: a speed peer.

Hirahara and Ikeuchi, section III, step by step, with nothing of tunnelsense imported:

* restoration: polar ranges to (depth, height), the sensor ``mount_height`` above the
  road (III-A);
* tilt: the first ``--road-beams`` beams with a return hit the road; each gives the
  tilt that puts its point at height 0, their median is the scan's tilt (III-B);
* ROI: 0.1 m < height < 2.0 m, no-return beams dropped (III-C);
* intra-scan clustering: single linkage (``scipy.cluster.hierarchy``), the tree cut at
  0.6 m (III-D);
* inter-scan clustering: clusters of consecutive scans whose mean depths differ by less
  than 0.5 m are one object; an object ends when the next scan has nothing to link
  (III-E);
* three regions (depth < 4.0 m, 4.0-6.6 m, > 6.6 m): a smaller object within the scans
  of a larger one in the same region is merged into it; the region labels the object
  (I passing, II parked, III roadside: the paper's experiment) (III-F).

It reads ``scans.npz`` and writes ``id,first_scan,last_scan,label`` for the objects of
regions I and II, as ``detect street`` does (without its extra columns), and prints
recall and precision against the run's ``gt.csv`` (scan-interval IoU >= 0.5) to show
that it works.

    python benchmarks/street_reference.py RUN OUT.csv
"""

import argparse
import csv
import sys
from pathlib import Path

import numpy as np
from scipy.cluster.hierarchy import fcluster, linkage

CUT = 0.6  # m, intra-scan single-linkage cut
LINK = 0.5  # m, inter-scan mean-depth difference
ROI = (0.1, 2.0)  # m, height
REGIONS = (4.0, 6.6)  # m, depth borders of regions I | II | III
LABELS = {1: "passing", 2: "parked", 3: "roadside"}


def restore(z, road_beams):
    """Depth and height of every beam (NaN where no return), tilt compensated."""
    r = np.asarray(z["ranges"], dtype=np.float64)
    r = np.where((r >= float(z["range_min"])) & (r < float(z["range_max"])), r, np.nan)
    theta = float(z["angle_min"]) + float(z["angle_increment"]) * np.arange(r.shape[1])
    mount = float(z["mount_height"])
    # the first beams with a return hit the road (height 0): each gives the tilt that
    # puts it there; their median is the scan's tilt
    with np.errstate(invalid="ignore"):
        each = -np.arcsin(np.clip(mount / r, -1.0, 1.0)) - theta
    each[~(r >= mount)] = np.nan
    order = np.argsort(np.isnan(each), axis=1, kind="stable")[:, :road_beams]
    first = np.take_along_axis(each, order, axis=1)
    seen = ~np.isnan(first).all(axis=1)
    tilt = np.zeros(len(r))
    tilt[seen] = np.nanmedian(first[seen], axis=1)
    angle = theta[None, :] + tilt[:, None]
    return r * np.cos(angle), mount + r * np.sin(angle)


def intra_clusters(depth, height):
    """Per scan: (mean depth, number of points) of each single-linkage cluster."""
    keep = (height > ROI[0]) & (height < ROI[1])  # NaN compares False
    out = []
    for i in range(depth.shape[0]):
        points = np.column_stack([depth[i, keep[i]], height[i, keep[i]]])
        if len(points) == 0:
            out.append(np.empty((0, 2)))
            continue
        if len(points) == 1:
            labels = np.ones(1, dtype=int)
        else:
            labels = fcluster(linkage(points, "single"), CUT, criterion="distance")
        n = np.bincount(labels)[1:]
        mean = np.bincount(labels, weights=points[:, 0])[1:] / np.maximum(n, 1)
        out.append(np.column_stack([mean[n > 0], n[n > 0]]))
    return out


def inter_clusters(clusters):
    """Objects: [first_scan, last_scan, mean depth, n_points] of linked clusters."""
    ids = []
    start = 0
    for c in clusters:
        ids.append(np.arange(start, start + len(c)))
        start += len(c)
    parent = np.arange(start)

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for i in range(1, len(clusters)):
        prev, cur = clusters[i - 1], clusters[i]
        if len(prev) == 0 or len(cur) == 0:
            continue
        near = np.abs(prev[:, 0][:, None] - cur[:, 0][None, :]) < LINK
        for a, b in zip(*np.nonzero(near), strict=True):
            ra, rb = find(ids[i - 1][a]), find(ids[i][b])
            if ra != rb:
                parent[max(ra, rb)] = min(ra, rb)
    scan = np.concatenate([np.full(len(c), i) for i, c in enumerate(clusters)])
    every = np.concatenate([c for c in clusters if len(c)] or [np.empty((0, 2))])
    roots = np.array([find(a) for a in range(start)], dtype=int)
    objects = []
    for root in np.unique(roots):
        member = roots == root
        n = every[member, 1].sum()
        objects.append([scan[member].min(), scan[member].max(),
                        (every[member, 0] * every[member, 1]).sum() / n, n])
    return np.array(objects).reshape(-1, 4)


def merge_regions(objects):
    """Merge a smaller object within a larger one's scans in the same region."""
    region = 1 + np.searchsorted(REGIONS, objects[:, 2])
    order = np.argsort(-objects[:, 3], kind="stable")  # larger first
    alive = np.ones(len(objects), dtype=bool)
    for a in order:
        if not alive[a]:
            continue
        inside = (alive & (region == region[a]) & (objects[:, 0] >= objects[a, 0])
                  & (objects[:, 1] <= objects[a, 1]) & (objects[:, 3] < objects[a, 3]))
        for b in np.flatnonzero(inside):
            n = objects[a, 3] + objects[b, 3]
            objects[a, 2] = (objects[a, 2] * objects[a, 3]
                             + objects[b, 2] * objects[b, 3]) / n
            objects[a, 3] = n
            alive[b] = False
    kept = objects[alive]
    return kept, 1 + np.searchsorted(REGIONS, kept[:, 2])


def scores(objects, labels, gt_path):
    """Recall and precision per label (scan-interval IoU >= 0.5, one-to-one)."""
    with open(gt_path, newline="") as f:
        gt = [(int(r["first_scan"]), int(r["last_scan"]), r["label"])
              for r in csv.DictReader(f)]
    text = []
    for label in ("parked", "passing"):
        truth = [(a, b) for a, b, lab in gt if lab == label]
        found = [(int(o[0]), int(o[1])) for o, lab in zip(objects, labels, strict=True)
                 if LABELS[lab] == label]
        used, hits = set(), 0
        for a, b in truth:
            for j, (c, d) in enumerate(found):
                inter = min(b, d) - max(a, c) + 1
                if j not in used and inter > 0 and inter / (max(b, d) - min(a, c) + 1) >= 0.5:
                    used.add(j)
                    hits += 1
                    break
        text.append(f"{label}: {hits} of {len(truth)} found, {len(found) - hits} false")
    return "; ".join(text)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", help="laser run folder (scans.npz, gt.csv)")
    parser.add_argument("out", help="object CSV to write")
    parser.add_argument("--road-beams", type=int, default=5,
                        help="first beams with a return taken as road (default 5)")
    args = parser.parse_args()
    run = Path(args.run)
    with np.load(run / "scans.npz") as z:
        depth, height = restore(z, args.road_beams)
    objects = inter_clusters(intra_clusters(depth, height))
    objects, region = merge_regions(objects)
    keep = region < 3
    objects, region = objects[keep], region[keep]
    order = np.lexsort((objects[:, 1], objects[:, 0]))
    with open(args.out, "w", newline="") as f:
        f.write("id,first_scan,last_scan,label\n")
        for i, k in enumerate(order, 1):
            f.write(f"{i},{int(objects[k, 0])},{int(objects[k, 1])},"
                    f"{LABELS[int(region[k])]}\n")
    if (run / "gt.csv").exists():
        print(f"{run.name}: {len(objects)} objects; "
              f"{scores(objects[order], region[order], run / 'gt.csv')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
