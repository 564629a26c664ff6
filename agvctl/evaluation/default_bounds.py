"""The bounds of the default gate that do not depend on the vehicle, and the record of a default bound
(:func:`~agvctl.evaluation.limits.default_limits` gives the gate; its module notes and record 0040 the reasons)."""

from __future__ import annotations

from dataclasses import dataclass

from agvctl.config import document_fields

__all__ = ["DefaultLimit"]


@document_fields
@dataclass(frozen=True)
class DefaultLimit:
    """A bound of the default gate and why it is what it is."""

    bound: float
    """The bound, in the unit of the limit's name."""
    reason: str
    """Why, in one line (``"ends within 1 cm of the path's end"``)."""


CORRIDOR_M = 0.10
"""The default corridor about the path: a healthy run stays within 10 cm of it."""
CORRIDOR_BEYOND_START_M = 0.05
"""A run that starts further off than the corridor may stray this much beyond its start's own offset."""


FINAL_HEADING_DEG = 0.5
"""The default final heading error: a healthy run ends within 0.25° of the path's final heading; 0.5° turns a
point a metre ahead of the axle 9 mm, as far as the final position's 1 cm."""
DOCK_CORRIDOR_M = 0.03
"""The default distance across the path's final line once the vehicle is there (the dock): a vehicle arrives within
2 cm of the end, so a healthy one is at most that far beside the line when the count starts, and a dock backing up
along it and coming in again only brings it closer; a further centimetre, the final position's, leaves room for
what remains of the approach."""
LATENESS_S = 0.5
"""The default lateness: a healthy run arrives within 2 cm of the path's end by the time the path ends (the
reference governor's catch-up makes up a start's lag), so half a second late is a delay of its own."""
REST_CURRENT_A = 0.1
"""The default current held at rest, the median over a second of both wheels resting: healthy wheel loops release
their wheels at rest (0 A)."""
