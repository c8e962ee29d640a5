"""Utilities for writing and testing tunnelsense stages.

:func:`check_record_stage` and :func:`record_stage_checks` run the checks every frame
or scan stage must pass; :func:`sklearn_api_checks` runs the scikit-learn API checks
that make sense without 2-D array input.
"""

from tunnelsense._lazy import attach

_NAMES = {
    "SKLEARN_RECORD_API_CHECKS": "_stage_checks",
    "assert_records_equal": "_stage_checks",
    "check_record_stage": "_stage_checks",
    "record_stage_checks": "_stage_checks",
    "sklearn_api_checks": "_stage_checks",
}

__all__ = [
    "SKLEARN_RECORD_API_CHECKS",
    "assert_records_equal",
    "check_record_stage",
    "record_stage_checks",
    "sklearn_api_checks",
]

__getattr__, __dir__, _ = attach(__name__, _NAMES, __all__)
