"""Region of interest (paper section III-C)."""

from __future__ import annotations

import numpy as np

__all__ = ["roi_mask"]


def roi_mask(depth, height, *, min_height=0.1, max_height=2.0):
    """Mask of the returns inside the region of interest.

    The region of interest is ``min_height < height < max_height`` in front of the
    sensor (``depth > 0``): the road (``|height| < 0.1`` m after tilt compensation) and
    everything taller than a vehicle are dropped.  No-return beams must already be NaN
    (see :func:`no_return`); NaN never passes.

    Parameters
    ----------
    depth, height : ndarray
        Restored coordinates (m), same shape.
    min_height, max_height : float, default=0.1, 2.0
        The height band (m), exclusive.

    Returns
    -------
    mask : ndarray of bool, same shape

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street import roi_mask
    >>> roi_mask(np.array([3.0, 3.0, 3.0, np.nan, -1.0]),
    ...          np.array([0.05, 1.0, 2.5, 1.0, 1.0])).tolist()
    [False, True, False, False, False]
    """
    depth = np.asarray(depth, dtype=np.float64)
    height = np.asarray(height, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        return (height > min_height) & (height < max_height) & (depth > 0)
