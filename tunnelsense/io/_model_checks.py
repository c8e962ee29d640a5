"""The second half of reading a detector's model strictly: what it holds.

:func:`check_detector` takes the object :func:`~tunnelsense.io._model_strict.read_strict`
built and refuses it unless it is exactly the pipeline ``train tunnel`` or
``train street`` writes: the expected steps by type and name, every step's
parameters valid by its own ``_parameter_constraints`` (and the checks its ``fit``
makes beyond them), its attributes exactly its parameters and the fitted attributes
its class documents, with their documented shapes, dtypes and finite values.
"""

from __future__ import annotations

import math
import numbers
from pathlib import Path

import numpy as np

from tunnelsense.exceptions import UntrustedModelError
from tunnelsense.io._model_strict import EXPECTED_STEPS, _is_trusted

__all__ = ["check_detector"]


def _int(value, low=0):
    return (isinstance(value, numbers.Integral) and not isinstance(value, bool)
            and value >= low)


def _finite(value):
    return (isinstance(value, numbers.Real) and not isinstance(value, bool)
            and math.isfinite(value))


def _array(est, name, kinds, shape):
    """The fitted array ``name`` of dtype kind in ``kinds`` and ``shape`` (None: any)."""
    value = getattr(est, name)
    if not isinstance(value, np.ndarray) or value.dtype.kind not in kinds:
        return f"{name} must be an array of kind {kinds!r}"
    if len(shape) != value.ndim or any(s is not None and s != n
                                       for s, n in zip(shape, value.shape, strict=True)):
        return f"{name} has shape {value.shape}, expected {shape}"
    if value.dtype.kind == "f" and not np.isfinite(value).all():
        return f"{name} holds non-finite values"
    return None


def _check_keypoints(est):
    try:
        kind = np.dtype(est.pixel_dtype_).kind
    except TypeError:
        kind = None
    if not isinstance(est.pixel_dtype_, str) or kind not in "uif":
        return "pixel_dtype_ must name a numeric NumPy dtype"
    if not (_finite(est.low_) and _finite(est.high_) and est.low_ <= est.high_):
        return "low_ and high_ must be finite with low_ <= high_"
    if est.frame_size == "training":
        shape = est.frame_shape_
        if not (isinstance(shape, tuple | list) and len(shape) == 2
                and all(_int(v, 1) and v <= 65535 for v in shape)):
            return "frame_shape_ must be (height, width), positive integers"
    if est.radiometry in ("frame", "contrast"):
        if not (_finite(est.ref_level_) and _finite(est.ref_spread_)
                and est.ref_spread_ > 0):
            return "ref_level_ and ref_spread_ must be finite with ref_spread_ > 0"
        if not (_finite(est.gain_tolerance_) and est.gain_tolerance_ >= 0):
            return "gain_tolerance_ must be finite and >= 0"
    if est.radiometry == "contrast":
        lo, hi = est.contrast_low_, est.contrast_high_
        if not (_finite(lo) and _finite(hi) and lo <= hi):
            return ("contrast_low_ and contrast_high_ must be finite with "
                    "contrast_low_ <= contrast_high_")
        if _deep(est) and not (_finite(est.raw_level_) and _finite(est.raw_spread_)
                               and est.raw_spread_ > 0):
            return "raw_level_ and raw_spread_ must be finite with raw_spread_ > 0"
    return None


def _deep(est):
    """Whether a keypoint sampler was fitted on frames deeper than 8 bits."""
    return getattr(est, "pixel_dtype_", "uint8") != "uint8"


def _check_verifier(est):
    n = est.n_features_in_
    if not _int(n, 1) or n != int(est._n_descriptor):
        return "n_features_in_ must be the descriptor length of the parameters"
    if not _int(est.n_centers_, 1):
        return "n_centers_ must be a positive integer"
    k = est.n_centers_
    for name, kinds, shape in (
        ("positive_centers_", "f", (None, n)), ("negative_centers_", "f", (None, n)),
        ("centers_", "f", (k, n)), ("center_scores_", "f", (k,)),
    ):
        if problem := _array(est, name, kinds, shape):
            return problem
    q = est.quantum_
    if not (_finite(q) and q > 0 and math.frexp(q)[0] == 0.5):
        return "quantum_ must be a positive power of two"
    for name in ("positive_centers_", "negative_centers_", "centers_"):
        grid = getattr(est, name) / q
        if not np.array_equal(grid, np.rint(grid)):
            return f"{name} must lie on the grid of quantum_"
    if not (_int(est.n_positive_) and _int(est.n_negative_)):
        return "n_positive_ and n_negative_ must be counts"
    return None


def _check_boost(est):
    n = est.n_features_in_
    if not _int(n, 1) or n != est._n_features():
        return "n_features_in_ must be the feature count of the parameters"
    m = getattr(est.stump_features_, "shape", (0,))[0]
    if m < 1:
        return "stump_features_ must hold at least one stump"
    for name, kinds, shape in (
        ("classes_", "biu", (2,)), ("stump_features_", "iu", (m,)),
        ("stump_thresholds_", "f", (m,)), ("_left", "iu", (m,)), ("_right", "iu", (m,)),
        ("stump_weights_", "f", (m,)), ("stump_errors_", "f", (m,)),
        ("stump_classes_", "iu", (m, 2)),
    ):
        if problem := _array(est, name, kinds, shape):
            return problem
    if not ((est.stump_features_ >= 0) & (est.stump_features_ < n)).all():
        return "stump_features_ must index the features"
    for name in ("_left", "_right", "stump_classes_"):
        if not ((getattr(est, name) >= 0) & (getattr(est, name) < 2)).all():
            return f"{name} must index classes_"
    if not (np.array_equal(est.stump_classes_[:, 0], est._left)
            and np.array_equal(est.stump_classes_[:, 1], est._right)):
        return "stump_classes_ must be _left and _right side by side"
    if not (_finite(est._total_weight)
            and math.isclose(est._total_weight, float(est.stump_weights_.sum()),
                             rel_tol=1e-9, abs_tol=1e-12)):
        return "_total_weight must be the sum of stump_weights_"
    if not (_int(est.n_clusters_fit_) and _int(est.n_positive_fit_)):
        return "n_clusters_fit_ and n_positive_fit_ must be counts"
    return None


def _check_frames_fit(est):
    return None if _int(est.n_frames_fit_) else "n_frames_fit_ must be a count"


def _check_scan(est):
    if problem := _array(est, "region_edges_", "f", (2,)):
        return problem
    if not est.region_edges_[0] <= est.region_edges_[1]:
        return "regions must be two increasing depths"
    if not (len(est.labels_) == 3 and all(isinstance(s, str) for s in est.labels_)):
        return "region_labels must be three strings"
    if not (est.min_height < est.max_height and est.min_length < est.max_length):
        return "min_height < max_height and min_length < max_length must hold"
    if not np.array_equal(est.region_edges_, np.asarray(est.regions, dtype=float)):
        return "region_edges_ must be the regions parameter"
    if est.labels_ != tuple(est.region_labels):
        return "labels_ must be the region_labels parameter"
    return None


#: The methods with which the estimators' ``fit`` checks what their constraints
#: cannot express (pairs, ranges).
_FIT_CHECKS = ("_check_settings", "_check_range", "_check_region_params")

#: Per class: its fitted attributes (documented in its docstring) and their check.
_FITTED = {
    "IntensityKeypointSampler": (
        lambda e: ("pixel_dtype_", "low_", "high_", "n_frames_fit_",
                   *(("frame_shape_",) if e.frame_size == "training" else ()),
                   *(("ref_level_", "ref_spread_", "gain_tolerance_")
                     if e.radiometry in ("frame", "contrast") else ()),
                   *(("contrast_low_", "contrast_high_")
                     if e.radiometry == "contrast" else ()),
                   # deeper frames map to an 8-bit picture from the training level
                   *(("raw_level_", "raw_spread_")
                     if e.radiometry == "contrast" and _deep(e) else ())),
        lambda e: _check_frames_fit(e) or _check_keypoints(e)),
    "KMeansHistogramVerifier": (
        ("positive_centers_", "negative_centers_", "center_scores_", "centers_",
         "n_centers_", "quantum_", "n_positive_", "n_negative_",
         "n_features_in_", "n_frames_fit_"),
        lambda e: _check_frames_fit(e) or _check_verifier(e)),
    "MSTClusterer": (("n_frames_fit_",), _check_frames_fit),
    "WeightedAdaBoost": (
        ("classes_", "stump_features_", "stump_thresholds_", "_left", "_right",
         "stump_weights_", "stump_errors_", "stump_classes_", "_total_weight",
         "n_features_in_", "n_clusters_fit_", "n_positive_fit_"), _check_boost),
    "TrajectoryLinker": (("n_frames_fit_",), _check_frames_fit),
    "PCCVerifier": (("n_frames_fit_",), _check_frames_fit),
    "ScanClusterer": (("region_edges_", "labels_"), _check_scan),
}


def _check_step(path, where, est):
    name = type(est).__name__
    params = set(type(est)._get_param_names())
    fitted, check = _FITTED[name]
    if callable(fitted):  # the attributes a fit sets follow some parameters
        fitted = fitted(est) if params <= set(vars(est)) else ()
    found = set(vars(est))
    if not found & set(fitted) and params <= found:
        raise UntrustedModelError(f"{path}: {where} ({name}) is not fitted; refusing "
                                  "to load it")
    if found != params | set(fitted):
        extra = sorted(found - params - set(fitted))
        missing = sorted((params | set(fitted)) - found)
        raise UntrustedModelError(
            f"{path}: {where} ({name}): "
            + (f"unexpected attributes {', '.join(extra)}" if extra else "")
            + ("; " if extra and missing else "")
            + (f"missing attributes {', '.join(missing)}" if missing else "")
            + " (a model of another tunnelsense version, or edited); refusing to load it"
        )
    try:
        est._validate_params()
        for method in _FIT_CHECKS:  # what fit checks beyond the constraints
            if hasattr(est, method):
                getattr(est, method)()
    except (ValueError, TypeError) as exc:  # InvalidParameterError is both
        raise UntrustedModelError(f"{path}: {where} ({name}): invalid parameter: "
                                  f"{exc}; refusing to load it") from None
    try:
        problem = check(est)
    except (AttributeError, TypeError, ValueError) as exc:
        problem = f"{type(exc).__name__}: {exc}"
    if problem:
        raise UntrustedModelError(f"{path}: {where} ({name}): {problem}; refusing to "
                                  "load it")


def check_detector(model, kind, path):
    """Refuse a model that is not exactly the ``kind`` detector's fitted pipeline."""
    from sklearn.pipeline import Pipeline

    path = Path(path)
    if type(model) is not Pipeline:
        raise UntrustedModelError(f"{path}: holds a {type(model).__name__}, not the "
                                  f"{kind} detector's Pipeline")
    expected_keys = set(Pipeline._get_param_names())
    if set(vars(model)) != expected_keys:
        raise UntrustedModelError(
            f"{path}: the Pipeline's attributes are {sorted(vars(model))}, expected "
            f"{sorted(expected_keys)}; refusing to load it")
    if model.memory is not None or not isinstance(model.verbose, bool) or getattr(
            model, "transform_input", None) is not None:
        raise UntrustedModelError(f"{path}: the Pipeline's memory, verbose or "
                                  "transform_input is not what tunnelsense writes")
    steps, expected = model.steps, EXPECTED_STEPS[kind]
    if (not isinstance(steps, list) or len(steps) != len(expected)
            or not all(isinstance(s, tuple) and len(s) == 2 for s in steps)):
        raise UntrustedModelError(
            f"{path}: the Pipeline's steps are not the {len(expected)} (name, "
            f"estimator) pairs of the {kind} detector; refusing to load it")
    for index, ((name, est), spec) in enumerate(zip(steps, expected, strict=True)):
        where = f"step {index} {name!r}"
        optional = len(spec) == 3
        if name != spec[0]:
            raise UntrustedModelError(f"{path}: {where}: expected the step "
                                      f"{spec[0]!r} ({spec[1]}) there")
        if optional and isinstance(est, str) and est == "passthrough":
            continue
        if type(est).__name__ != spec[1] or not _is_trusted(type(est)):
            raise UntrustedModelError(
                f"{path}: {where}: a {type(est).__module__}.{type(est).__name__}, "
                f"expected tunnelsense's {spec[1]}; refusing to load it")
        _check_step(path, where, est)
    return model
