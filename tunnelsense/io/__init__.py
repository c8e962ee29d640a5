"""Reading and writing tours and laser runs in the formats other tools use.

* Far-infrared tours: MOTChallenge sequence folders (``seqinfo.ini``, ``img1/``,
  ``gt/gt.txt``), plain image folders and video files through OpenCV (8- and 16-bit);
  detections as MOTChallenge results files with their ``.clusters.csv`` companion,
  written line by line (:class:`ResultsWriter`).
* Laser runs: ``scans.npz`` with ROS ``sensor_msgs/LaserScan`` field names, and
  ``gt.csv`` (``id,first_scan,last_scan,label``); ROS bags of ``LaserScan`` (the
  ``rosbag`` extra), read by the same functions and written by :func:`write_run_bag`.
* Fitted models: a safe ``.skops`` format (no code runs on load; versions, training
  summary and a checksum inside) or plain ``.joblib`` pickles.
"""

from tunnelsense.io._bag_writer import write_run_bag
from tunnelsense.io._describe import describe, format_description, open_source
from tunnelsense.io._images import iter_video, read_image
from tunnelsense.io._keys import (
    generate_key_pair,
    read_private_key,
    read_public_key,
    read_secret,
)
from tunnelsense.io._laser import (
    RunStream,
    ego_speed,
    open_run_stream,
    read_objects,
    read_run,
    read_run_gt,
    write_run,
    write_run_gt,
)
from tunnelsense.io._model import (
    MAX_MODEL_BYTES,
    TRUSTED_TYPES,
    ModelVersionWarning,
    UntrustedModelError,
    describe_model,
    load_model,
    save_model,
)
from tunnelsense.io._mot import read_tour, write_tour
from tunnelsense.io._results import (
    CLUSTERS_HEADER,
    CLUSTERS_SUFFIX,
    MOT_RESULT_COLUMNS,
    cluster_lines,
    clusters_path,
    mot_result_lines,
    read_hypotheses,
    read_mot_results,
    write_mot_results,
)
from tunnelsense.io._sources import open_tour, read_image_folder, read_video
from tunnelsense.io._tables import read_mot_gt, write_mot_gt
from tunnelsense.io._trust import check_model_path, load_trusted_model, read_signing_key
from tunnelsense.io._writer import ResultsWriter

__all__ = [
    "MAX_MODEL_BYTES",
    "generate_key_pair",
    "read_private_key",
    "read_public_key",
    "read_secret",
    "check_model_path",
    "load_trusted_model",
    "read_signing_key",
    "CLUSTERS_HEADER",
    "CLUSTERS_SUFFIX",
    "MOT_RESULT_COLUMNS",
    "ResultsWriter",
    "cluster_lines",
    "clusters_path",
    "mot_result_lines",
    "read_hypotheses",
    "TRUSTED_TYPES",
    "ModelVersionWarning",
    "UntrustedModelError",
    "describe_model",
    "load_model",
    "save_model",
    "describe",
    "format_description",
    "iter_video",
    "RunStream",
    "ego_speed",
    "open_run_stream",
    "open_source",
    "open_tour",
    "read_image",
    "read_image_folder",
    "read_mot_gt",
    "read_mot_results",
    "read_objects",
    "read_run",
    "read_run_gt",
    "read_tour",
    "read_video",
    "write_mot_gt",
    "write_mot_results",
    "write_run",
    "write_run_bag",
    "write_run_gt",
    "write_tour",
]
