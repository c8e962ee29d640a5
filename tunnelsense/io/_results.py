"""Results files: what the detectors write, and how it is read back.

* A MOTChallenge results file (``detect tunnel --out``): one line per detection,
  ``frame,id,bb_left,bb_top,bb_width,bb_height,conf,x,y,z`` with ``x, y, z = -1``.
  :func:`write_mot_results`, :func:`mot_result_lines` and :func:`read_mot_results`
  are its one writer and reader.
* Its companion ``RESULTS.clusters.csv``: every keypoint cluster with the detector's
  decisions (:data:`CLUSTERS_HEADER`), so that the false-alarm rate can be scored;
  :func:`cluster_lines` writes it, :func:`read_hypotheses` reads both back.
* :class:`~tunnelsense.io.ResultsWriter` writes any of them line by line, flushed,
  and resumes an interrupted file.

Floats are written in their shortest round-trip form, so a file read back gives the
same numbers.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from tunnelsense.exceptions import InputFormatError
from tunnelsense.io._tables import read_table

__all__ = [
    "CLUSTERS_HEADER",
    "CLUSTERS_SUFFIX",
    "MOT_RESULT_COLUMNS",
    "RESULT_LINE",
    "cluster_lines",
    "clusters_path",
    "mot_result_lines",
    "read_hypotheses",
    "read_mot_results",
    "write_mot_results",
]

#: Column names of a MOTChallenge results file.
MOT_RESULT_COLUMNS = (
    "frame", "id", "bb_left", "bb_top", "bb_width", "bb_height", "conf", "x", "y", "z",
)

#: A line of a MOTChallenge results file as :func:`mot_result_lines` writes it.
RESULT_LINE = r"\d+,-?\d+(?:,[^,]+){5},-1,-1,-1"

#: The companion of ``RESULTS.txt`` is ``RESULTS.clusters.csv``.
CLUSTERS_SUFFIX = ".clusters.csv"

#: Header of the ``*.clusters.csv`` companion of a results file.
CLUSTERS_HEADER = (
    "frame,track_id,bb_left,bb_top,bb_width,bb_height,indicator,trajectory_positive"
)


def _result_line(frame, track, left, top, width, height, conf, x=-1, y=-1, z=-1):
    xyz = ",".join("-1" if v == -1 else repr(float(v)) for v in (x, y, z))
    return (f"{int(frame)},{int(track)},{float(left)!r},{float(top)!r},"
            f"{float(width)!r},{float(height)!r},{float(conf)!r},{xyz}")


def mot_result_lines(record) -> list[str]:
    """The MOTChallenge results lines of one frame the indicator detector released.

    Parameters
    ----------
    record : FrameRecord
        With ``payload["detections"]``: rows ``(left, top, width, height, id, conf)``.

    Returns
    -------
    lines : list of str
        One line per detection, without newlines.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import FrameRecord
    >>> from tunnelsense.io import mot_result_lines
    >>> r = FrameRecord("t", 3, np.zeros((4, 4)), {"detections": [[1, 2, 4, 8, 7, 0.5]]})
    >>> mot_result_lines(r)
    ['3,7,1.0,2.0,4.0,8.0,0.5,-1,-1,-1']
    """
    rows = np.asarray(record.payload["detections"], np.float64).reshape(-1, 6).tolist()
    return [_result_line(record.frame, d[4], *d[:4], d[5]) for d in rows]


def write_mot_results(results: pd.DataFrame, path) -> None:
    """Write detections as a MOTChallenge results file.

    Parameters
    ----------
    results : DataFrame
        With ``frame,id,bb_left,bb_top,bb_width,bb_height,conf``; ``x, y, z`` are
        written as -1 unless given.
    path : str or Path
        The file to write (its folder is created).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import pandas as pd
    >>> from tunnelsense.io import read_mot_results, write_mot_results
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "res.txt"
    >>> write_mot_results(pd.DataFrame({"frame": [1], "id": [4], "bb_left": [10.5],
    ...     "bb_top": [3.0], "bb_width": [6.0], "bb_height": [14.0], "conf": [0.9]}),
    ...     path)
    >>> path.read_text()
    '1,4,10.5,3.0,6.0,14.0,0.9,-1,-1,-1\\n'
    >>> read_mot_results(path)["bb_height"].tolist()
    [14.0]
    """
    missing = [c for c in MOT_RESULT_COLUMNS[:7] if c not in results.columns]
    if missing:
        raise InputFormatError(f"cannot write {path}: the table lacks columns {missing}")
    table = results.assign(**{c: -1.0 for c in "xyz" if c not in results.columns})
    rows = table[list(MOT_RESULT_COLUMNS)].itertuples(index=False, name=None)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text("".join(_result_line(*row) + "\n" for row in rows),
                          encoding="utf-8")


def read_mot_results(path) -> pd.DataFrame:
    """Read a MOTChallenge results file as a DataFrame.

    Parameters
    ----------
    path : str or Path
        A results file with the 10 columns
        ``frame,id,bb_left,bb_top,bb_width,bb_height,conf,x,y,z``.

    Returns
    -------
    results : DataFrame
        ``frame`` and ``id`` as int64, the rest float64.

    Raises
    ------
    FileNotFoundError
        There is no such file.
    InputFormatError
        As for :func:`~tunnelsense.io.read_mot_gt` (names the file and the line).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from tunnelsense.io import read_mot_results
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "res.txt"
    >>> _ = path.write_text("3,7,1.0,2.0,4.0,8.0,0.5,-1,-1,-1\\n")
    >>> read_mot_results(path)[["frame", "id", "bb_height"]].to_numpy().tolist()
    [[3.0, 7.0, 8.0]]
    """
    return read_table(path, MOT_RESULT_COLUMNS)


def clusters_path(results) -> Path:
    """The ``*.clusters.csv`` companion of a results file.

    Examples
    --------
    >>> from tunnelsense.io import clusters_path
    >>> clusters_path("out/tour.txt").as_posix()
    'out/tour.clusters.csv'
    """
    results = Path(results)
    return results.with_name(results.stem + CLUSTERS_SUFFIX)


def cluster_lines(record) -> list[str]:
    """The ``*.clusters.csv`` lines of one released frame: every keypoint cluster.

    Parameters
    ----------
    record : FrameRecord
        With the payload keys ``cluster_boxes``, ``track_ids``, ``indicator`` and
        ``trajectory_positive`` the indicator detector writes.

    Returns
    -------
    lines : list of str
        In the columns of :data:`CLUSTERS_HEADER`, without newlines.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import FrameRecord
    >>> from tunnelsense.io import cluster_lines
    >>> r = FrameRecord("t", 2, np.zeros((4, 4)), {"cluster_boxes": [[1, 2, 3, 4]],
    ...     "track_ids": [5], "indicator": [True], "trajectory_positive": [False]})
    >>> cluster_lines(r)
    ['2,5,1.0,2.0,3.0,4.0,True,False']
    """
    p = record.payload
    boxes = np.asarray(p["cluster_boxes"], np.float64).reshape(-1, 4)
    scale = p.get("frame_scale")
    if scale is not None and tuple(scale) != (1.0, 1.0):  # the detector resampled the frame: back to its own pixels
        boxes = boxes / np.array([scale[0], scale[1], scale[0], scale[1]])
    boxes = boxes.tolist()
    return [
        f"{record.frame},{t},{b[0]!r},{b[1]!r},{b[2]!r},{b[3]!r},{bool(i)},{bool(tp)}"
        for b, t, i, tp in zip(
            boxes,
            np.asarray(p["track_ids"]).tolist(),
            np.asarray(p["indicator"]).tolist(),
            np.asarray(p["trajectory_positive"]).tolist(),
            strict=True,
        )
    ]


def read_hypotheses(results, tour_name) -> tuple[pd.DataFrame, bool]:
    """The hypotheses behind a results file: every cluster when its companion exists.

    The companion ``*.clusters.csv`` is read strictly (``indicator`` and
    ``trajectory_positive`` must be ``True`` or ``False``) and must agree with the
    results file: its positive-trajectory rows are exactly the detections of the
    results file, else it is stale (another run's) and refused.

    Parameters
    ----------
    results : str or Path
        A results file written by ``detect tunnel``.
    tour_name : str
        The ``tour`` column of the hypotheses.

    Returns
    -------
    hypotheses : DataFrame (see :data:`tunnelsense.metrics.HYPOTHESIS_COLUMNS`)
    complete : bool
        Whether the companion ``*.clusters.csv`` (every cluster) was found; otherwise
        the rows are the detections of the results file, all labelled indicator.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from tunnelsense.io import read_hypotheses
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "res.txt"
    >>> _ = path.write_text("1,4,10.0,3.0,6.0,14.0,0.9,-1,-1,-1\\n")
    >>> hypotheses, complete = read_hypotheses(path, "tour")
    >>> len(hypotheses), complete
    (1, False)
    """
    res = read_mot_results(results)
    detections = pd.DataFrame({
        "tour": tour_name,
        "frame": res["frame"].astype(np.int64),
        "track_id": res["id"].astype(np.int64),
        **{c: res[c].astype(np.float64) for c in MOT_RESULT_COLUMNS[2:6]},
        "indicator": True,
        "trajectory_positive": True,
    })
    companion = clusters_path(results)
    if not companion.is_file():
        return detections, False
    h = _read_companion(companion)
    h.insert(0, "tour", tour_name)
    keys = ["frame", "track_id", "bb_left", "bb_top", "bb_width", "bb_height"]

    def rows(table):
        return sorted(map(tuple, table[keys].to_numpy(np.float64).round(6).tolist()))

    if rows(h[h["trajectory_positive"]]) != rows(detections):
        raise InputFormatError(
            f"{companion}: does not match {results} (its positive trajectories are not "
            "the detections of the results file); is it from another run? Delete it "
            "to score the results file alone"
        )
    return h, True


def _read_companion(path: Path) -> pd.DataFrame:
    """A ``*.clusters.csv`` file, every field checked (the message names the line)."""
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise InputFormatError(f"{path}: not UTF-8 text") from None
    lines = text.splitlines()
    if not lines or lines[0].strip() != CLUSTERS_HEADER:
        raise InputFormatError(
            f"{path}: expected the header {CLUSTERS_HEADER!r} on line 1"
        )
    columns = CLUSTERS_HEADER.split(",")
    rows = []
    for n, line in enumerate(lines[1:], 2):
        fields = line.split(",")
        if len(fields) != len(columns):
            raise InputFormatError(
                f"{path}, line {n}: expected {len(columns)} fields, got {len(fields)}"
            )
        try:
            frame, track = int(fields[0]), int(fields[1])
            box = [float(v) for v in fields[2:6]]
        except ValueError:
            raise InputFormatError(
                f"{path}, line {n}: frame and track_id must be integers and the box "
                "numbers"
            ) from None
        bad = [(c, v) for c, v in zip(columns[6:], fields[6:], strict=True)
               if v not in ("True", "False")]
        if bad:
            raise InputFormatError(
                f"{path}, line {n}: {bad[0][0]} is {bad[0][1]!r}, expected True or False"
            )
        if frame < 1 or not np.all(np.isfinite(box)):
            raise InputFormatError(
                f"{path}, line {n}: expected a frame >= 1 and a finite box"
            )
        rows.append((frame, track, *box, fields[6] == "True", fields[7] == "True"))
    dtypes = [np.int64] * 2 + [np.float64] * 4 + [bool] * 2
    return pd.DataFrame({c: pd.Series([r[i] for r in rows], dtype=d)
                         for i, (c, d) in enumerate(zip(columns, dtypes, strict=True))})
