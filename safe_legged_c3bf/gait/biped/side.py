"""Which leg: the biped's left and right sides (REP-103: +y is left of base_link)."""

from __future__ import annotations

import enum


class Side(enum.StrEnum):
    """A leg of the biped; the value is the prefix of its joint names ('l_knee', 'r_knee')."""

    LEFT = "l"
    RIGHT = "r"

    @property
    def other(self) -> Side:
        """The opposite leg."""
        return _OTHER[self]

    @property
    def sign(self) -> float:
        """+1 for the left leg, -1 for the right leg (the side of base_link's +y axis)."""
        return _SIGN[self]

    @property
    def joints(self) -> slice:
        """Slice of this leg's six entries in the controller's 12-joint vectors (left leg first)."""
        return _JOINTS[self]


#: both legs in the controller's joint order
SIDES = (Side.LEFT, Side.RIGHT)
_OTHER = {Side.LEFT: Side.RIGHT, Side.RIGHT: Side.LEFT}
_SIGN = {Side.LEFT: 1.0, Side.RIGHT: -1.0}
_JOINTS = {Side.LEFT: slice(0, 6), Side.RIGHT: slice(6, 12)}
