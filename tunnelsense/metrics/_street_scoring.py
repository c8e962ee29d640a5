"""Street scores for a whole report, and scikit-learn scorers built on them.

:func:`street_report` gathers the per-label and per-class scores of
:mod:`tunnelsense.metrics._street`; :func:`objects_from_targets` turns per-scan targets into
the object tables those scores read; :func:`make_street_scorer` wraps them for
``GridSearchCV``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from tunnelsense._records import RUN_LABELS, check_scans
from tunnelsense.metrics._street import (
    street_class_scores,
    street_confusion_matrix,
    street_scores,
)

__all__ = ["make_street_scorer", "objects_from_targets", "street_report"]

def street_report(gt, detected, *, min_iou=0.5, label="parked"):
    """Scores per label and the confusion matrix of ``label``, as text.

    When both tables have a ``vehicle_class`` column, the class confusion matrix of
    ``label`` follows, with every class's recall and accuracy
    (:func:`street_class_scores`).  A rate without a denominator (no ground truth, no detection) and the undefined
    true negatives print as ``n/a``.

    Parameters
    ----------
    gt, detected : DataFrame
        Object tables (see :func:`match_objects`).
    min_iou : float, default=0.5
        Smallest scan-interval IoU of a match.
    label : str, default="parked"
        The label of the confusion matrix.

    Returns
    -------
    report : str

    Examples
    --------
    >>> import pandas as pd
    >>> from tunnelsense.metrics import street_report
    >>> gt = pd.DataFrame({"first_scan": [0], "last_scan": [9], "label": ["parked"]})
    >>> print(street_report(gt, gt))
    parked   tp    1  fp    0  fn    0  recall 1.000  precision 1.000
    passing  tp    0  fp    0  fn    0  recall n/a    precision n/a
    <BLANKLINE>
    parked vehicles, the paper's confusion matrix (rows: truth):
    truth \\ predicted  negative  positive
    negative                n/a         0
    positive                  0         1
    """
    def rate(value):
        return "n/a  " if value is None else f"{value:.3f}"

    lines = [f"{name:8s} tp {s['tp']:4d}  fp {s['fp']:4d}  fn {s['fn']:4d}  "
             f"recall {rate(s['recall'])}  precision {rate(s['precision'])}".rstrip()
             for name, s in street_scores(gt, detected, min_iou=min_iou,
                                          zero_division=None).items()]
    matrix = street_confusion_matrix(gt, detected, label=label, min_iou=min_iou)
    lines += ["", f"{label} vehicles, the paper's confusion matrix (rows: truth):",
              "truth \\ predicted  negative  positive"]
    for name, values in matrix.iterrows():
        cells = ["n/a" if v != v else str(int(v)) for v in values]
        lines.append(f"{name:18s} {cells[0]:>8s}  {cells[1]:>8s}")
    if "vehicle_class" in gt and "vehicle_class" in detected:
        s = street_class_scores(gt, detected, label=label, min_iou=min_iou)
        lines += ["", f"{label} vehicles by class (rows: truth; accuracy: of those "
                  "found):"]
        lines.append("truth \\ detected  " + "".join(
            f"{c:>10s}" for c in s["confusion"].columns) + "    recall  accuracy")
        for name, values in s["confusion"].iterrows():
            v = s["classes"][name]
            lines.append(f"{name:18s}" + "".join(f"{int(x):10d}" for x in values)
                         + f"    {rate(v['recall'])}     {rate(v['accuracy'])}")
        lines.append(f"class accuracy {rate(s['accuracy'])}")
    return "\n".join(lines)


def objects_from_targets(X, y):
    """Object table from per-scan targets (or predictions) ``(object id, label code)``.

    Parameters
    ----------
    X : sequence of ScanRecord
        The scans (their runs and numbers).
    y : sequence of array-like of shape (k_i, 2)
        Per scan, ``(object id, label code)`` (:meth:`tunnelsense.Run.targets`, or
        ``ScanClusterer.predict``).

    Returns
    -------
    objects : DataFrame
        Columns ``run, id, first_scan, last_scan, label``; an object spans its first to
        its last scan in ``X``.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import LaserGeometry, ScanSequence
    >>> from tunnelsense.metrics import objects_from_targets
    >>> X = ScanSequence.from_arrays(np.ones((3, 2)), np.arange(3.0),
    ...                              LaserGeometry(0, 0.1, 0, 9, 1), run="r")
    >>> objects_from_targets(X, [[[7, 1]], [[7, 1]], []]).to_dict("list")
    {'run': ['r'], 'id': [7], 'first_scan': [0], 'last_scan': [1], 'label': ['parked']}
    """
    records, y = check_scans(X, y)
    if y is None:
        raise ValueError("y is required: one (k, 2) array per scan")
    names = {v: k for k, v in RUN_LABELS.items()}
    counts = np.array([len(t) for t in y], dtype=np.int64)
    cols = ["run", "id", "first_scan", "last_scan", "label"]
    if counts.sum() == 0:
        return pd.DataFrame({c: pd.Series(dtype=object if c in ("run", "label")
                                          else np.int64) for c in cols})
    t = np.concatenate(y)
    runs = np.repeat(np.array([r.run for r in records], dtype=object), counts)
    scans = np.repeat(np.array([r.scan for r in records], dtype=np.int64), counts)
    df = pd.DataFrame({"run": runs, "id": t[:, 0], "scan": scans, "code": t[:, 1]})
    unknown = ~df["code"].isin(list(names))
    if unknown.any():
        raise ValueError(
            f"y holds label code {int(df.loc[unknown, 'code'].iloc[0])}: expected one "
            f"of {sorted(names)} (RUN_LABELS)"
        )
    agg = df.groupby(["run", "id"], sort=True).agg(
        first_scan=("scan", "min"), last_scan=("scan", "max"),
        code=("code", lambda c: int(pd.Series(c).mode().iloc[0])),
    ).reset_index()
    agg["label"] = agg["code"].map(names).astype(object)
    out = agg[cols].copy()
    out["run"] = out["run"].astype(object)
    return out.sort_values(["run", "first_scan", "id"]).reset_index(drop=True)


class _StreetScorer:
    """Callable ``scorer(estimator, X, y)`` for GridSearchCV (picklable)."""

    def __init__(self, label, metric, min_iou):
        self.label = label
        self.metric = metric
        self.min_iou = min_iou

    def __call__(self, estimator, X, y):
        gt = objects_from_targets(X, y)
        det = objects_from_targets(X, estimator.predict(X))
        s = street_scores(gt, det, min_iou=self.min_iou, labels=(self.label,))[self.label]
        if self.metric == "f1":
            p, r = s["precision"], s["recall"]
            return 2 * p * r / (p + r) if p + r > 0 else 0.0
        return float(s[self.metric])

    def __repr__(self):
        return (f"make_street_scorer(label={self.label!r}, metric={self.metric!r}, "
                f"min_iou={self.min_iou})")


def make_street_scorer(label="parked", metric="f1", *, min_iou=0.5):
    """A scorer ``scorer(estimator, X, y)`` for :class:`~sklearn.model_selection.GridSearchCV`.

    It predicts per-scan ``(object id, label code)`` with the estimator, rebuilds the
    object tables of prediction and truth (:func:`objects_from_targets`) and scores
    them (:func:`street_scores`).

    Parameters
    ----------
    label : str, default="parked"
    metric : {"f1", "recall", "precision"}, default="f1"
    min_iou : float, default=0.5

    Returns
    -------
    scorer : callable

    Examples
    --------
    >>> from tunnelsense.metrics import make_street_scorer
    >>> make_street_scorer("parked", "recall")
    make_street_scorer(label='parked', metric='recall', min_iou=0.5)
    """
    if label not in RUN_LABELS:
        raise ValueError(f"label must be one of {list(RUN_LABELS)}; got {label!r}")
    if metric not in ("f1", "recall", "precision"):
        raise ValueError(
            f"metric must be 'f1', 'recall' or 'precision'; got {metric!r}"
        )
    return _StreetScorer(label, metric, float(min_iou))
