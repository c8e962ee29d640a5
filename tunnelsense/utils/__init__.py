"""Utilities for writing and testing tunnelsense stages.

:func:`check_record_stage` and :func:`record_stage_checks` run the checks every frame
or scan stage must pass; :func:`sklearn_api_checks` runs the scikit-learn API checks
that make sense without 2-D array input.
"""

from tunnelsense.utils._stage_checks import (
    SKLEARN_RECORD_API_CHECKS,
    assert_records_equal,
    check_record_stage,
    record_stage_checks,
    sklearn_api_checks,
)

__all__ = [
    "SKLEARN_RECORD_API_CHECKS",
    "assert_records_equal",
    "check_record_stage",
    "record_stage_checks",
    "sklearn_api_checks",
]
