"""Pictures of the street detector: Fig. 4 (a scan's clusters and the ROI), Fig. 5 (a
scan's dendrogram and the cut), and the panoramic range image with the objects.

matplotlib is imported lazily (the optional ``plot`` extra).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.cluster.hierarchy import dendrogram, single
from scipy.spatial.distance import pdist

from tunnelsense._records import ScanRecord
from tunnelsense.plotting._scans import _pyplot, interval_bars, plot_range_image
from tunnelsense.street._restoration import no_return, restore_points

__all__ = ["draw_run", "plot_clusters", "plot_dendrogram", "plot_objects"]


def _check_clustered(record):
    if not isinstance(record, ScanRecord) or "clusters" not in record.payload:
        raise ValueError(
            "record must be a ScanRecord returned by ScanClusterer.transform "
            "(its payload holds points and clusters)"
        )


def plot_clusters(record, *, roi=(0.1, 2.0), regions=(4.0, 6.6), ax=None):
    """Fig. 4: one scan on the depth-height plane, clusters coloured, ROI drawn.

    Parameters
    ----------
    record : ScanRecord
        A record returned by :meth:`ScanClusterer.transform` (tilt compensated).
    roi : (float, float), default=(0.1, 2.0)
    regions : (float, float), default=(4.0, 6.6)
    ax : matplotlib Axes, default=None

    Returns
    -------
    ax : matplotlib Axes
    """
    _check_clustered(record)
    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(8, 4.5))
    g = record.geometry
    r = np.where(no_return(record.ranges, g.range_min, g.range_max), np.nan,
                 record.ranges)
    d, h = restore_points(r, g.angles(len(r)), g.mount_height,
                          record.payload.get("tilt", 0.0))
    ax.scatter(d, h, s=5, c="0.7", label="outside the ROI")
    pts, cl = record.payload["points"], record.payload["clusters"]
    for k in np.unique(cl):
        sel = cl == k
        ax.scatter(pts[sel, 0], pts[sel, 1], s=9, label=f"cluster {k}")
    ax.axhspan(roi[0], roi[1], color="tab:green", alpha=0.06, label="ROI")
    for x in regions:
        ax.axvline(x, color="0.4", ls="--", lw=0.8)
    ax.plot([0], [g.mount_height], "k^", ms=8)
    ax.set(xlabel="depth (m)", ylabel="height (m)",
           title=f"{record.run}: scan {record.scan}, "
                 f"tilt {np.rad2deg(record.payload.get('tilt', 0.0)):.2f} deg")
    ax.set_aspect("equal")
    ax.legend(loc="upper right", fontsize="x-small", markerscale=2)
    return ax


def plot_dendrogram(record, *, cut=0.6, ax=None):
    """Fig. 5: the single-linkage dendrogram of a scan's ROI points and the cut line.

    The y-axis reaches above the cut even when every merge is shorter, so that the
    cut line is always seen.

    Parameters
    ----------
    record : ScanRecord
        A record returned by :meth:`ScanClusterer.transform`.
    cut : float, default=0.6
    ax : matplotlib Axes, default=None

    Returns
    -------
    ax : matplotlib Axes
    """
    _check_clustered(record)
    pts = record.payload["points"]
    if len(pts) < 2:
        raise ValueError(
            f"scan {record.scan} of run {record.run!r} has {len(pts)} ROI point(s): "
            "a dendrogram needs at least 2"
        )
    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(8, 4))
    dendrogram(single(pdist(pts)), ax=ax, no_labels=True, color_threshold=cut)
    ax.axhline(cut, color="tab:red", lw=1.2, label=f"cut {cut:g} m")
    bottom, top = ax.get_ylim()  # scipy sets it to the highest merge
    ax.set_ylim(bottom, max(top, 1.1 * cut))
    ax.set(ylabel="linkage distance (m)",
           title=f"{record.run}: scan {record.scan}, {len(pts)} ROI points")
    ax.legend(loc="upper right")
    return ax


def plot_objects(run, objects, *, ax=None):
    """The panoramic range image of a run with the detected objects marked.

    Parameters
    ----------
    run : Run
    objects : DataFrame
        From :meth:`ScanClusterer.detect`.
    ax : matplotlib Axes, default=None

    Returns
    -------
    ax : matplotlib Axes

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> from tunnelsense.datasets import make_street_scans
    >>> from tunnelsense.plotting import plot_objects
    >>> run = make_street_scans(300, random_state=0)
    >>> ax = plot_objects(run, run.gt)
    >>> [t.get_text() for t in ax.get_legend().get_texts()]
    ['parked (gt)', 'passing (gt)', 'parked (detected)', 'passing (detected)']
    """
    ax = plot_range_image(run, ax=ax)
    interval_bars(ax, objects, "detected", alpha=0.6)
    return ax


def draw_run(run, clusterer, outdir, *, X=None, max_scans=1500):
    """Write the pictures of ``detect street --draw``: range image with objects, and
    Fig. 4 / Fig. 5 of the scan in the middle of the first parked object.

    The range image is cut into pictures of ``max_scans`` scans each, of a fixed size
    (1540 x 440 px).

    Parameters
    ----------
    run : Run
    clusterer : ScanClusterer
        Fitted.
    outdir : str or Path
        The folder to write into (created).
    X : sequence of ScanRecord or None, default=None
        The run's scans as the clusterer takes them (the run's own when None).
    max_scans : int, default=1500
        Scans per range-image picture.

    Returns
    -------
    paths : list of Path
    """
    plt = _pyplot()
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    X = list(run.scans) if X is None else X
    objects = clusterer.detect(X, all_objects=True)
    written = []
    for start in range(0, len(run), max_scans):
        part = objects[(objects.first_scan < start + max_scans)
                       & (objects.last_scan >= start)]
        fig, ax = plt.subplots(figsize=(14, 4), layout="constrained")
        plot_objects(run, part, ax=ax)
        ax.set_xlim(start, min(start + max_scans, len(run)))
        path = out / f"range_image_{start:06d}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)
    parked = objects[objects.label == "parked"]
    scan = int(parked.iloc[0][["first_scan", "last_scan"]].mean()) if len(parked) else 0
    rec = next((r for r in clusterer.transform(X) if r.scan == scan), None)
    if rec is not None:
        fig, ax = plt.subplots(figsize=(8, 4.5))
        plot_clusters(rec, roi=(clusterer.min_height, clusterer.max_height),
                      regions=tuple(clusterer.regions), ax=ax)
        path = out / f"scan_{scan:06d}_clusters.png"
        fig.savefig(path, dpi=110, bbox_inches="tight")
        plt.close(fig)
        written.append(path)
        if len(rec.payload["points"]) >= 2:
            fig, ax = plt.subplots(figsize=(8, 4))
            plot_dendrogram(rec, cut=clusterer.cut, ax=ax)
            path = out / f"scan_{scan:06d}_dendrogram.png"
            fig.savefig(path, dpi=110, bbox_inches="tight")
            plt.close(fig)
            written.append(path)
    return written
