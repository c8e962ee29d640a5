"""The grid of ``train tunnel --search`` (no imports: the command line names it)."""

__all__ = ["SEARCH_GRID"]

#: The small grid ``fit_indicator_detector(search=True)`` explores.
SEARCH_GRID = {
    "appearance__positive_weight": [1.0, 7.0],
    "motion__min_r": [0.9, 0.95],
    "motion__min_length": [5, 10],
}
