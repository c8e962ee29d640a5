"""The text reports of the tunnel commands, and the demonstration of ``tunnelsense demo``.

:func:`format_tours` and :func:`format_training` say what ``train tunnel`` learnt
from, and what; :func:`format_detection` what ``detect tunnel`` wrote;
:func:`run_demo` simulates, trains, detects and reports.
"""

from __future__ import annotations

import time

from tunnelsense._records import to_xy
from tunnelsense.io import clusters_path
from tunnelsense.metrics import indicator_scores, tunnel_report
from tunnelsense.tunnel._detect import detect_tour
from tunnelsense.tunnel._pipeline import make_indicator_pipeline

__all__ = ["format_detection", "format_tours", "format_training", "run_demo"]

#: The scenarios of the demonstration's tours: the first trains, the others test.
DEMO_SCENARIOS = ("light", "light", "heavy", "curved")


def format_tours(tours) -> str:
    """What a detector is trained on: tours, frames and indicators.

    Examples
    --------
    >>> from tunnelsense.datasets import make_tunnel_tour
    >>> format_tours([make_tunnel_tour(5, random_state=0)])  # doctest: +ELLIPSIS
    'training on 1 tour(s), 5 frames, ... indicators'
    """
    n_ind = sum(t.gt.loc[t.gt["class"] == 1, "id"].nunique() for t in tours)
    return (f"training on {len(tours)} tour(s), {sum(map(len, tours))} frames, {n_ind} "
            "indicators")


def format_training(model, summary) -> str:
    """The fitted detector in a few words: a search's best parameters, the keypoint band.

    Parameters
    ----------
    model : Pipeline
        Fitted by :func:`~tunnelsense.tunnel.fit_indicator_detector`.
    summary : dict
        Its training summary.

    Examples
    --------
    >>> from tunnelsense._records import to_xy
    >>> from tunnelsense.datasets import make_tunnel_tour
    >>> X, y, _ = to_xy([make_tunnel_tour(30, random_state=0)])
    >>> model = make_indicator_pipeline().fit(X, y)
    >>> format_training(model, {}).startswith("keypoint band: [")
    True
    """
    lines = []
    if "search" in summary:
        s = summary["search"]
        lines.append(f"best parameters: {s['best_parameters']} "
                     f"(score {s['best_score']:.4f})")
    kp = model.named_steps["keypoints"]
    lines.append(f"keypoint band: [{kp.low_:.1f}, {kp.high_:.1f}] ({kp.band})")
    if summary.get("sample_rate") is not None:
        lines.append(f"fitted on {summary['frames_fitted']} frames "
                     f"({summary['sample_rate']:g} a second of each tour)")
    return "\n".join(lines)


def format_detection(facts, out, *, draw=None) -> str:
    """What :func:`~tunnelsense.tunnel.detect_to_files` wrote, from the facts it returns.

    Examples
    --------
    >>> facts = {"drawn": [], "detections": 12, "frames": 30, "trajectories": 1}
    >>> print(format_detection(facts, "out.txt"))
    wrote out.txt: 12 detections on 30 frames, 1 indicator trajectories, and every keypoint cluster to out.clusters.csv (for 'evaluate tunnel')
    """
    lines = []
    if facts["drawn"]:
        lines.append(f"drew {len(facts['drawn'])} pictures "
                     f"({sum(facts['drawn']) / 1e6:.1f} MB) in {draw}")
    lines.append(f"wrote {out}: {facts['detections']} detections on {facts['frames']} "
                 f"frames, {facts['trajectories']} indicator trajectories, and every "
                 f"keypoint cluster to {clusters_path(out)} (for 'evaluate tunnel')")
    return "\n".join(lines)


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
    from tunnelsense.datasets import make_tunnel_tour  # the simulator: only here

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
