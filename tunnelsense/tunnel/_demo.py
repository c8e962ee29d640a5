"""The demonstration of ``tunnelsense demo``: simulate, train, detect, report."""

from __future__ import annotations

import time

from tunnelsense._records import to_xy
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.metrics import indicator_scores, tunnel_report
from tunnelsense.tunnel._detect import detect_tour
from tunnelsense.tunnel._pipeline import make_indicator_pipeline

__all__ = ["run_demo"]

#: The scenarios of the demonstration's tours: the first trains, the others test.
DEMO_SCENARIOS = ("light", "light", "heavy", "curved")


def run_demo(n_frames=900, *, random_state=0, min_height=14.0, progress=None):
    """Simulate four tours, train on the first, detect on the others; yield the report.

    Parameters
    ----------
    n_frames : int, default=900
        Frames per simulated tour.
    random_state : int, default=0
        Seed of the training tour; the test tours take the next three.
    min_height : float, default=14.0
        Indicator boxes at least this tall (px) count.
    progress : callable, default=None
        ``progress(total, desc)`` returns a progress bar (or None) for each stage.

    Yields
    ------
    text : str
        A line of the report, the cluster and trajectory figures of a test tour,
        and last the totals and the time taken.

    Examples
    --------
    A tour too short to hold an indicator is refused before training:

    >>> next(run_demo(10))
    Traceback (most recent call last):
    ...
    ValueError: --frames 10 is too short: the simulated training tour holds no indicator at least 14 px tall to learn from (use --frames 300 or more)
    """
    start, bar = time.perf_counter(), progress or (lambda total, desc: None)
    train, *tests = [
        make_tunnel_tour(n_frames, scenario=scenario, random_state=random_state + k,
                         progress=bar(n_frames, f"simulating a {scenario} tour"))
        for k, scenario in enumerate(DEMO_SCENARIOS)
    ]
    X, y, _ = to_xy([train])
    if not any(len(b) for b in train.boxes(min_height=min_height)):
        raise ValueError(f"--frames {n_frames} is too short: the simulated training tour "
                         f"holds no indicator at least {min_height:g} px tall to learn "
                         "from (use --frames 300 or more)")
    yield "training the indicator detector"
    model = make_indicator_pipeline(random_state=random_state).fit(X, y)
    found = total = false_alarms = 0
    for tour in tests:
        X, y, _ = to_xy([tour])
        records = detect_tour(model, X, progress=bar(n_frames, f"detecting {tour.name}"))
        scores = indicator_scores(records, y, min_height=min_height)
        t = scores["trajectory"]
        found, total = found + t["detected"], total + t["indicators"]
        false_alarms += t["false_alarms"]
        yield "\n" + tunnel_report(scores, f"{tour.name} ({tour.info.get('scenario')})")
    yield (f"\n{found} of {total} indicators found, {false_alarms} false-alarm "
           f"trajectories ({time.perf_counter() - start:.0f} s)")
