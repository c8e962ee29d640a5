"""A far-infrared frame with its ground-truth (or detected) boxes, coloured by class."""

import numpy as np

from tunnelsense._records import OBJECT_CLASSES

__all__ = ["CLASS_COLORS", "plot_frame"]

#: Box colour per ground-truth class (1 indicator, 2 lamp, 3 vehicle, 4 shadow).
CLASS_COLORS = {1: "red", 2: "gold", 3: "deepskyblue", 4: "limegreen"}


def _as_boxes(boxes, classes):
    """``(k, 4)`` boxes and ``(k,)`` class ids from a gt DataFrame or an array."""
    if boxes is None:
        return np.empty((0, 4)), np.empty(0, dtype=int)
    if hasattr(boxes, "columns"):  # gt rows (MOTChallenge columns)
        cols = ["bb_left", "bb_top", "bb_width", "bb_height"]
        missing = [c for c in cols if c not in boxes.columns]
        if missing:
            raise ValueError(f"boxes DataFrame lacks the columns {missing}")
        arr = boxes[cols].to_numpy(dtype=np.float64)
        if classes is None and "class" in boxes.columns:
            classes = boxes["class"].to_numpy()
    else:
        arr = np.asarray(boxes, dtype=np.float64)
        if arr.size == 0:
            arr = arr.reshape(0, 4)
        if arr.ndim != 2 or arr.shape[1] != 4:
            raise ValueError(
                "boxes must be a ground-truth DataFrame or an array of shape (k, 4) "
                f"(left, top, width, height); got shape {arr.shape}"
            )
    if classes is None:
        classes = np.ones(len(arr), dtype=int)
    classes = np.broadcast_to(np.asarray(classes, dtype=int), (len(arr),))
    return arr, classes


def plot_frame(image, boxes=None, *, classes=None, ax=None):
    """Draw a frame and its boxes, coloured by class.

    Parameters
    ----------
    image : ndarray of shape (height, width)
        The frame (uint8 or uint16), shown in grey levels.
    boxes : DataFrame or array-like of shape (k, 4), default=None
        The ground-truth rows of this frame (``bb_left, bb_top, bb_width, bb_height``
        and ``class`` columns) or plain boxes ``(left, top, width, height)``.
    classes : int or array-like of shape (k,), default=None
        Class id per box; default: the ``class`` column of a DataFrame, else 1
        (indicator).
    ax : matplotlib Axes, default=None
        Where to draw; default: a new figure.

    Returns
    -------
    ax : matplotlib Axes

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> from tunnelsense.datasets import make_tunnel_tour
    >>> from tunnelsense.plotting import plot_frame
    >>> tour = make_tunnel_tour(2, random_state=0)
    >>> ax = plot_frame(tour.frames[0].image, tour.gt[tour.gt["frame"] == 1])
    >>> len(ax.patches) == int((tour.gt["frame"] == 1).sum())
    True
    """
    import matplotlib.pyplot as plt  # noqa: PLC0415
    from matplotlib.patches import Rectangle  # noqa: PLC0415

    image = np.asarray(image)
    if image.ndim != 2:
        raise ValueError(f"image must be 2-D (height, width); got shape {image.shape}")
    arr, cls = _as_boxes(boxes, classes)
    if ax is None:
        _, ax = plt.subplots(figsize=(image.shape[1] / 100, image.shape[0] / 100))
    vmax = 255 if image.dtype == np.uint8 else float(image.max() or 1)
    ax.imshow(image, cmap="gray", vmin=0, vmax=vmax, interpolation="nearest")
    seen = set()
    for (left, top, width, height), c in zip(arr, cls, strict=True):
        label = OBJECT_CLASSES.get(int(c), str(c))
        ax.add_patch(
            Rectangle(
                (left - 0.5, top - 0.5),
                width,
                height,
                fill=False,
                lw=1.0,
                edgecolor=CLASS_COLORS.get(int(c), "magenta"),
                label=None if label in seen else label,
            )
        )
        seen.add(label)
    ax.set_xlim(-0.5, image.shape[1] - 0.5)
    ax.set_ylim(image.shape[0] - 0.5, -0.5)
    ax.set_axis_off()
    if seen:
        ax.legend(loc="lower right", fontsize="x-small", framealpha=0.6)
    return ax
