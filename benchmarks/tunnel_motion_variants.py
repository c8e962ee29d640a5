"""Motion-stage variants on every row of the tunnel matrix, the first five stages run once.

The motion stage (:class:`~tunnelsense.tunnel.PCCVerifier`) learns nothing, so its
settings can be compared on the same output of the first five stages: this script
fits the detector (default, or with ``--set`` overrides of the earlier stages) on
the plain training tour of ``docs/figures/cross_condition_tunnel_table.py``, runs
its first five stages once per test tour (cached, images dropped, under
``--cache``) and scores the motion variants given as ``--variant NAME:PARAM=VALUE,...``
(``before`` is always the default motion stage) with that script's counts
(indicators found / indicators, false-alarm trajectories).  The figures equal the
table's: the whole pipeline's ``predict`` runs the same stages on the same frames.

Usage::

    python benchmarks/tunnel_motion_variants.py --seeds tuning \
        --variant inward:max_inward_offset=0.3 [--set appearance__widest_sign=1.25] \
        [--conditions plain defects]
"""

from __future__ import annotations

import argparse
import ast
import pickle
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "docs" / "figures"))
import cross_condition_tunnel_table as table  # noqa: E402

from tunnelsense import FrameRecord, to_xy  # noqa: E402
from tunnelsense.metrics import indicator_scores  # noqa: E402
from tunnelsense.tunnel import PCCVerifier, make_indicator_pipeline  # noqa: E402
from tunnelsense.tunnel._pcc_stream import frame_size  # noqa: E402


class Shaped:
    """Stands in for a frame's image: its shape only (what the motion stage reads)."""

    def __init__(self, shape):
        self.shape = shape

    def load(self):
        raise RuntimeError("the image was dropped from the cache")


def tracked(pipe, condition, seed, cache):
    """The first five stages' output on a test tour, and its boxes (cached)."""
    path = cache / f"{condition}_{seed}.pkl"
    if path.exists():
        with open(path, "rb") as fh:
            return pickle.load(fh)
    X, y, _ = to_xy([table.tour(condition, seed, 600)])
    Z = [FrameRecord(r.tour, r.frame, Shaped(tuple(int(v) for v in frame_size(r)[::-1])),
                     r.payload) for r in pipe[:-1].transform(X)]
    with open(path, "wb") as fh:
        pickle.dump((Z, y), fh)
    return Z, y


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", choices=("evaluation", "tuning"), default="tuning")
    ap.add_argument("--conditions", nargs="*", default=None)
    ap.add_argument("--set", nargs="*", default=[], metavar="STEP__PARAM=VALUE")
    ap.add_argument("--variant", action="append", default=[], metavar="NAME:P=V,...")
    ap.add_argument("--cache", type=Path, default=Path("/tmp/tunnel-motion-variants"))
    args = ap.parse_args(argv)
    params = {k: ast.literal_eval(v) for k, v in (s.split("=", 1) for s in args.set)}
    train, seeds = ((table.TUNING_TRAIN_SEED, table.TUNING_TEST_SEEDS)
                    if args.seeds == "tuning"
                    else (table.EVAL_TRAIN_SEED, table.EVAL_TEST_SEEDS))
    variants = {"before": {}}
    for v in args.variant:
        name, _, spec = v.partition(":")
        variants[name] = {k: ast.literal_eval(x) for k, x in
                          (item.split("=", 1) for item in spec.split(",") if item)}
    cache = args.cache / args.seeds / "-".join(args.set or ["default"])
    cache.mkdir(parents=True, exist_ok=True)
    X, y, _ = to_xy([table.tour("plain", train, 600)])
    pipe = make_indicator_pipeline(random_state=0, **params).fit(X, y)
    motion = pipe[-1].get_params()
    print("| row | " + " | ".join(variants) + " |")
    print("|---" * (len(variants) + 1) + "|")
    for condition in args.conditions or list(table.CONDITIONS):
        model = pipe
        if condition in table.OWN_TRAINING:
            Xb, yb, _ = to_xy([table.tour(condition, train, 600)])
            model = make_indicator_pipeline(random_state=0, **params).fit(Xb, yb)
        runs = [tracked(model, condition, s, cache) for s in seeds]
        cells = []
        for extra in variants.values():
            found = total = fa = 0
            for Z, yz in runs:
                out = PCCVerifier(**{**motion, **extra}).fit(Z).predict(Z)
                s = indicator_scores(out, yz)["trajectory"]
                found, total, fa = (found + s["detected"], total + s["indicators"],
                                    fa + s["false_alarms"])
            cells.append(f"{found}/{total}, {fa}")
        print(f"| {condition} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
