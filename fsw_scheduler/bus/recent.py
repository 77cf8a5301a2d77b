"""The newest keys only: a memory of ids that cannot grow without bound.

The node remembers ids it has answered (the inbox's accepted goals, the
goals a standby said it holds, the sources of goals awaiting a verdict)
for as long as a sender could plausibly send them again, and no longer:
a flood of fresh ids pushes the oldest out instead of the memory growing.
"""

from __future__ import annotations

from collections import OrderedDict
from typing import Generic, TypeVar

V = TypeVar("V")


class Recent(Generic[V]):
    """The newest ``limit`` keys put, each with its value.

    Not locked: each owner calls it under its own lock, or from one
    thread.

    Parameters
    ----------
    limit
        Keys kept; putting one more forgets the one put longest ago.
    """

    def __init__(self, limit: int) -> None:
        if limit < 1:
            raise ValueError(f"limit {limit} < 1")
        self.limit = limit
        self._items: OrderedDict[str, V] = OrderedDict()

    def put(self, key: str, value: V) -> None:
        """Remember ``key`` (again: it becomes the newest)."""
        self._items[key] = value
        self._items.move_to_end(key)
        while len(self._items) > self.limit:
            self._items.popitem(last=False)

    def pop(self, key: str) -> V | None:
        """Forget ``key``; its value (None: not remembered)."""
        return self._items.pop(key, None)

    def __contains__(self, key: object) -> bool:
        return key in self._items

    def __len__(self) -> int:
        return len(self._items)
