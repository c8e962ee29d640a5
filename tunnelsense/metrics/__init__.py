"""Scores of the detectors against their ground truth."""

from tunnelsense._lazy import attach

_NAMES = {
    "interval_iou": "_street",
    "make_street_scorer": "_street_scoring",
    "match_objects": "_street",
    "objects_from_targets": "_street_scoring",
    "street_class_scores": "_street",
    "street_confusion_matrix": "_street",
    "street_report": "_street_scoring",
    "street_scores": "_street",
    "HYPOTHESIS_COLUMNS": "_tunnel",
    "gt_from_boxes": "_tunnel",
    "hypotheses_from_records": "_tunnel",
    "indicator_scores": "_tunnel",
    "tunnel_scores": "_tunnel",
    "TUNNEL_SCORER_METRICS": "_tunnel_scoring",
    "make_tunnel_scorer": "_tunnel_scoring",
    "results_scores": "_tunnel_scoring",
    "tunnel_report": "_tunnel_scoring",
}

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

__getattr__, __dir__, _ = attach(__name__, _NAMES, __all__)
