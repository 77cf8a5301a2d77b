"""Members of the election: who each scheduler is, and their order.

Each scheduler of a spacecraft declares ``scheduler/nodes/<rank>/
<started>/<node id>``; the election (:mod:`fsw_scheduler.bus.
redundancy`) orders them by rank, then start time, then id.
"""

from __future__ import annotations

import os
import socket
from typing import NamedTuple


class Member(NamedTuple):
    """One scheduler of the spacecraft, as its tokens name it."""

    rank: int
    started_ns: int
    node_id: str

    @property
    def chunks(self) -> str:
        """The key chunks ``<rank>/<started>/<node id>``."""
        return f"{self.rank}/{self.started_ns}/{self.node_id}"

    @classmethod
    def parse(cls, tail: str) -> Member | None:
        """From ``<rank>/<started>/<node id>``; None if malformed."""
        parts = tail.split("/")
        if len(parts) != 3:
            return None
        try:
            return cls(int(parts[0]), int(parts[1]), parts[2])
        except ValueError:
            return None


def order(member: Member) -> tuple[int, int, str]:
    """The election order: rank, then start time, then id (lowest wins)."""
    return (member.rank, member.started_ns, member.node_id)


def precedence(member: Member, term: int) -> tuple[int, int, int, str]:
    """Sort key of active members: the higher term first (it took over
    from the other, its state is the newer), then the better order."""
    return (-term, *order(member))


def beats(one: tuple[Member, int], other: tuple[Member, int]) -> bool:
    """Whether active ``one`` outranks ``other`` (member, term)."""
    return precedence(*one) < precedence(*other)


def default_node_id() -> str:
    """``<host>-<pid>``, made key-safe."""
    host = "".join(
        c if c.isalnum() or c in "_.-" else "-" for c in socket.gethostname()
    )
    return f"{host or 'node'}-{os.getpid()}"
