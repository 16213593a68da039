"""The safety filter's per-cycle logic and the input guards every node uses (no ROS)."""

from .flood import cap_nearest
from .stamp_gate import StampGate, StampVerdict

__all__ = ["StampGate", "StampVerdict", "cap_nearest"]
