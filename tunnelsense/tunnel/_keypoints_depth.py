"""Bit depth of FIR frames: the pixel type a keypoint sampler is fitted on, and
the refusal of frames of another depth (in ``transform``, and before a detector
serves a source)."""

from __future__ import annotations

import numpy as np

from tunnelsense._payload import where
from tunnelsense.exceptions import InputFormatError

__all__ = ["check_served_depth"]


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
        f"{where(record, index)}: a {image.dtype} frame, "
        f"but {told}. A 16-bit camera's raw counts are not 8-bit levels times 257 "
        "(the camera's gain decides); fit the detector on frames of this depth, or "
        "convert the frames to the fitted depth yourself"
    )


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
        f"on {fitted} frames (its intensity band is in {fitted} grey levels). A "
        "16-bit camera's raw counts are not 8-bit levels times 257 (the camera's "
        "gain decides); fit the detector on frames of this depth, or convert the "
        "frames to the fitted depth yourself"
    )


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
