"""Pictures of laser scans: one scan as a depth-height plot, a run as a range image."""

from __future__ import annotations

import numpy as np

from tunnelsense._records import LaserGeometry, Run, ScanRecord, ScanSequence

__all__ = ["interval_bars", "plot_range_image", "plot_scan", "scan_points"]


def _pyplot():
    try:
        import matplotlib.pyplot as plt
    except ImportError:  # pragma: no cover - depends on the install
        raise ImportError(
            "plotting needs matplotlib; install the optional extra: "
            "pip install 'tunnelsense[plot]'"
        ) from None
    return plt


def scan_points(ranges, geometry, *, roll=0.0):
    """Depth and height (m) of every beam of a scan, the road at height 0.

    Parameters
    ----------
    ranges : array-like of shape (n_beams,)
        Ranges (m); NaN, +inf or ``>= geometry.range_max`` are no return.
    geometry : LaserGeometry
        Beam layout and mounting height.
    roll : float, default=0.0
        Sensor roll (rad) added to the nominal beam angles (positive turns beams up).

    Returns
    -------
    depth, height : ndarray of shape (n_beams,)
        NaN where the beam has no return.
    no_return : ndarray of bool of shape (n_beams,)
        Beams with NaN, +inf or a range ``>= range_max``.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import LaserGeometry
    >>> from tunnelsense.plotting import scan_points
    >>> g = LaserGeometry(-np.pi / 4, np.pi / 4, 0.1, 8.191, 2.0)
    >>> d, h, none = scan_points([2 * np.sqrt(2), 8.191, 1.0], g)
    >>> np.round(d, 3).tolist(), np.round(h, 3).tolist(), none.tolist()
    ([2.0, nan, 0.707], [0.0, nan, 2.707], [False, True, False])
    """
    r = np.asarray(ranges, dtype=np.float64)
    if r.ndim != 1:
        raise ValueError(f"ranges must be 1-D (one scan); got shape {r.shape}")
    if not isinstance(geometry, LaserGeometry):
        raise TypeError(f"geometry must be a LaserGeometry; got {type(geometry).__name__}")
    theta = geometry.angles(len(r)) + roll
    no_return = ~np.isfinite(r) | (r >= geometry.range_max)
    rr = np.where(no_return, np.nan, r)
    return rr * np.cos(theta), geometry.mount_height + rr * np.sin(theta), no_return


def plot_scan(record_or_ranges, geometry=None, *, ax=None, labels=None, roi=(0.1, 2.0),
              regions=(4.0, 6.6)):
    """Plot one scan on the depth-height plane, like Fig. 4 of the LRF paper.

    Road points (``|height| < roi[0]``) are black, points of the region of interest
    are coloured (by ``labels`` when given), points above ``roi[1]`` are red, and the
    no-return beams are drawn in blue on the max-range arc.  Dashed lines mark the
    depth regions.

    Parameters
    ----------
    record_or_ranges : ScanRecord or array-like of shape (n_beams,)
        The scan.
    geometry : LaserGeometry, default=None
        Needed when ranges are given; taken from the record otherwise.
    ax : matplotlib Axes, default=None
        Where to draw; a new figure when None.
    labels : array-like of int of shape (n_beams,), default=None
        A label per beam (a cluster id, say; negative = none) colouring ROI points.
    roi : (float, float), default=(0.1, 2.0)
        Heights (m) bounding the region of interest.
    regions : sequence of float, default=(4.0, 6.6)
        Depths (m) of the region boundaries.

    Returns
    -------
    ax : matplotlib Axes
    """
    if isinstance(record_or_ranges, ScanRecord):
        ranges = record_or_ranges.ranges
        geometry = record_or_ranges.geometry if geometry is None else geometry
        title = f"{record_or_ranges.run}: scan {record_or_ranges.scan}"
    else:
        ranges = np.asarray(record_or_ranges, dtype=np.float64)
        title = "scan"
        if geometry is None:
            raise ValueError("geometry is required when record_or_ranges is an array")
    depth, height, none = scan_points(ranges, geometry)
    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(8, 4.5))
    road = np.abs(height) < roi[0]
    high = height >= roi[1]
    in_roi = ~none & ~road & ~high & (height > roi[0])
    ax.scatter(depth[road], height[road], s=6, c="k", label="road")
    if labels is None:
        ax.scatter(depth[in_roi], height[in_roi], s=8, c="tab:green", label="ROI")
    else:
        labels = np.asarray(labels)
        if labels.shape != depth.shape:
            raise ValueError(
                f"labels must have shape {depth.shape} (one per beam); got {labels.shape}"
            )
        sel = in_roi & (labels >= 0)
        ax.scatter(depth[sel], height[sel], s=8, c=labels[sel], cmap="tab10",
                   vmin=0, vmax=9, label="ROI (clusters)")
        rest = in_roi & (labels < 0)
        ax.scatter(depth[rest], height[rest], s=8, c="0.6", label="ROI (unclustered)")
    below = ~none & (height < -roi[0])
    ax.scatter(depth[below], height[below], s=6, c="0.4", marker="x", label="below road")
    ax.scatter(depth[high], height[high], s=6, c="tab:red", label=f"above {roi[1]:g} m")
    theta = geometry.angles(len(ranges))
    R = geometry.range_max
    arc = none & ~np.isnan(np.asarray(ranges, dtype=np.float64))  # NaN: dropouts
    ax.scatter(R * np.cos(theta[arc]), geometry.mount_height + R * np.sin(theta[arc]),
               s=6, c="tab:blue", label=f"max range ({R:g} m arc)")
    ax.plot([0], [geometry.mount_height], "k^", ms=8)
    for d in regions:
        ax.axvline(d, color="0.5", ls="--", lw=0.8)
    ax.axhline(roi[1], color="tab:red", lw=0.6, ls=":")
    ax.set_xlabel("depth (m)")
    ax.set_ylabel("height (m)")
    ax.set_aspect("equal")
    ax.set_title(title)
    ax.legend(loc="upper left", fontsize="small", markerscale=2)
    return ax


#: Where :func:`interval_bars` draws, in axes fractions (bottom, top) per label.
_BAR_ROWS = {("parked", "gt"): (0.0, 0.035), ("parked", "detected"): (0.045, 0.08),
             ("passing", "gt"): (0.965, 1.0), ("passing", "detected"): (0.92, 0.955)}
_BAR_COLOURS = {"parked": "tab:green", "passing": "tab:purple"}


def interval_bars(ax, intervals, source, *, alpha=1.0):
    """Mark scan intervals on a range image: parked along the bottom, passing the top.

    The bars are drawn inside the axes (clipped to them), in a band per ``source``, so
    that a picture of part of a run keeps its size.

    Parameters
    ----------
    ax : matplotlib Axes
        A range image (:func:`plot_range_image`): x is the scan.
    intervals : DataFrame
        ``first_scan``, ``last_scan`` and ``label`` (other labels are not drawn).
    source : {"gt", "detected"}
        The band, and the legend's words.
    alpha : float, default=1.0

    Returns
    -------
    ax : matplotlib Axes
    """
    for label, colour in _BAR_COLOURS.items():
        lo, hi = _BAR_ROWS[label, source]
        rows = intervals[intervals["label"] == label]
        for first, last in zip(rows["first_scan"], rows["last_scan"], strict=True):
            ax.fill_between([first, last + 1], lo, hi, color=colour, alpha=alpha,
                            transform=ax.get_xaxis_transform(), linewidth=0)
        ax.plot([], [], color=colour, alpha=alpha, lw=3, label=f"{label} ({source})")
    ax.legend(loc="lower right", fontsize="small", bbox_to_anchor=(1.0, 1.0), ncol=4,
              frameon=False)
    return ax


def plot_range_image(run_or_ranges, *, ax=None, gt=None, geometry=None, max_depth=8.0):
    """Plot the panoramic range image of a run: beams up, scans along, coloured by depth.

    Parameters
    ----------
    run_or_ranges : Run, ScanSequence or array-like of shape (n_scans, n_beams)
        The run (its ground truth is drawn unless ``gt=False``).
    ax : matplotlib Axes, default=None
        Where to draw; a new figure when None.
    gt : DataFrame, False or None, default=None
        Intervals ``id,first_scan,last_scan,label`` to mark along the bottom (parked)
        and top (passing); the run's own when None; none when False.
    geometry : LaserGeometry, default=None
        Used to colour by depth (horizontal distance) instead of range; taken from a
        Run or ScanSequence.
    max_depth : float, default=8.0
        Upper end of the colour scale (m).

    Returns
    -------
    ax : matplotlib Axes
    """
    name = "range image"
    if isinstance(run_or_ranges, Run):
        ranges = run_or_ranges.scans.ranges()
        geometry = run_or_ranges.geometry if geometry is None else geometry
        gt = run_or_ranges.gt if gt is None else gt
        name = run_or_ranges.name
    elif isinstance(run_or_ranges, ScanSequence):
        ranges = run_or_ranges.ranges()
        if geometry is None and len(run_or_ranges):
            geometry = run_or_ranges[0].geometry
    else:
        ranges = np.asarray(run_or_ranges, dtype=np.float64)
    if ranges.ndim != 2:
        raise ValueError(f"ranges must have shape (n_scans, n_beams); got {ranges.shape}")
    if geometry is not None:
        depth, _, none = zip(*(scan_points(r, geometry) for r in ranges), strict=True)
        value, none = np.array(depth), np.array(none)
        what = "depth (m)"
    else:
        none = ~np.isfinite(ranges)
        value = np.where(none, np.nan, ranges)
        what = "range (m)"
    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(12, 3.5))
    cmap = plt.get_cmap("turbo").with_extremes(bad="white")
    im = ax.imshow(value.T, origin="lower", aspect="auto", cmap=cmap, vmin=0, vmax=max_depth,
                   interpolation="nearest")
    ax.figure.colorbar(im, ax=ax, label=what, pad=0.01)
    if gt is not None and gt is not False and len(gt):
        interval_bars(ax, gt, "gt")
    ax.set_xlabel("scan")
    ax.set_ylabel("beam (bottom = road)")
    ax.set_title(name, loc="left")
    return ax
