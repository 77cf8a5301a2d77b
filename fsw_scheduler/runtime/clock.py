"""Time sources. The engine only ever sees integer time units.

:class:`UnitClock` turns a monotonic clock (injected, so tests and replay
can drive it) into time units; the bus clock needs no class: each
``fsw/<sc>/clock`` message is the time.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Callable


class UnitClock:
    """Time units from a monotonic seconds clock.

    Parameters
    ----------
    seconds
        A monotonic clock in seconds (e.g. :func:`time.monotonic`).
    unit
        Seconds per time unit.
    start
        Time unit at the moment of construction.
    """

    def __init__(
        self, seconds: Callable[[], float], unit: float, start: int = 0
    ) -> None:
        if unit <= 0:
            raise ValueError("unit must be > 0")
        self._seconds = seconds
        self._unit = unit
        self._origin = seconds()
        self._start = start

    def now(self) -> int:
        """The current time unit."""
        elapsed = self._seconds() - self._origin
        return self._start + math.floor(elapsed / self._unit)

    def seconds_to_next(self) -> float:
        """Seconds until the next unit begins."""
        elapsed = self._seconds() - self._origin
        units = math.floor(elapsed / self._unit) + 1
        return max(units * self._unit - elapsed, 0.0)
