"""Helpers shared by the FIR stages: the two-mode dispatch, keypoint labels, bin tables."""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np
from sklearn.utils.validation import check_is_fitted

from tunnelsense._payload import inside_boxes
from tunnelsense._records import (
    FrameRecord,
    FrameSequence,
    ScanRecord,
    ScanSequence,
    check_frames,
)
from tunnelsense.exceptions import InputFormatError

__all__ = [
    "FrameModeMixin",
    "bin_lut",
    "check_intensity_range",
    "is_record_input",
    "one_frame_shape",
    "points_in_boxes",
    "require_boxes",
]

def is_record_input(X) -> bool:
    """Whether ``X`` is meant as frame records (frame mode) rather than a 2-D array.

    A :class:`FrameSequence` or :class:`ScanSequence`, or a list / tuple whose first
    element is a record, selects frame mode (wrong record types are then rejected by
    :func:`tunnelsense.check_frames`).  A 3-D array (a stack of images) is rejected here
    with a message that says what is expected.
    """
    if isinstance(X, FrameSequence | ScanSequence):
        return True
    if isinstance(X, np.ndarray):
        if X.ndim == 3:
            raise TypeError(
                "X must be a sequence of FrameRecord (frame mode) or a 2-D array "
                f"(tabular mode); got an array of shape {X.shape}. Wrap a stack of "
                "images with tunnelsense.FrameSequence.from_array(images)."
            )
        return False
    if isinstance(X, Sequence) and not isinstance(X, str | bytes) and len(X):
        return isinstance(X[0], FrameRecord | ScanRecord)
    return False


class FrameModeMixin:
    """The frame stage on top of a tabular core: the one place that looks at ``X``.

    :class:`MSTClusterer`, :class:`KMeansHistogramVerifier` and
    :class:`WeightedAdaBoost` are each a tabular core (a scikit-learn estimator of
    2-D arrays, which passes ``parametrize_with_checks`` in full) with this mixin in
    front, so that the name a user imports takes both frame records (in a
    :class:`~sklearn.pipeline.Pipeline`) and 2-D arrays, with the same fitted
    attributes: a frame stage fits its core on what the frames give (histograms of
    keypoints or of clusters).  ``fit``, ``transform`` and ``fit_transform`` hand
    frame records (:func:`is_record_input`) to the class's ``_fit_frames(X, y,
    **fit_params)`` and ``_transform_frames(records) -> list of records``, and 2-D
    arrays to the core; the core's methods named in ``_tabular_methods`` refuse
    frame records, pointing to ``_frames_instead``.
    """

    _tabular_methods: tuple = ()
    _frames_instead = "transform"

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        for name in cls.__dict__.get("_tabular_methods", ()):
            setattr(cls, name, _tabular_only(getattr(cls, name), name))

    def fit(self, X, y=None, **fit_params):
        """Fit on frame records (the frame stage) or on a 2-D array (the core).

        Parameters
        ----------
        X : sequence of FrameRecord, or array-like of shape (n_samples, n_features)
        y : sequence of array-like of shape (k_i, 4), or array-like of shape (n_samples,)
            For frames: per frame, the indicator boxes.  For arrays: as the core
            takes it.
        **fit_params : dict
            Passed on (``sample_weight`` for arrays).

        Returns
        -------
        self : object
        """
        if is_record_input(X):
            return self._fit_frames(X, y, **fit_params)
        return super().fit(X, y, **fit_params)

    def transform(self, X):
        """Evolve frame records (see the class), or transform a 2-D array (the core).

        Parameters
        ----------
        X : sequence of FrameRecord, or array-like of shape (n_samples, n_features)

        Returns
        -------
        X_new : FrameSequence or ndarray
        """
        if is_record_input(X):
            check_is_fitted(self)
            records, _ = check_frames(X)
            return FrameSequence(self._transform_frames(records))
        return super().transform(X)

    def fit_transform(self, X, y=None, **fit_params):
        """Fit, then transform the same ``X`` (frame records or a 2-D array).

        Returns
        -------
        X_new : FrameSequence or ndarray
        """
        return self.fit(X, y, **fit_params).transform(X)


def _tabular_only(method, name):
    @functools.wraps(method)
    def tabular(self, X, *args, **kwargs):
        if is_record_input(X):
            raise TypeError(
                f"{type(self).__name__}.{name} takes a 2-D array; for frame records "
                f"use {self._frames_instead}"
            )
        return method(self, X, *args, **kwargs)

    return tabular


def require_boxes(boxes, owner, purpose):
    """Refuse ``boxes`` None (no ``y``): ``owner`` needs the indicator boxes ``purpose``.

    Examples
    --------
    >>> require_boxes(None, "MyStage", "that label keypoints positive")
    Traceback (most recent call last):
    ...
    ValueError: MyStage requires y: per frame, the (k, 4) indicator boxes that label keypoints positive
    """
    if boxes is None:
        raise ValueError(
            f"{owner} requires y: per frame, the (k, 4) indicator boxes {purpose}"
        )


def points_in_boxes(rows, cols, boxes) -> np.ndarray:
    """Whether each point ``(row, col)`` lies inside any box ``(left, top, w, h)``.

    A point is inside when ``left <= col < left + width`` and
    ``top <= row < top + height`` (:func:`tunnelsense._payload.inside_boxes`).

    Examples
    --------
    >>> import numpy as np
    >>> points_in_boxes(np.array([5, 50]), np.array([5, 5]), np.array([[0, 0, 10, 10.]]))
    array([ True, False])
    """
    return inside_boxes(cols, rows, boxes).any(axis=1)


def check_intensity_range(intensity_range):
    """Refuse an ``intensity_range`` that is neither None nor a pair (lo, hi), lo < hi.

    Examples
    --------
    >>> check_intensity_range((0, 4096))
    >>> check_intensity_range((10, 10))
    Traceback (most recent call last):
    ...
    ValueError: intensity_range must be None or a pair (lo, hi) with lo < hi; got (10, 10)
    """
    if intensity_range is None:
        return
    r = tuple(intensity_range)
    if len(r) != 2 or not r[0] < r[1]:
        raise ValueError(
            "intensity_range must be None or a pair (lo, hi) with lo < hi; "
            f"got {intensity_range!r}"
        )


def bin_lut(dtype, bins, intensity_range=None, binning="hard"):
    """Lookup tables from every pixel value of ``dtype`` to its histogram bin(s).

    ``binning="hard"``: one table, the bin of every value (values outside
    ``intensity_range`` go to the end bins).  ``binning="linear"``: a pair
    ``(lower_bin, upper_weight)``: a value at bin coordinate ``x`` (bin centres at
    integers) gives weight ``1 - w`` to bin ``floor(x)`` and ``w`` to the next, clipped
    at the ends.  Tables are built once per process and argument set (a 16-bit table
    costs about a millisecond) and returned read-only.

    Examples
    --------
    >>> import numpy as np
    >>> bin_lut(np.uint8, 4)[[0, 63, 64, 255]].tolist()
    [0, 0, 1, 3]
    """
    dtype = np.dtype(dtype)
    if intensity_range is None:
        lo, hi = 0, int(np.iinfo(dtype).max) + 1
    else:
        lo, hi = (int(v) for v in intensity_range)
    return _bin_lut(dtype, int(bins), lo, hi, binning)


@functools.lru_cache(maxsize=16)
def _bin_lut(dtype, bins, lo, hi, binning):
    values = np.arange(int(np.iinfo(dtype).max) + 1, dtype=np.int64)
    if binning == "hard":
        # integer arithmetic: floor((v - lo) * bins / (hi - lo)) exactly
        table = np.clip(((values - lo) * bins) // (hi - lo), 0, bins - 1).astype(np.intp)
        table.flags.writeable = False
        return table
    x = np.clip((values + 0.5 - lo) * bins / (hi - lo) - 0.5, 0, bins - 1)
    b0 = np.minimum(np.floor(x), bins - 2 if bins > 1 else 0)
    lower, weight = b0.astype(np.intp), (x - b0).astype(np.float32)
    lower.flags.writeable = False
    weight.flags.writeable = False
    return lower, weight


def one_frame_shape(records):
    """The one ``(height, width)`` of the frames (``frame_size="training"``)."""
    shapes = set()
    for r in records:
        shape = getattr(r.source, "shape", None)
        shapes.add(tuple(shape[:2]) if shape is not None and len(shape) == 2
                   else r.image.shape[:2])
    if len(shapes) > 1:
        raise InputFormatError(
            f"the training frames have several sizes ({sorted(shapes)}); with "
            "frame_size='training' they must have one, the size every length in "
            "pixels refers to"
        )
    return tuple(int(v) for v in shapes.pop())
