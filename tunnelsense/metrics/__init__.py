"""Scores of the detectors against their ground truth."""

from tunnelsense.metrics._street import (
    interval_iou,
    make_street_scorer,
    match_objects,
    objects_from_targets,
    street_class_scores,
    street_confusion_matrix,
    street_report,
    street_scores,
)
from tunnelsense.metrics._tunnel import (
    HYPOTHESIS_COLUMNS,
    gt_from_boxes,
    hypotheses_from_records,
    indicator_scores,
    tunnel_scores,
)
from tunnelsense.metrics._tunnel_scoring import (
    TUNNEL_SCORER_METRICS,
    make_tunnel_scorer,
    results_scores,
    tunnel_report,
)

__all__ = [
    "HYPOTHESIS_COLUMNS",
    "TUNNEL_SCORER_METRICS",
    "gt_from_boxes",
    "hypotheses_from_records",
    "indicator_scores",
    "make_tunnel_scorer",
    "results_scores",
    "tunnel_report",
    "tunnel_scores",
    "interval_iou",
    "make_street_scorer",
    "match_objects",
    "objects_from_targets",
    "street_class_scores",
    "street_confusion_matrix",
    "street_report",
    "street_scores",
]
