"""Two small nodes of a replay: one plays a recording, one collects what the filter did.

:class:`RecordingPlayer` publishes the recording's messages (serialized bytes, stamps as
recorded) when the replay's sim time reaches theirs: sim time advances ``rate`` times the
wall clock from the first message, and ``/clock`` is among the played topics, so the pipeline's
nodes (on sim time) see the recorded clock. :class:`FilterCollector` keeps every
``/c3bf/state`` (status, reference and filtered command per cycle).
"""

from __future__ import annotations

import time

import numpy as np
from rclpy.node import Node

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.nodes import ros_common
from safe_legged_c3bf.replay.kpis import FilterCycles
from safe_legged_c3bf.replay.recording import Recording

#: Wall s between the player's checks for due messages.
PLAY_PERIOD = 0.002


class RecordingPlayer(Node):
    """Publishes a recording's messages in log order, paced by ``rate`` x the wall clock."""

    def __init__(self, recording: Recording, rate: float = 1.0, **kwargs) -> None:
        """``rate``: sim seconds played per wall second (> 0); ``kwargs`` go to rclpy's Node."""
        super().__init__("replay_player", **kwargs)
        if not rate > 0:
            raise ValueError(f"rate must be positive, got {rate}")
        self._messages = recording.messages
        self._rate = float(rate)
        names = sorted({name for _, name, _ in self._messages})
        self._pubs = {name: ros_common.publisher(self, topics.by_name(name)) for name in names}
        self._next = 0
        self._wall0: float | None = None
        self.sim_time = self._messages[0][0] if self._messages else 0.0
        self._timer = self.create_timer(PLAY_PERIOD, self._play)

    @property
    def finished(self) -> bool:
        """True once every message has been published."""
        return self._next >= len(self._messages)

    def _play(self) -> None:
        now = time.monotonic()
        if self._wall0 is None:
            self._wall0 = now
        start = self._messages[0][0] if self._messages else 0.0
        target = start + self._rate * (now - self._wall0)
        msgs = self._messages
        while self._next < len(msgs) and msgs[self._next][0] <= target:
            t, name, data = msgs[self._next]
            self._pubs[name].publish(data)
            self.sim_time = t
            self._next += 1


class FilterCollector(Node):
    """Keeps the safety filter's state of every cycle."""

    def __init__(self, **kwargs) -> None:
        """Subscribe to ``/c3bf/state``; ``kwargs`` go to rclpy's Node."""
        super().__init__("replay_collector", **kwargs)
        self._rows: list[tuple] = []
        ros_common.subscription(self, topics.FILTER_STATE, self._on_state)

    def _on_state(self, msg) -> None:  # noqa: ANN001 - SafetyFilterState
        r, f = msg.reference, msg.filtered
        self._rows.append((ros_common.from_time_msg(msg.header.stamp), msg.status,
                           r.linear.x, r.linear.y, r.angular.z, f.linear.x, f.linear.y,
                           f.angular.z))

    def cycles(self) -> FilterCycles:
        """The collected cycles, in time order."""
        rows = np.array(sorted(self._rows), float).reshape(-1, 8)
        return FilterCycles(rows[:, 0], rows[:, 1].astype(int), rows[:, 2:5], rows[:, 5:8])
