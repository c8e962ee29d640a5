"""The data contract: sample records, their containers, and their validation.

A *sample* is one frame of far-infrared video or one scan of a laser range finder.
Every stage of a tunnelsense pipeline maps a sequence of N records to a sequence of N
records with the same identities and a new payload, which is what keeps ``Pipeline``,
``clone``, ``GridSearchCV``, ``GroupKFold`` and joblib working unchanged.

This package owns:

* the record types :class:`FrameRecord` (``_frames``) and :class:`ScanRecord`
  (``_scans``);
* the containers :class:`FrameSequence` and :class:`ScanSequence` (``_sequences``: one
  or several tours or runs; ``len``, integer, slice and index-array indexing,
  concatenation);
* the bundles :class:`Tour` and :class:`Run` (``_bundles``: records + ground truth +
  metadata) and :func:`to_xy`;
* :func:`check_frames` and :func:`check_scans` (``_checks``).

Frame numbers are 1-based, as in MOTChallenge's ``gt.txt``; scan numbers are 0-based, as
in ``gt.csv``.
"""

from tunnelsense._lazy import attach

_NAMES = {
    "Run": "_bundles",
    "Tour": "_bundles",
    "empty_mot_gt": "_bundles",
    "empty_run_gt": "_bundles",
    "to_xy": "_bundles",
    "check_frames": "_checks",
    "check_scans": "_checks",
    "MOT_GT_COLUMNS": "_frames",
    "OBJECT_CLASSES": "_frames",
    "DecodedImage": "_frames",
    "FrameRecord": "_frames",
    "ImageFile": "_frames",
    "VideoFrame": "_frames",
    "decode_once": "_frames",
    "release_image": "_frames",
    "GEOMETRY_FIELDS": "_scans",
    "GEOMETRY_RULES": "_scans",
    "RUN_GT_COLUMNS": "_scans",
    "RUN_LABELS": "_scans",
    "LaserGeometry": "_scans",
    "ScanRecord": "_scans",
    "geometry_problem": "_scans",
    "FrameSequence": "_sequences",
    "ScanSequence": "_sequences",
}

__all__ = [
    "GEOMETRY_FIELDS",
    "GEOMETRY_RULES",
    "MOT_GT_COLUMNS",
    "OBJECT_CLASSES",
    "RUN_GT_COLUMNS",
    "RUN_LABELS",
    "DecodedImage",
    "FrameRecord",
    "FrameSequence",
    "ImageFile",
    "LaserGeometry",
    "Run",
    "ScanRecord",
    "ScanSequence",
    "Tour",
    "VideoFrame",
    "check_frames",
    "check_scans",
    "decode_once",
    "empty_mot_gt",
    "empty_run_gt",
    "geometry_problem",
    "release_image",
    "to_xy",
]

__getattr__, __dir__, _ = attach(__name__, _NAMES, __all__)
