"""Bus-side test helpers: liveliness tokens and matching declarations."""

from __future__ import annotations

import queue
from typing import TYPE_CHECKING, cast

if TYPE_CHECKING:
    import zenoh

#: The liveliness token of the test node's scheduler.
ALIVE = "fsw/sat1/scheduler/alive"


class Liveliness:
    """Liveliness changes of a key, received through a queue."""

    def __init__(self, session: zenoh.Session, key: str = ALIVE) -> None:
        self.changes: queue.Queue[zenoh.SampleKind] = queue.Queue()
        self._sub = session.liveliness().declare_subscriber(
            key, lambda s: self.changes.put(s.kind), history=True
        )

    def expect(self, kind: zenoh.SampleKind, timeout: float = 10.0) -> None:
        """Wait for the next change and check it is ``kind``."""
        assert self.changes.get(timeout=timeout) == kind

    def close(self) -> None:
        """Undeclare the subscriber."""
        self._sub.undeclare()


def matching(entity: zenoh.Publisher | zenoh.Querier) -> bool:
    """Whether a publisher (querier) meets a subscriber (queryable) yet.

    The zenoh stub types ``matching_status`` as a bool; zenoh 1.x returns a
    ``MatchingStatus``, whose ``matching`` says it.
    """
    return cast("zenoh.MatchingStatus", entity.matching_status).matching
