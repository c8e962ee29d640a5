"""Bit depth of FIR frames: the pixel type a keypoint sampler is fitted on, and
the refusal of frames of another depth (in ``transform``, and before a detector
serves a source)."""

from __future__ import annotations

import numpy as np

from tunnelsense._payload import check_image, where
from tunnelsense.exceptions import InputFormatError

__all__ = ["check_band_reaches_boxes", "check_served_depth"]


#: What both refusals of another bit depth advise (in ``transform``, and before a
#: detector serves a source).
_DEPTH_ADVICE = (
    "A 16-bit camera's raw counts are not 8-bit levels times 257 (the camera's gain "
    "decides); fit the detector on frames of this depth, or convert the frames to "
    "the fitted depth yourself")


def _check_depth(image, index, record, expected, band=None):
    """Refuse a frame whose pixel type is not ``expected``, the units of the band.

    ``band`` is the fitted band (in ``transform``), or None (in ``fit``, where the
    other frames set ``expected``).
    """
    if image.dtype == expected:
        return image
    told = (
        f"the other frames are {expected}: fit on frames of one bit depth"
        if band is None
        else f"the sampler was fitted on {expected} frames: its intensity band "
        f"[{band[0]:g}, {band[1]:g}] is in {expected} grey levels"
    )
    raise InputFormatError(
        f"{where(record, index)}: a {image.dtype} frame, but {told}. {_DEPTH_ADVICE}")


def check_served_depth(model, record, source):
    """Refuse, before any output is written, a source whose first frame has another
    pixel type than the frames ``model`` (a fitted indicator pipeline) was fitted
    on, naming the file and both types; a model without a fitted sampler of known
    depth passes (its own ``predict`` decides)."""
    step = getattr(model, "named_steps", {}).get("keypoints")
    fitted = getattr(step, "pixel_dtype_", None)
    image = record.image
    if fitted is None or str(image.dtype) == fitted:
        return
    origin = getattr(record.source, "origin", record.source)  # decoded: its file
    path = getattr(origin, "path", None) or str(source)
    raise InputFormatError(
        f"{path}: frame {record.frame} is {image.dtype}, but the detector was fitted "
        f"on {fitted} frames (its intensity band is in {fitted} grey levels). "
        f"{_DEPTH_ADVICE}")


def _pixel_dtype(records) -> str:
    """The pixel type of the frames (one decode at most when none is decoded)."""
    kinds = set()
    for r in records:
        source = r.source
        if isinstance(source, np.ndarray):
            kinds.add(str(source.dtype))
        elif hasattr(source, "array"):  # DecodedImage
            kinds.add(str(source.array.dtype))
    if not kinds and len(records):
        kinds.add(str(records[0].image.dtype))
    if len(kinds) > 1:
        raise InputFormatError(
            f"the frames mix pixel types ({', '.join(sorted(kinds))}); fit on frames "
            "of one bit depth: the intensity band is in grey levels of that depth"
        )
    return kinds.pop() if kinds else "uint8"


def check_band_reaches_boxes(records, boxes, low, high, dtype):
    """Refuse a fixed band ``[low, high]`` that holds no pixel inside (or on the
    edge of) any indicator box of the frames ``records``: no keypoint could be a
    sign, and the verifier could not be fitted.  The message names the band, the
    frames' pixel type and the range of the box pixels (a band of 8-bit grey
    levels on 14- or 16-bit counts is the usual cause).  Frames are read until one
    box pixel lies in the band (the first labelled frame, as a rule).

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import FrameSequence
    >>> X = FrameSequence.from_array(np.full((1, 20, 20), 9000, np.uint16))
    >>> check_band_reaches_boxes(X, [np.array([[4, 4, 5, 8.]])], 160, 190, "uint16")
    Traceback (most recent call last):
    ...
    ValueError: the fixed keypoint band [160, 190] (low, high) holds none of the pixels inside the indicator boxes y: those of the uint16 training frames lie in [9000, 9000]; ...
    """
    seen_lo, seen_hi = np.inf, -np.inf
    for i, (r, b) in enumerate(zip(records, boxes, strict=True)):
        if not len(b):
            continue
        image = check_image(r.image, where(r, i))
        h, w = image.shape[:2]
        for left, top, bw, bh in np.asarray(b, float)[:, :4]:
            # the pixels the box touches (a superset of the keypoints it holds)
            r0, c0 = max(int(np.floor(top)), 0), max(int(np.floor(left)), 0)
            r1, c1 = min(int(np.ceil(top + bh)) + 1, h), min(int(np.ceil(left + bw)) + 1, w)
            if r1 <= r0 or c1 <= c0:
                continue
            patch = image[r0:r1, c0:c1]
            if np.any((patch >= low) & (patch <= high)):
                return
            seen_lo = min(seen_lo, float(patch.min()))
            seen_hi = max(seen_hi, float(patch.max()))
    if not np.isfinite(seen_lo):  # no box in the frames: nothing to check
        return
    raise ValueError(
        f"the fixed keypoint band [{low:g}, {high:g}] (low, high) holds none of the "
        f"pixels inside the indicator boxes y: those of the {dtype} training frames "
        f"lie in [{seen_lo:g}, {seen_hi:g}]; the band is in the frames' own units "
        "(the paper's [160, 190] is in 8-bit grey levels): set low and high in "
        "these units, use band='learned', or the default detector "
        "(make_indicator_pipeline()), which learns its band at any bit depth"
    )
