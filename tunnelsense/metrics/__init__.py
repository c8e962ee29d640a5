"""Scores of the detectors against their ground truth."""

from tunnelsense.metrics._street import (
    interval_iou,
    make_street_scorer,
    match_objects,
    objects_from_targets,
    street_confusion_matrix,
    street_scores,
)

__all__ = [
    "interval_iou",
    "make_street_scorer",
    "match_objects",
    "objects_from_targets",
    "street_confusion_matrix",
    "street_scores",
]
