"""Per-frame cost of the FIR detector with local-contrast keypoints beside the default,
beside OpenCV's PNG decode of the same frames, in one run.

The detector (``make_indicator_pipeline``) is fitted on one simulated plain tour
(tuning seed 1) twice: with the defaults and with
``keypoints__radiometry="contrast"`` (the settings of the cross-condition table's
``contrast`` method); a second tour (tuning seed 101, ``--frames`` frames) is then
predicted, the whole tour per call, and the same frames are decoded from PNG
(``cv2.imdecode``), interleaved, ``--repeats`` times.  Prints medians per frame and
the ratios to the decode.  One thread.

    python benchmarks/bench_contrast_radiometry.py --frames 300 --repeats 5
"""

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import cv2  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "docs" / "figures"))
import cross_condition_tunnel_table as table  # noqa: E402

from tunnelsense import to_xy  # noqa: E402
from tunnelsense.tunnel import make_indicator_pipeline  # noqa: E402

cv2.setNumThreads(1)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=300)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    X, y, _ = to_xy([table.tour("plain", table.TUNING_TRAIN_SEED, args.frames)])
    Xt, _, _ = to_xy([table.tour("plain", table.TUNING_TEST_SEEDS[0], args.frames)])
    models = {name: make_indicator_pipeline(random_state=0, **table.METHODS[name]).fit(X, y)
              for name in ("ours", "contrast")}
    pngs = [cv2.imencode(".png", r.image)[1] for r in Xt]

    def decode():
        for b in pngs:
            cv2.imdecode(b, cv2.IMREAD_UNCHANGED)

    runs = {"decode": decode}
    for name, model in models.items():
        runs[name] = (lambda m: lambda: m.predict(Xt))(model)
    times = {k: [] for k in runs}
    for _ in range(args.repeats):
        for k, f in runs.items():
            t0 = time.perf_counter()
            f()
            times[k].append((time.perf_counter() - t0) / len(Xt) * 1e3)
    med = {k: float(np.median(v)) for k, v in times.items()}
    for k, v in med.items():
        print(f"{k:>9}: {v:6.2f} ms/frame  ({v / med['decode']:.2f} x decode)")
    print(f" contrast / default: {med['contrast'] / med['ours']:.2f}")


if __name__ == "__main__":
    main()
