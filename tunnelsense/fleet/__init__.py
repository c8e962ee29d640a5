"""Many tours or laser runs detected at once, locally or on a Dask cluster.

:func:`detect_tours` runs one task per tour (in worker processes, or on a Dask
cluster), writes each tour's results into one folder, and skips the tours finished by
an earlier run, so a run that was stopped resumes where it was.
"""

from tunnelsense._lazy import attach

_NAMES = {
    "KINDS": "_one",
    "detect_one": "_one",
    "detect_tours": "_tours",
    "read_tour_list": "_tours",
    "tour_outputs": "_one",
}

__all__ = ["KINDS", "detect_one", "detect_tours", "read_tour_list", "tour_outputs"]

__getattr__, __dir__, _ = attach(__name__, _NAMES, __all__)
