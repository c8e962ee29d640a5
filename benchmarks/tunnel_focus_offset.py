"""The focus-of-expansion check (``motion__max_focus_offset``) on every row of the
cross-condition matrix, with and without it, from ONE run of the default detector.

The check only removes trajectories, so the detector is run once per tour with the
check off; :func:`~tunnelsense.tunnel._pcc_measures.focus_offset` is computed on every
positive trajectory (frame size from the tour's frames) and the figures with the check
are those of the same clusters with the failing trajectories made negative.  Applying
the check in the detector (``cross_condition_tunnel_table.py --set
motion__max_focus_offset=X``) gives the same figures.

Usage::

    python benchmarks/tunnel_focus_offset.py [--seeds tuning|evaluation]
        [--offsets 0.5] [--conditions ...]
"""

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "docs" / "figures"))

import cross_condition_tunnel_table as cc  # noqa: E402

from tunnelsense import to_xy  # noqa: E402
from tunnelsense.metrics._tunnel import (  # noqa: E402
    gt_from_boxes,
    hypotheses_from_records,
    tunnel_scores,
)
from tunnelsense.tunnel import make_indicator_pipeline  # noqa: E402
from tunnelsense.tunnel._pcc_measures import focus_offset  # noqa: E402


def row(model, condition, seeds, offsets):
    """Per offset (None: off): found, indicators, false alarms; the largest offset
    of a positive trajectory."""
    totals = {o: [0, 0, 0] for o in (None, *offsets)}
    largest = 0.0
    for seed in seeds:
        t = cc.tour(condition, seed, 600)
        X, y, _ = to_xy([t])
        out = model.predict(X)
        hyp, gt = hypotheses_from_records(out), gt_from_boxes(out, y)
        height, width = t.frames[0].image.shape[:2]
        pos = hyp[hyp.trajectory_positive]
        measure = {}
        for tid, g in pos.groupby("track_id"):
            measure[tid] = focus_offset(g.bb_left + g.bb_width / 2,
                                        g.bb_top + g.bb_height / 2, width, height)
        largest = max([largest, *measure.values()])
        for o in totals:
            h = hyp.copy()
            if o is not None:
                bad = h.track_id.isin([k for k, v in measure.items() if v > o])
                h.loc[bad, ["trajectory_positive", "indicator"]] = False
            s = tunnel_scores(h, gt)["trajectory"]
            for i, key in enumerate(("detected", "indicators", "false_alarms")):
                totals[o][i] += s[key]
    return totals, largest


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", choices=("tuning", "evaluation"), default="tuning")
    ap.add_argument("--offsets", nargs="*", type=float, default=[0.5])
    ap.add_argument("--conditions", nargs="*", default=None)
    args = ap.parse_args(argv)
    train, seeds = ((cc.TUNING_TRAIN_SEED, cc.TUNING_TEST_SEEDS) if args.seeds == "tuning"
                    else (cc.EVAL_TRAIN_SEED, cc.EVAL_TEST_SEEDS))
    X, y, _ = to_xy([cc.tour("plain", train, 600)])
    model = make_indicator_pipeline(random_state=0).fit(X, y)
    print("| row | off | " + " | ".join(f"<= {o}" for o in args.offsets)
          + " | largest offset of a positive trajectory |")
    print("|---" * (len(args.offsets) + 3) + "|")
    for c in args.conditions or list(cc.CONDITIONS):
        m = model
        if c in cc.OWN_TRAINING:
            Xc, yc, _ = to_xy([cc.tour(c, train, 600)])
            m = make_indicator_pipeline(random_state=0).fit(Xc, yc)
        totals, largest = row(m, c, seeds, args.offsets)
        cells = [f"{a}/{b}, {f}" for a, b, f in totals.values()]
        print(f"| {c} | " + " | ".join(cells) + f" | {largest:.3f} |", flush=True)


if __name__ == "__main__":
    main()
