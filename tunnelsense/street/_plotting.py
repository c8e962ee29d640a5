"""Moved to :mod:`tunnelsense.plotting` (the one home of pictures)."""

from tunnelsense.plotting._street import (  # noqa: F401
    draw_run,
    plot_clusters,
    plot_dendrogram,
    plot_objects,
)
