"""Opening a detector's model file: the strict reader beside skops' general loader.

A vehicle opens its model once per start, in a fresh process, so what counts is a
fresh interpreter's wall time.  Each repeat starts two fresh processes in turn, one
opening the tunnel model with ``load_trusted_model`` (the commands' strict reader:
no skops import, no discovery of every scikit-learn estimator) and one with
``load_model`` (skops' audited loader), both after ``import tunnelsense.io``; it
reports each median and their ratio.  The models are the same file.

    python benchmarks/bench_model_load.py [--repeats 7]
"""

import argparse
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

_TIMED = """
import time, warnings, sys
warnings.simplefilter("ignore")
import tunnelsense.io
from tunnelsense.io._trust import load_trusted_model
from tunnelsense.io import load_model
t0 = time.perf_counter()
if sys.argv[1] == "strict":
    load_trusted_model(sys.argv[2], last_step="motion", command="x")
else:
    load_model(sys.argv[2])
print(time.perf_counter() - t0)
"""


def _model(folder: Path) -> Path:
    from tunnelsense import make_indicator_pipeline, to_xy
    from tunnelsense.datasets import make_tunnel_tour
    from tunnelsense.io import save_model

    tour = make_tunnel_tour(240, scenario="light", random_state=3, name="tour")
    X, y, _ = to_xy([tour])
    return save_model(make_indicator_pipeline(random_state=0).fit(X, y),
                      folder / "tunnel.skops")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = _model(Path(tmp))
        times = {"strict": [], "skops": []}
        for _ in range(args.repeats):
            for how in times:
                out = subprocess.run([sys.executable, "-c", _TIMED, how, str(path)],
                                     capture_output=True, text=True, check=True)
                times[how].append(float(out.stdout.split()[-1]))
    strict, general = (statistics.median(times[k]) for k in ("strict", "skops"))
    print(f"open the tunnel model in a fresh process (median of {args.repeats}):")
    print(f"  strict reader (load_trusted_model): {strict * 1000:7.1f} ms")
    print(f"  skops loader  (load_model):         {general * 1000:7.1f} ms")
    print(f"  ratio skops / strict:               {general / strict:7.1f} x")


if __name__ == "__main__":
    main()
