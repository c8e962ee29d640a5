"""Online positioning stream: time per frame and memory, flat in the tour's length.

Run: ``python benchmarks/bench_positioning_stream.py [frames ...] [--repeats N]
[--speed]``.  The default sizes are 3,000, 30,000 and 300,000 frames; 3000000 can be
added (the simulator's tours end at 1,000 km, so that tour is driven at 34 km/h;
its tables, not the stream, take a few hundred MB, and it runs for many minutes).
For each size a simulated tour (80 km/h, a sign every 200 m, the detector's output
simulated) is pushed frame by frame through a fresh
``TunnelPositioner().start_stream()``, its final rows drained every 1,024 frames as
``position --model`` does: the time a frame (median of ``--repeats`` runs, without
``tracemalloc``), then the memory the stream holds at the end and at its peak
(``tracemalloc``, one more run).  ``--speed`` instead times ``position --model``
beside ``detect tunnel`` on one rendered tour, alternating in one run, and prints
their ratio (``--frames``, default 3,000).

The measuring code is the Positioning page's figure script's
(``docs/figures/positioning_accuracy.py``), one definition for both.
"""

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

import argparse  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "docs" / "figures"))
from _common import machine  # noqa: E402
from positioning_accuracy import memory, speed  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sizes", nargs="*", type=int,
                        default=[3_000, 30_000, 300_000])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--kmh", type=float, default=None, help="the tours' speed "
                        "(default 80 km/h, slower where a tour would pass 1,000 km)")
    parser.add_argument("--speed", action="store_true")
    parser.add_argument("--frames", type=int, default=3000)
    args = parser.parse_args()
    print(machine())
    if args.speed:
        speed(args.frames, args.repeats)
    else:
        memory(tuple(args.sizes), args.repeats, args.kmh)


if __name__ == "__main__":
    main()
