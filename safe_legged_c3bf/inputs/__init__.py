"""Untrusted-input guards shared by the nodes (ROS-free): time stamps and flood caps."""

from .flood import cap_nearest
from .stamp_gate import StampGate, StampVerdict

__all__ = ["StampGate", "StampVerdict", "cap_nearest"]
