"""Mean of a measured vector over a sliding time window (the anti-windup's velocity).

A walking robot's base velocity swings within every step (the biped's torso sways sideways at
up to 0.3 m/s and yaws at up to 0.7 rad/s while it walks straight, measured); its mean over a
gait cycle is what the robot actually does. Units are the caller's (s for time).
"""

from __future__ import annotations

from collections import deque

import numpy as np

__all__ = ["MovingMean"]


class MovingMean:
    """Mean of the samples added within the last ``window`` s (``window`` 0: the latest).

    A non-finite sample is not added (the caller rejects that cycle's state anyway); a jump
    back in time restarts the window.
    """

    def __init__(self, window: float) -> None:
        """Average over ``window`` [s] (>= 0)."""
        if not window >= 0.0:
            raise ValueError(f"window must be >= 0 s, got {window!r}")
        self.window = float(window)
        self._samples: deque[tuple[float, np.ndarray]] = deque()
        self._sum: np.ndarray | None = None

    def add(self, t: float, value: np.ndarray) -> np.ndarray:
        """Add the sample ``value`` taken at ``t`` [s]; the mean over the window (a new array).

        A non-finite ``value`` is returned as it is, not added; so is every ``value`` when
        ``window`` is 0 (nothing kept: the filter's cycle pays nothing for it).
        """
        if self.window <= 0.0:
            self._samples.clear()
            self._sum = None
            return value
        value = np.array(value, dtype=float)
        if not np.isfinite(value).all():
            return value
        if self._sum is None or self._samples[-1][0] > t:
            self._samples.clear()
            self._sum = np.zeros_like(value)
        self._samples.append((t, value))
        self._sum += value
        while self._samples[0][0] < t - self.window:
            self._sum -= self._samples.popleft()[1]
        return self._sum / len(self._samples)
