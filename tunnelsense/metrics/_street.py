"""Object-level scores of the street-parked vehicle detector.

A detected object and a ground-truth object are intervals of scans of one run.  They
are matched one to one (Hungarian assignment) when their scan-interval IoU is at least
``min_iou`` (0.5); among such pairs, equal labels are preferred.  Per label:

* true positive: a ground-truth object of the label matched to a detection of the label;
* false negative (miss): a ground-truth object of the label not so matched;
* false positive: a detection of the label not so matched.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

from tunnelsense._records import RUN_LABELS

__all__ = [
    "interval_iou",
    "match_objects",
    "street_class_scores",
    "street_confusion_matrix",
    "street_scores",
]

_LABELS = tuple(RUN_LABELS)


def interval_iou(a, b):
    """IoU of inclusive scan intervals, every ``a`` against every ``b``.

    Parameters
    ----------
    a, b : array-like of shape (n, 2) and (m, 2)
        ``(first_scan, last_scan)``, inclusive.

    Returns
    -------
    iou : ndarray of shape (n, m)

    Examples
    --------
    >>> from tunnelsense.metrics import interval_iou
    >>> interval_iou([[0, 9]], [[5, 14], [0, 9], [20, 30]]).round(3).tolist()
    [[0.333, 1.0, 0.0]]
    """
    a = np.asarray(a, dtype=np.float64).reshape(-1, 2)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 2)
    inter = np.minimum(a[:, None, 1], b[None, :, 1]) - np.maximum(
        a[:, None, 0], b[None, :, 0]
    ) + 1
    inter = np.maximum(inter, 0)
    la = a[:, 1] - a[:, 0] + 1
    lb = b[:, 1] - b[:, 0] + 1
    union = la[:, None] + lb[None, :] - inter
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(union > 0, inter / union, 0.0)


def _as_table(objects, name):
    if not isinstance(objects, pd.DataFrame):
        raise TypeError(f"{name} must be a DataFrame; got {type(objects).__name__}")
    missing = [c for c in ("first_scan", "last_scan", "label") if c not in objects]
    if missing:
        raise ValueError(
            f"{name} lacks column(s) {', '.join(missing)}: expected "
            "id,first_scan,last_scan,label (and optionally run)"
        )
    t = objects.reset_index(drop=True)
    run = t["run"].astype(str) if "run" in t else pd.Series([""] * len(t), dtype=object)
    first = pd.to_numeric(t["first_scan"], errors="coerce")
    last = pd.to_numeric(t["last_scan"], errors="coerce")
    if first.isna().any() or last.isna().any() or (last < first).any():
        raise ValueError(
            f"{name}: first_scan and last_scan must be integers with "
            "first_scan <= last_scan"
        )
    return pd.DataFrame({
        "run": run.to_numpy(dtype=object),
        "first_scan": first.to_numpy(dtype=np.int64),
        "last_scan": last.to_numpy(dtype=np.int64),
        "label": t["label"].astype(str).to_numpy(dtype=object),
    })


def match_objects(gt, detected, *, min_iou=0.5):
    """Match detected objects one to one to ground-truth objects.

    Parameters
    ----------
    gt, detected : DataFrame
        Columns ``first_scan, last_scan, label`` and optionally ``run`` (when both
        tables have it, objects match only within a run; otherwise all are one run).
    min_iou : float, default=0.5
        Smallest scan-interval IoU of a match.

    Returns
    -------
    matches : DataFrame
        Columns ``gt`` and ``detected`` (row positions in the two tables) and ``iou``.

    Examples
    --------
    >>> import pandas as pd
    >>> from tunnelsense.metrics import match_objects
    >>> gt = pd.DataFrame({"first_scan": [0, 20], "last_scan": [9, 29],
    ...                    "label": ["parked", "parked"]})
    >>> det = pd.DataFrame({"first_scan": [1, 40], "last_scan": [10, 45],
    ...                     "label": ["parked", "parked"]})
    >>> match_objects(gt, det).to_dict("list")
    {'gt': [0], 'detected': [0], 'iou': [0.8181818181818182]}
    """
    g = _as_table(gt, "gt")
    d = _as_table(detected, "detected")
    if "run" not in gt or "run" not in detected:
        g["run"] = ""
        d["run"] = ""
    gi, di, ious = [], [], []
    for run, gg in g.groupby("run", sort=False):
        dd = d[d["run"] == run]
        if not len(dd):
            continue
        iou = interval_iou(gg[["first_scan", "last_scan"]], dd[["first_scan", "last_scan"]])
        ok = iou >= min_iou
        if not ok.any():
            continue
        same = gg["label"].to_numpy()[:, None] == dd["label"].to_numpy()[None, :]
        weight = np.where(ok, iou + same, 0.0)
        r, c = linear_sum_assignment(weight, maximize=True)
        keep = ok[r, c]
        gi.append(gg.index.to_numpy()[r[keep]])
        di.append(dd.index.to_numpy()[c[keep]])
        ious.append(iou[r[keep], c[keep]])
    def cat(parts, dt):
        return np.concatenate(parts).astype(dt) if parts else np.empty(0, dt)

    return pd.DataFrame({
        "gt": cat(gi, np.int64), "detected": cat(di, np.int64),
        "iou": cat(ious, np.float64),
    })


def street_scores(gt, detected, *, min_iou=0.5, labels=_LABELS, zero_division=0.0):
    """Per label true positives, false positives, misses, recall and precision.

    Parameters
    ----------
    gt, detected : DataFrame
        Object tables (see :func:`match_objects`); detections of other labels
        (``"roadside"``, ``"other"``) are ignored.
    min_iou : float, default=0.5
        Smallest scan-interval IoU of a match.
    labels : sequence of str, default=("parked", "passing")
    zero_division : float or None, default=0.0
        Recall (precision) when there is no ground truth (no detection) of a label;
        None: undefined (``n/a`` in :func:`street_report`).

    Returns
    -------
    scores : dict
        ``{label: {"tp", "fp", "fn", "recall", "precision"}}``.

    Examples
    --------
    >>> import pandas as pd
    >>> from tunnelsense.metrics import street_scores
    >>> gt = pd.DataFrame({"first_scan": [0, 20], "last_scan": [9, 29],
    ...                    "label": ["parked", "parked"]})
    >>> det = pd.DataFrame({"first_scan": [1], "last_scan": [10], "label": ["parked"]})
    >>> street_scores(gt, det)["parked"]
    {'tp': 1, 'fp': 0, 'fn': 1, 'recall': 0.5, 'precision': 1.0}
    """
    g = _as_table(gt, "gt")
    d = _as_table(detected, "detected")
    if "run" not in gt or "run" not in detected:
        g["run"] = ""
        d["run"] = ""
    undefined = None if zero_division is None else float(zero_division)
    m = match_objects(g, d, min_iou=min_iou)
    gl = g["label"].to_numpy()[m["gt"].to_numpy()]
    dl = d["label"].to_numpy()[m["detected"].to_numpy()]
    out = {}
    for label in labels:
        tp = int(np.sum((gl == label) & (dl == label)))
        n_gt = int(np.sum(g["label"] == label))
        n_det = int(np.sum(d["label"] == label))
        out[label] = {
            "tp": tp,
            "fp": n_det - tp,
            "fn": n_gt - tp,
            "recall": tp / n_gt if n_gt else undefined,
            "precision": tp / n_det if n_det else undefined,
        }
    return out


def _classes_of(table, name):
    """The ``vehicle_class`` column of an object table as stripped strings."""
    values = table["vehicle_class"].reset_index(drop=True)
    return values.fillna("").astype(str).str.strip().to_numpy(dtype=object)


def street_class_scores(gt, detected, *, label="parked", min_iou=0.5, classes=None):
    """Per vehicle class: recall, class accuracy and the class confusion matrix.

    The objects of ``label`` are matched as in :func:`street_scores`; then, per class
    of the ground truth (its ``vehicle_class`` column):

    * ``recall``: the fraction of its objects matched to a detection of ``label``
      (whatever the detection's class);
    * ``accuracy``: the fraction of those matched whose detection has the same class.

    Parameters
    ----------
    gt, detected : DataFrame
        Object tables (see :func:`match_objects`), both with a ``vehicle_class``
        column (empty: no class).
    label : str, default="parked"
    min_iou : float, default=0.5
    classes : sequence of str, default=None
        The classes, in order; None: :data:`tunnelsense.street.VEHICLE_CLASSES`.

    Returns
    -------
    scores : dict
        ``{"classes": {class: {"n", "matched", "correct", "recall", "accuracy"}},
        "accuracy": float or None, "confusion": DataFrame}``: the overall class
        accuracy of the matched objects, and the counts of truth (rows, ``classes``)
        against detected class (columns: ``classes``, ``"none"`` for a detection
        without a class, ``"missed"`` for no detection); rates of no object are None.

    Raises
    ------
    ValueError
        A table lacks the ``vehicle_class`` column (an object table written before
        the detector gave classes).

    Examples
    --------
    >>> import pandas as pd
    >>> from tunnelsense.metrics import street_class_scores
    >>> gt = pd.DataFrame({"first_scan": [0, 20, 40], "last_scan": [9, 29, 49],
    ...                    "label": ["parked"] * 3,
    ...                    "vehicle_class": ["car", "motorbike", "van"]})
    >>> det = pd.DataFrame({"first_scan": [0, 21], "last_scan": [9, 29],
    ...                     "label": ["parked"] * 2, "vehicle_class": ["car", "car"]})
    >>> s = street_class_scores(gt, det)
    >>> s["classes"]["motorbike"]
    {'n': 1, 'matched': 1, 'correct': 0, 'recall': 1.0, 'accuracy': 0.0}
    >>> s["confusion"].loc["van"].tolist()  # car, van, motorbike, none, missed
    [0, 0, 0, 0, 1]
    """
    if classes is None:
        from tunnelsense.street._census import VEHICLE_CLASSES as classes
    classes = tuple(classes)
    for table, name in ((gt, "gt"), (detected, "detected")):
        if isinstance(table, pd.DataFrame) and "vehicle_class" not in table:
            raise ValueError(
                f"{name} has no vehicle_class column: per-class scores need the "
                "classes of both tables (an object table written before the "
                "detector gave classes has none)")
    g = _as_table(gt, "gt")
    d = _as_table(detected, "detected")
    if "run" not in gt or "run" not in detected:
        g["run"] = ""
        d["run"] = ""
    gc, dc = _classes_of(gt, "gt"), _classes_of(detected, "detected")
    m = match_objects(g, d, min_iou=min_iou)
    gi, di = m["gt"].to_numpy(), m["detected"].to_numpy()
    ok = (g["label"].to_numpy()[gi] == label) & (d["label"].to_numpy()[di] == label)
    found = np.full(len(g), None, dtype=object)
    found[gi[ok]] = [c if c in classes else "none" for c in dc[di[ok]]]
    columns = [*classes, "none", "missed"]
    confusion = pd.DataFrame(0, index=pd.Index(list(classes), name="truth"),
                             columns=pd.Index(columns, name="detected"), dtype=np.int64)
    out = {}
    mine = g["label"].to_numpy() == label
    for c in classes:
        rows = mine & (gc == c)
        hits = found[rows]
        matched = int(sum(h is not None for h in hits))
        correct = int(sum(h == c for h in hits))
        for column in columns[:-1]:
            confusion.loc[c, column] = int(sum(h == column for h in hits))
        confusion.loc[c, "missed"] = int(rows.sum()) - matched
        out[c] = {"n": int(rows.sum()), "matched": matched, "correct": correct,
                  "recall": matched / int(rows.sum()) if rows.sum() else None,
                  "accuracy": correct / matched if matched else None}
    matched = sum(v["matched"] for v in out.values())
    correct = sum(v["correct"] for v in out.values())
    return {"classes": out, "accuracy": correct / matched if matched else None,
            "confusion": confusion}


def street_confusion_matrix(gt, detected, *, label="parked", min_iou=0.5):
    """The paper's confusion matrix (TABLE 1) of one label.

    Rows are the truth, columns the prediction, both ``negative, positive``; the true
    negatives are not defined for object detection (NaN; ``n/a`` in
    :func:`street_report`).

    Returns
    -------
    matrix : DataFrame
        ``[[NaN, fp], [fn, tp]]``.

    Examples
    --------
    >>> import pandas as pd
    >>> from tunnelsense.metrics import street_confusion_matrix
    >>> gt = pd.DataFrame({"first_scan": [0, 20], "last_scan": [9, 29],
    ...                    "label": ["parked", "parked"]})
    >>> det = pd.DataFrame({"first_scan": [1], "last_scan": [10], "label": ["parked"]})
    >>> m = street_confusion_matrix(gt, det)
    >>> m.index.tolist(), m.columns.tolist()
    (['negative', 'positive'], ['negative', 'positive'])
    >>> m.to_numpy().tolist()
    [[nan, 0.0], [1.0, 1.0]]
    """
    s = street_scores(gt, detected, min_iou=min_iou, labels=(label,))[label]
    m = pd.DataFrame(
        [[np.nan, s["fp"]], [s["fn"], s["tp"]]],
        index=pd.Index(["negative", "positive"], name="actual"),
        columns=pd.Index(["negative", "positive"], name="predicted"),
        dtype=np.float64,
    )
    return m
