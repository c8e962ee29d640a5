"""Defaults of the side-of-road cue shared by the positioner, ``position_tour`` and
the command line (no import: the command line's parser reads them)."""

__all__ = []

#: Least drift (in standard errors) that reads a side
#: (:func:`~tunnelsense.positioning.observed_side`).
SIDE_MIN_T = 3.0

#: Default probability that a side read surely is the other wall (``side_error``
#: of :class:`~tunnelsense.positioning.TunnelPositioner`, ``position_tour`` and
#: ``position --side-error``).
SIDE_ERROR = 0.05
