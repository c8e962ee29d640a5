"""The scikit-learn names tunnelsense uses that scikit-learn does not make public.

Parameter validation (``_fit_context``, ``_check_sample_weight``, ``Interval``, ``StrOptions``,
``validate_parameter_constraints``) lives in private modules of scikit-learn; every
module of tunnelsense imports it from here, so a scikit-learn release that moves it is
a fix in this one file (as imbalanced-learn does).  ``validate_data`` is public from
scikit-learn 1.6, the lowest release tunnelsense supports.
"""

from sklearn.base import _fit_context
from sklearn.utils._param_validation import (
    Interval,
    StrOptions,
    validate_parameter_constraints,
)
from sklearn.utils.validation import _check_sample_weight, validate_data

__all__ = [
    "Interval",
    "_check_sample_weight",
    "StrOptions",
    "_fit_context",
    "validate_data",
    "validate_parameter_constraints",
]
