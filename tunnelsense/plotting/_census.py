"""The picture of a parking census: the street along the distance driven, its parked
vehicles coloured by class under the kerb occupancy of each segment.

matplotlib is imported lazily (the optional ``plot`` extra).
"""

from __future__ import annotations

import numpy as np

from tunnelsense.plotting._scans import _pyplot
from tunnelsense.street._census import CENSUS_CLASSES, CENSUS_COLUMNS

__all__ = ["VEHICLE_CLASS_COLOURS", "plot_census"]

#: Colour of each census class in :func:`plot_census`.
VEHICLE_CLASS_COLOURS = {"car": "tab:blue", "van": "tab:orange",
                         "motorbike": "tab:green", "unclassified": "0.35"}

#: Segments up to which the count of each segment is written above it.
_MAX_LABELLED = 40


def plot_census(table, parked, *, ax=None, title=None):
    """Draw a census along the street: occupancy per segment, vehicles by class.

    The bars (y from 0 to 1) are the kerb occupancy of each segment, with its count
    of parked vehicles above it (up to 40 segments); below them, a lane per class
    holds the parked vehicles, each a bar over its stretch of street.

    Parameters
    ----------
    table : DataFrame
        A census (:func:`~tunnelsense.street.census`).
    parked : DataFrame
        The parked vehicles with ``start_m``, ``end_m`` and ``vehicle_class``
        (:func:`~tunnelsense.street.parked_extents`).
    ax : matplotlib Axes, default=None
        Where to draw; a new wide figure when None.
    title : str, default=None

    Returns
    -------
    ax : matplotlib Axes

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import pandas as pd
    >>> from tunnelsense.plotting import plot_census
    >>> from tunnelsense.street import census, parked_extents
    >>> objects = pd.DataFrame({"first_scan": [0, 60], "last_scan": [44, 79],
    ...                         "label": ["parked", "parked"]})
    >>> distances = [0.1 * i for i in range(301)]
    >>> ax = plot_census(census(objects, distances, segment_length=10.0),
    ...                  parked_extents(objects, distances))
    >>> [t.get_text() for t in ax.get_legend().get_texts()]
    ['unclassified', 'kerb occupancy']
    """
    missing = [c for c in CENSUS_COLUMNS if c not in table]
    if missing:
        raise ValueError(f"table lacks column(s) {', '.join(missing)}: expected a "
                         "census (tunnelsense.street.census)")
    missing = [c for c in ("start_m", "end_m", "vehicle_class") if c not in parked]
    if missing:
        raise ValueError(f"parked lacks column(s) {', '.join(missing)}: expected "
                         "tunnelsense.street.parked_extents")
    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(14, 4), layout="constrained")
    starts = table["start_m"].to_numpy(dtype=float)
    widths = table["kerb_length_m"].to_numpy(dtype=float)
    ax.bar(starts, table["occupancy"], width=widths, align="edge", color="0.85",
           edgecolor="0.6", linewidth=0.6, label="kerb occupancy")
    if len(table) <= _MAX_LABELLED:
        for x, w, n in zip(starts, widths, table["parked"], strict=True):
            ax.text(x + w / 2, 1.02, str(int(n)), ha="center", va="bottom",
                    fontsize="small")
    present = [c for c in CENSUS_CLASSES if (parked["vehicle_class"] == c).any()]
    lane = 0.3 / max(len(present), 1)
    for i, name in enumerate(present):
        rows = parked[parked["vehicle_class"] == name]
        top = -0.05 - i * lane
        spans = list(zip(rows["start_m"], rows["end_m"] - rows["start_m"], strict=True))
        ax.broken_barh(spans, (top - 0.8 * lane, 0.8 * lane),
                       facecolor=VEHICLE_CLASS_COLOURS[name], edgecolor="white",
                       linewidth=0.5, label=name)
    end = float(table["end_m"].iloc[-1]) if len(table) else 1.0
    ax.set_xlim(0.0, end)
    ax.set_ylim(-0.4, 1.15)
    ax.set_yticks(np.linspace(0.0, 1.0, 5))
    ax.set(xlabel="distance along the street (m)",
           ylabel="kerb occupancy; parked vehicles below", title=title)
    ax.legend(loc="upper left", fontsize="small", bbox_to_anchor=(1.0, 1.0),
              frameon=False)
    return ax
