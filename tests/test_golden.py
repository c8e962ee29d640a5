"""Today's detections, as a user sees them: a refactor must not change what a user gets.

The tours, runs and models are made afresh from fixed seeds through the public API and
the command line; the results files are compared with the ones committed in
``tests/data/golden``.  The comparison is of what a user sees, with stated tolerances,
not of bytes (a last-bit difference of a CPU's arithmetic must not fail the suite):

* tunnel detections: the same frames, each box within ``BOX_PX`` pixels of its
  golden box, and the same number of trajectories;
* tunnel clusters: at least ``CLUSTER_MATCH`` of the clusters on each side matched
  one to one (same frame, IoU >= 0.5), and the matched ones with the same indicator
  and trajectory labels, at least ``CLUSTER_MATCH`` of them;
* street objects: one to one, the same label and vehicle class, first and last scans
  within ``SCAN_TOL`` scans.

A change that is meant to alter detections regenerates them deliberately with
``TUNNELSENSE_REGENERATE_GOLDEN=1 pytest tests/test_golden.py`` and says why in its
commit.
"""

import csv
import os
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

from tunnelsense._cli import main
from tunnelsense.datasets import make_street_scans, make_tunnel_tour
from tunnelsense.io import write_run, write_tour

GOLDEN = Path(__file__).parent / "data" / "golden"
REGENERATE = os.environ.get("TUNNELSENSE_REGENERATE_GOLDEN") == "1"
BOX_PX = 1.0
CLUSTER_MATCH = 0.97
SCAN_TOL = 2


def _golden(produced: Path, name: str) -> Path:
    expected = GOLDEN / name
    if REGENERATE:
        expected.write_bytes(produced.read_bytes())
    assert expected.is_file(), f"no golden file {expected}"
    return expected


def _iou(a, b):
    """IoU of (left, top, width, height) boxes a (n, 4) and b (m, 4): (n, m)."""
    a, b = np.asarray(a, float).reshape(-1, 4), np.asarray(b, float).reshape(-1, 4)
    x0 = np.maximum(a[:, None, 0], b[None, :, 0])
    y0 = np.maximum(a[:, None, 1], b[None, :, 1])
    x1 = np.minimum((a[:, 0] + a[:, 2])[:, None], (b[:, 0] + b[:, 2])[None, :])
    y1 = np.minimum((a[:, 1] + a[:, 3])[:, None], (b[:, 1] + b[:, 3])[None, :])
    inter = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
    union = (a[:, 2] * a[:, 3])[:, None] + (b[:, 2] * b[:, 3])[None, :] - inter
    return inter / np.maximum(union, 1e-12)


def _match(a, b, min_iou=0.5):
    """Greedy one-to-one matching of two box lists by IoU: list of (i, j)."""
    if not len(a) or not len(b):
        return []
    iou = _iou(a, b)
    pairs = []
    for flat in np.argsort(-iou, axis=None, kind="stable"):
        i, j = divmod(int(flat), iou.shape[1])
        if iou[i, j] < min_iou:
            break
        if all(i != p and j != q for p, q in pairs):
            pairs.append((i, j))
    return pairs


def _mot_rows(path):
    rows = np.loadtxt(path, delimiter=",", ndmin=2)
    return rows[:, 0].astype(int), rows[:, 1].astype(int), rows[:, 2:6]


def test_match_helpers_find_a_shifted_box_and_refuse_a_far_one():
    assert _match([[0, 0, 10, 10]], [[1, 0, 10, 10]]) == [(0, 0)]
    assert _match([[0, 0, 10, 10]], [[8, 8, 10, 10]]) == []


@pytest.fixture(scope="module")
def tunnel_results(tmp_path_factory):
    root = tmp_path_factory.mktemp("golden-tunnel")
    train = make_tunnel_tour(300, scenario="light", random_state=11, first_indicator_m=40.0)
    test = make_tunnel_tour(300, scenario="heavy", random_state=12, first_indicator_m=30.0)
    write_tour(train, root / "train")
    write_tour(test, root / "test")
    model = root / "m.skops"
    assert main(["train", "tunnel", str(root / "train"), "--model", str(model),
                 "--quiet"]) == 0
    out = root / "test.txt"
    assert main(["detect", "tunnel", "--model", str(model), str(root / "test"),
                 "--out", str(out), "--quiet"]) == 0
    return out


@pytest.mark.slow
def test_tunnel_detections_unchanged(tunnel_results):
    expected = _golden(tunnel_results, "tunnel-results.txt")
    got_frames, got_ids, got_boxes = _mot_rows(tunnel_results)
    want_frames, want_ids, want_boxes = _mot_rows(expected)
    assert len(got_frames) == len(want_frames), (
        f"{len(got_frames)} detections against {len(want_frames)} in the golden file"
    )
    # one detection per frame and trajectory: compare frame by frame in order
    order_got = np.lexsort((got_boxes[:, 0], got_frames))
    order_want = np.lexsort((want_boxes[:, 0], want_frames))
    np.testing.assert_array_equal(got_frames[order_got], want_frames[order_want])
    np.testing.assert_allclose(got_boxes[order_got], want_boxes[order_want],
                               rtol=0, atol=BOX_PX)
    assert len(set(got_ids)) == len(set(want_ids))


@pytest.mark.slow
def test_tunnel_clusters_unchanged(tunnel_results):
    companion = tunnel_results.with_name(tunnel_results.stem + ".clusters.csv")
    assert companion.is_file()
    expected = _golden(companion, "tunnel-results.clusters.csv")

    def read(path):
        by_frame = defaultdict(list)
        with open(path, newline="") as f:
            for r in csv.DictReader(f):
                box = [float(r[k]) for k in ("bb_left", "bb_top", "bb_width", "bb_height")]
                by_frame[int(r["frame"])].append(
                    (box, r["indicator"], r["trajectory_positive"]))
        return by_frame

    got, want = read(companion), read(expected)
    n_got = sum(map(len, got.values()))
    n_want = sum(map(len, want.values()))
    matched = same_labels = 0
    for frame in set(got) | set(want):
        a, b = got.get(frame, []), want.get(frame, [])
        pairs = _match([c[0] for c in a], [c[0] for c in b])
        matched += len(pairs)
        same_labels += sum(a[i][1:] == b[j][1:] for i, j in pairs)
    assert matched >= CLUSTER_MATCH * max(n_got, n_want), (
        f"{matched} clusters matched of {n_got} produced and {n_want} golden"
    )
    assert same_labels >= CLUSTER_MATCH * matched


@pytest.mark.parametrize("scenario", ["dense", "crowded"])
def test_street_detections_unchanged(scenario, tmp_path):
    write_run(make_street_scans(1200, scenario="sparse", random_state=31), tmp_path / "a")
    write_run(make_street_scans(1200, scenario=scenario, random_state=32), tmp_path / "b")
    model = tmp_path / "m.skops"
    assert main(["train", "street", str(tmp_path / "a"), "--model", str(model)]) == 0
    out = tmp_path / "b.csv"
    assert main(["detect", "street", "--model", str(model), str(tmp_path / "b"),
                 "--out", str(out)]) == 0
    expected = _golden(out, f"street-{scenario}.csv")

    def read(path):
        with open(path, newline="") as f:
            return [(int(r["first_scan"]), int(r["last_scan"]), r["label"],
                     r["vehicle_class"]) for r in csv.DictReader(f)]

    got, want = read(out), read(expected)
    assert len(got) == len(want), f"{len(got)} objects against {len(want)} golden"
    unmatched = list(want)
    for first, last, label, kind in got:
        hit = [w for w in unmatched if w[2:] == (label, kind)
               and abs(w[0] - first) <= SCAN_TOL and abs(w[1] - last) <= SCAN_TOL]
        assert hit, (f"object scans {first}-{last} ({label}, {kind}) not in the "
                     "golden file")
        unmatched.remove(hit[0])
