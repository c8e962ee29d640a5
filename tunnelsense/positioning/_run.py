"""Positioning a tour from files: what ``tunnelsense position`` and
``tunnelsense evaluate position`` do, callable from Python."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tunnelsense.exceptions import InputFormatError
from tunnelsense.io._output import atomic_write, check_output, input_files
from tunnelsense.positioning._defaults import SIDE_ERROR
from tunnelsense.positioning._evaluate import position_errors
from tunnelsense.positioning._online import locate_online
from tunnelsense.positioning._positioner import TunnelPositioner
from tunnelsense.positioning._tables import (
    read_indicator_map,
    read_odometry,
    read_positions,
)

__all__ = ["evaluate_positions", "position_tour", "tour_tables"]

_TABLES = ("positions.csv", "odometry.csv", "indicators.csv")


def tour_tables(tour, odometry=None, indicator_map=None):
    """The odometry and indicator-map files of a tour, and every file it reads.

    Parameters
    ----------
    tour : str or Path
        Tour folder; a simulated one holds ``positions.csv``, ``odometry.csv`` and
        ``indicators.csv``.
    odometry, indicator_map : str or Path, default=None
        Files to use instead of the tour's own.

    Returns
    -------
    odometry, indicator_map : Path
    inputs : list of Path
        The tour's files and the tables: paths no output may overwrite.

    Examples
    --------
    >>> odometry, imap, inputs = tour_tables("tour", indicator_map="map.csv")
    >>> odometry.as_posix(), imap.as_posix()
    ('tour/odometry.csv', 'map.csv')
    """
    tour = Path(tour)
    odometry = Path(odometry or tour / "odometry.csv")
    indicator_map = Path(indicator_map or tour / "indicators.csv")
    inputs = [*input_files(tour), *(tour / n for n in _TABLES), odometry, indicator_map]
    return odometry, indicator_map, inputs


def position_tour(tour, out, *, model=None, results=None, odometry=None,
                  indicator_map=None, smooth=False, start_chainage=0.0,
                  start_sigma=1.0, odometry_scale=1.0, odometry_scale_sigma=0.05,
                  focal_length_px=None, sign_height_m=None, side_error=SIDE_ERROR,
                  overwrite=False, progress=None, inputs=(), n_threads=0, colour=None,
                  missing_frames="raise"):
    """Write the chainage of every frame of a tour, from odometry and indicator fixes.

    The file has a row per frame: ``frame,stamp,chainage,sigma,locked,scale,
    scale_sigma`` -- the chainage (m) and its standard deviation, whether the
    position is known (without a start, rows before the lock are ``false`` with the
    chainage left empty), and the odometry's estimated scale factor and its
    standard deviation (the last row's is what to give the next tunnel).

    Parameters
    ----------
    tour : str or Path
        Tour folder (its frames are read when ``model`` is given).
    out : str or Path
        The ``frame,stamp,chainage,sigma`` file to write.
    model : Pipeline, default=None
        A fitted indicator detector, run frame by frame (:func:`locate_online`).
    results : str or Path, default=None
        Instead of ``model``, a results file of ``detect tunnel``.
    odometry, indicator_map : str or Path, default=None
        Files to use instead of the tour's own (:func:`tour_tables`).
    smooth : bool, default=False
        Smooth: with ``results`` over the whole tour (offline), with ``model`` by a
        fixed-lag smoother (online); default: what was known at each frame.
    start_chainage : float or None, default=0.0
        Chainage of the first frame (m).  The default assumes the tour starts at
        the map's chainage 0 (the portal it is measured from).  None: unknown; the
        position locks on to the map from the spacing of the indicators passed.
    start_sigma : float, default=1.0
        Standard deviation of ``start_chainage`` (m).
    odometry_scale, odometry_scale_sigma : float, default=1.0, 0.05
        Prior of the odometry's scale factor (true / odometry distance) and its
        standard deviation: by default a wheel odometry within about 5 %; give the
        ``scale`` and ``scale_sigma`` a previous tunnel ended with to start
        calibrated.
    focal_length_px, sign_height_m : float or None, default=None
        The camera's focal length (px) and the indicators' height (m): each sign's
        box growth then measures the odometry's scale, before a second sign is
        passed (see :class:`TunnelPositioner`).  None: not known.
    side_error : float or None, default=0.05
        While locking on (without a start, or after a wrong start is dropped),
        where the map's ``side`` column names both walls, the wall each
        trajectory is seen on helps: the probability that it
        is read as the other wall (see :class:`TunnelPositioner`).  None: the
        side is not used.
    overwrite : bool, default=False
        Replace an existing ``out``.
    colour : int, "luminance" or None, default=None
        With ``model``: how colour frames become grey (refused by default; see
        :func:`~tunnelsense.io.read_image`).
    progress : callable, default=None
        ``progress(total, desc)`` returns a progress bar (or None) for the frames
        detected with ``model``.
    inputs : sequence of path, default=()
        More files ``out`` must not be (the model file, a key file).
    n_threads : int, default=0
        Reader threads decoding frames ahead of the detector (with ``model``).
    missing_frames : {"raise", "gap"}, default="raise"
        Frame files missing from the tour's folder (a recorder that lost frames):
        refused, or read as gaps in time (see :func:`~tunnelsense.io.read_tour`).
        A lost frame keeps its row: its position comes from the odometry alone.

    Returns
    -------
    positions : DataFrame
    fixes : DataFrame
        One row per trajectory; ``accepted`` marks those that gave a fix;
        ``attrs["lock_status"]`` says whether and where the position locked on.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from tunnelsense.datasets import make_tunnel_tour
    >>> from tunnelsense.io import write_tour
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = write_tour(make_tunnel_tour(20, random_state=0), folder / "tour")
    >>> _ = (folder / "none.txt").write_text("")  # no detection: dead reckoning only
    >>> positions, fixes = position_tour(folder / "tour", folder / "pos.csv",
    ...                                  results=folder / "none.txt")
    >>> len(positions), len(fixes)
    (20, 0)
    """
    from tunnelsense.io import read_mot_results

    if (model is None) == (results is None):
        raise ValueError("give exactly one of model and results")
    if (focal_length_px is None) != (sign_height_m is None):
        raise ValueError("focal_length_px (--focal-length) and sign_height_m "
                         "(--sign-height): give both or neither")
    odometry, indicator_map, tables = tour_tables(tour, odometry, indicator_map)
    extra = [p for p in (*inputs, results) if p]
    check_output(out, overwrite=overwrite, inputs=[*tables, *extra], what="--out")
    positioner = TunnelPositioner(
        smooth=smooth, initial_chainage=start_chainage, initial_sigma=start_sigma,
        initial_scale=odometry_scale, scale_sigma=odometry_scale_sigma,
        focal_length_px=focal_length_px, sign_height_m=sign_height_m,
        side_error=side_error)
    odo = read_odometry(odometry)
    positioner.fit(read_indicator_map(indicator_map))
    if results is not None:
        detections = read_mot_results(results)
        _check_coverage(odo, detections, tour, odometry, missing_frames)
        positions, fixes = positioner.predict(detections, odo, return_fixes=True)
    else:
        from tunnelsense.tunnel._detect import open_frames

        positioner.set_params(max_gap=max(model.named_steps["tracks"].max_gap, 0))
        # as detect tunnel: a video decoded lazily
        frames, total = open_frames(tour, colour=colour, missing_frames=missing_frames)
        bar = progress and progress(total, "detecting and positioning")
        positions, fixes = locate_online(model, frames, odo, positioner, progress=bar,
                                         n_threads=n_threads)
    with atomic_write(out, "w") as f:
        write_positions(positions, f)
    return positions, fixes


def _check_coverage(odo, detections, tour, odometry, missing_frames="raise") -> None:
    """The odometry must have a row for every frame of the tour (as ``--model`` mode
    requires): a gap or a shorter odometry would leave frames without a position."""
    from tunnelsense.io import open_tour

    tour = Path(tour)
    try:
        frames = open_tour(tour, ground_truth=False, missing_frames=missing_frames).frames
        last = int(frames[-1].frame) if len(frames) else 0
    except (OSError, ValueError):
        if (tour / "seqinfo.ini").is_file() or (tour / "img1").is_dir():
            raise  # a tour's frames that cannot be read (lost frames: the option)
        last = 0  # a folder of tables only: the detections say
    if len(detections):
        last = max(last, int(detections["frame"].max()))
    missing = np.setdiff1d(np.arange(1, last + 1), odo["frame"].to_numpy())
    if missing.size:
        raise InputFormatError(
            f"{odometry}: no odometry for frame {missing[0]} ({missing.size} of the "
            f"{last} frames of the tour have none); the odometry must cover every frame")


def write_positions(positions, f):
    """Write a positions table as CSV: ``locked`` as true/false, unknown cells empty."""
    positions.assign(locked=positions["locked"].map({True: "true", False: "false"})
                     ).to_csv(f, index=False, lineterminator="\n")


def evaluate_positions(tour, positions, *, odometry=None, indicator_map=None, draw=None,
                       overwrite=False):
    """Score a position estimate against a tour's true positions; plot it if asked.

    Parameters
    ----------
    tour : str or Path
        Tour folder holding the true ``positions.csv``.
    positions : str or Path
        The estimate, written by :func:`position_tour`.
    odometry, indicator_map : str or Path, default=None
        Files to use instead of the tour's own (:func:`tour_tables`).
    draw : str or Path, default=None
        Also plot the errors against time into this PNG file.
    overwrite : bool, default=False
        Replace an existing ``draw`` file.

    Returns
    -------
    errors : dict
        :func:`position_errors` of the estimate.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from tunnelsense.datasets import make_tunnel_tour
    >>> from tunnelsense.io import write_tour
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = write_tour(make_tunnel_tour(20, random_state=0), folder / "tour")
    >>> _ = (folder / "none.txt").write_text("")
    >>> _ = position_tour(folder / "tour", folder / "pos.csv", results=folder / "none.txt")
    >>> errors = evaluate_positions(folder / "tour", folder / "pos.csv")
    >>> errors["within_2_sigma"], errors["passes"]
    (1.0, [])
    """
    odometry, indicator_map, inputs = tour_tables(tour, odometry, indicator_map)
    if draw:
        check_output(draw, overwrite=overwrite, inputs=[*inputs, positions], what="--draw")
    truth = read_positions(Path(tour) / "positions.csv")
    estimate = read_positions(positions, sigma=True)
    odo = read_odometry(odometry) if odometry.is_file() else None
    indicators = read_indicator_map(indicator_map)
    errors = position_errors(truth, estimate, odo, indicators)
    if draw:
        import matplotlib.pyplot as plt

        from tunnelsense.positioning._plot import plot_positioning

        ax = plot_positioning(truth, estimate, odo, indicator_map=indicators)
        with atomic_write(draw, "wb") as f:
            ax.figure.savefig(f, format="png", dpi=100)
        plt.close(ax.figure)
    return errors
