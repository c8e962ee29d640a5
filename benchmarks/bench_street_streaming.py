"""Streaming street detector: per-scan latency beside the batch throughput.

Run: ``python benchmarks/bench_street_streaming.py [n_scans] [repeats]``.  A simulated
"dense" street run (the simulator's default 241-beam scanner) is processed on one
thread by the same fitted detector

* online: ``ScanClusterer.start_stream()``, one ``push`` per scan, the time of every
  push recorded (p50, p99, max) and the scans per second of the whole stream;
* in batch: ``ScanClusterer.detect`` on the whole run (which runs the very same state
  machine over the run at once).

Every figure is the median over repeats measured in this run; the object tables of
both are checked identical.  The sensor delivers 75 scans/s (13.3 ms per scan).
"""

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from tunnelsense.datasets import make_street_scans  # noqa: E402
from tunnelsense.street import OBJECT_COLUMNS, ScanClusterer  # noqa: E402


def stream_once(est, X):
    state = est.start_stream()
    lat = np.empty(len(X))
    rows = []
    window = 0
    t0 = time.perf_counter()
    for i, record in enumerate(X):
        t = time.perf_counter()
        done = state.push(record)
        lat[i] = time.perf_counter() - t
        window = max(window, state.n_held)
        rows.extend(row for r in done for row in r.payload["finished_objects"])
    rows.extend(row for r in state.close() for row in r.payload["finished_objects"])
    return time.perf_counter() - t0, lat, rows, window


def main(n_scans=3000, repeats=3):
    run = make_street_scans(n_scans, scenario="dense", random_state=0)
    X = list(run.scans)
    est = ScanClusterer().fit(X)
    est.detect(X)  # warm up
    t_batch, t_stream, p50, p99, pmax = [], [], [], [], []
    for _ in range(repeats):
        t = time.perf_counter()
        table = est.detect(X, all_objects=True)
        t_batch.append(time.perf_counter() - t)
        total, lat, rows, window = stream_once(est, X)
        t_stream.append(total)
        p50.append(np.percentile(lat, 50))
        p99.append(np.percentile(lat, 99))
        pmax.append(lat.max())
    same = rows == [tuple(r) for r in table[list(OBJECT_COLUMNS)].itertuples(index=False)]
    tb, ts = float(np.median(t_batch)), float(np.median(t_stream))
    print(f"run: {n_scans} scans x {len(X[0].ranges)} beams ('dense'), one thread, "
          f"medians of {repeats} repeats; {len(rows)} objects")
    print()
    print(f"{'what':44s} {'ms/scan':>9s} {'scans/s':>9s} {'ratio':>7s}")
    print(f"{'batch detect (whole run), mean':44s} {1e3 * tb / n_scans:9.3f} "
          f"{n_scans / tb:9.0f} {1.0:6.1f}x")
    print(f"{'streaming push, mean (whole stream)':44s} {1e3 * ts / n_scans:9.3f} "
          f"{n_scans / ts:9.0f} {ts / tb:6.1f}x")
    print(f"{'streaming push latency, p50':44s} {1e3 * np.median(p50):9.3f} "
          f"{'':>9s} {np.median(p50) / (tb / n_scans):6.1f}x")
    print(f"{'streaming push latency, p99':44s} {1e3 * np.median(p99):9.3f} "
          f"{'':>9s} {np.median(p99) / (tb / n_scans):6.1f}x")
    print(f"{'streaming push latency, max':44s} {1e3 * np.median(pmax):9.3f} "
          f"{'':>9s} {np.median(pmax) / (tb / n_scans):6.1f}x")
    print(f"{'sensor period (75 scans/s)':44s} {1e3 / 75:9.3f} {75:9.0f}")
    print(f"\nlargest window held by the stream: {window} scans of {n_scans}")
    print(f"streaming object table identical to batch: {same}")


if __name__ == "__main__":
    args = [int(a) for a in sys.argv[1:]]
    main(*args)
