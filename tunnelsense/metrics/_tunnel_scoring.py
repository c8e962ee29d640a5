"""The indicator detector's scores put to use: a results file scored, a text report,
and a scorer for scikit-learn's model selection."""

from __future__ import annotations

from pathlib import Path

from tunnelsense.io._results import read_hypotheses
from tunnelsense.metrics._tunnel import indicator_scores, tunnel_scores

__all__ = [
    "TUNNEL_SCORER_METRICS",
    "make_tunnel_scorer",
    "results_scores",
    "tunnel_report",
]


def results_scores(results, tour, *, min_height=14.0) -> dict:
    """Score a results file of ``detect tunnel`` against a tour's ground truth.

    The file's ``.clusters.csv`` companion, when present, gives every cluster (see
    :func:`tunnelsense.io.read_hypotheses`); without it the false-alarm rate is
    unknown (``None``) and ``complete`` is False.

    Parameters
    ----------
    results : str or Path
        The results file.
    tour : Tour
        The labelled tour it was detected on.
    min_height : float, default=14.0

    Returns
    -------
    scores : dict
        As :func:`tunnel_scores`, with ``complete``.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from tunnelsense.datasets import make_tunnel_tour
    >>> from tunnelsense.metrics import results_scores
    >>> tour = make_tunnel_tour(30, random_state=0, first_indicator_m=20.0)
    >>> results = pathlib.Path(tempfile.mkdtemp()) / "none.txt"
    >>> _ = results.write_text("")  # no detection at all
    >>> scores = results_scores(results, tour)
    >>> scores["complete"], scores["cluster"]["false_alarm_rate"]
    (False, None)
    """
    if not Path(results).is_file():
        raise FileNotFoundError(f"{results}: results file not found")
    hypotheses, complete = read_hypotheses(results, tour.name)
    scores = tunnel_scores(hypotheses, tour.gt.assign(tour=tour.name),
                           min_height=min_height, complete=complete)
    return {**scores, "complete": complete}


def _percent(rate) -> str:
    return "n/a (0 of 0)" if rate is None else f"{100 * rate:.1f} %"


def tunnel_report(scores, title) -> str:
    """The paper's cluster (Table 1) and trajectory figures as text.

    A rate of 0 of 0 reads ``n/a (0 of 0)``; without the ``.clusters.csv`` companion
    (``scores["complete"]`` False) the false-alarm rate reads ``n/a`` too.

    Parameters
    ----------
    scores : dict
        From :func:`tunnel_scores`, :func:`indicator_scores` or
        :func:`results_scores`.
    title : str
        The first line.

    Returns
    -------
    report : str

    Examples
    --------
    >>> from tunnelsense.metrics import tunnel_report
    >>> scores = {"cluster": {"total": 0, "correct": 0, "misses": 0,
    ...                       "false_alarms": 0, "detection_rate": None,
    ...                       "false_alarm_rate": None},
    ...           "trajectory": {"indicators": 0, "detected": 0, "false_alarms": 0,
    ...                          "detection_rate": None}}
    >>> print(tunnel_report(scores, "empty").splitlines()[6])
      detection rate      n/a (0 of 0)
    """
    c, t = scores["cluster"], scores["trajectory"]
    far = (_percent(c["false_alarm_rate"]) if scores.get("complete", True)
           else "n/a (no .clusters.csv companion: the negatives are unknown)")
    return "\n".join([
        title, "keypoint clusters (Table 1)",
        f"  total number        {c['total']}",
        f"  correctly labelled  {c['correct']}",
        f"  miss detections     {c['misses']}",
        f"  false alarms        {c['false_alarms']}",
        f"  detection rate      {_percent(c['detection_rate'])}",
        f"  false alarm rate    {far}",
        "trajectories",
        f"  indicators          {t['indicators']}",
        f"  detected            {t['detected']}",
        f"  false alarms        {t['false_alarms']}",
        f"  detection rate      {_percent(t['detection_rate'])}",
    ])


#: Metrics :func:`make_tunnel_scorer` knows (greater is better for every one).
TUNNEL_SCORER_METRICS = (
    "youden",
    "cluster_detection_rate",
    "cluster_false_alarm_rate",
    "trajectory_detection_rate",
    "trajectory_false_alarms",
)


class _TunnelScorer:
    """A picklable ``scorer(estimator, X, y)`` for GridSearchCV."""

    def __init__(self, metric, min_height):
        self.metric = metric
        self.min_height = min_height

    def __repr__(self):
        return f"make_tunnel_scorer({self.metric!r}, min_height={self.min_height})"

    def __call__(self, estimator, X, y):
        s = indicator_scores(estimator.predict(X), y, min_height=self.min_height)
        c, t = s["cluster"], s["trajectory"]
        # a fold with nothing to detect (or no negative) cannot lower the score
        detection = 1.0 if c["detection_rate"] is None else c["detection_rate"]
        false_alarm = 0.0 if c["false_alarm_rate"] is None else c["false_alarm_rate"]
        if self.metric == "youden":
            return detection - false_alarm
        if self.metric == "cluster_detection_rate":
            return detection
        if self.metric == "cluster_false_alarm_rate":
            return -false_alarm
        if self.metric == "trajectory_detection_rate":
            return 1.0 if t["detection_rate"] is None else t["detection_rate"]
        return -float(t["false_alarms"])


def make_tunnel_scorer(metric="youden", *, min_height=14.0):
    """A scorer for :class:`~sklearn.model_selection.GridSearchCV` over the detector.

    Parameters
    ----------
    metric : str, default="youden"
        ``"youden"``: cluster detection rate minus cluster false-alarm rate;
        ``"cluster_detection_rate"``; ``"cluster_false_alarm_rate"`` (negated);
        ``"trajectory_detection_rate"``; ``"trajectory_false_alarms"`` (negated
        count).  Greater is better for all.
    min_height : float, default=14.0
        Indicator boxes at least this tall count.

    Returns
    -------
    scorer : callable ``scorer(estimator, X, y) -> float``

    Examples
    --------
    >>> from tunnelsense.metrics import make_tunnel_scorer
    >>> make_tunnel_scorer("cluster_detection_rate")
    make_tunnel_scorer('cluster_detection_rate', min_height=14.0)
    """
    if metric not in TUNNEL_SCORER_METRICS:
        raise ValueError(f"metric must be one of {list(TUNNEL_SCORER_METRICS)}; got {metric!r}")
    return _TunnelScorer(metric, float(min_height))
