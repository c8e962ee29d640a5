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

from tunnelsense._records._bundles import Run, Tour, empty_mot_gt, empty_run_gt, to_xy
from tunnelsense._records._checks import check_frames, check_scans
from tunnelsense._records._frames import (
    MOT_GT_COLUMNS,
    OBJECT_CLASSES,
    DecodedImage,
    FrameRecord,
    ImageFile,
    VideoFrame,
    decode_once,
    release_image,
)
from tunnelsense._records._scans import (
    GEOMETRY_FIELDS,
    GEOMETRY_RULES,
    RUN_GT_COLUMNS,
    RUN_LABELS,
    LaserGeometry,
    ScanRecord,
    geometry_problem,
)
from tunnelsense._records._sequences import FrameSequence, ScanSequence

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
