"""Limits of the input formats: key-safe ids, time values and costs.

The numbers every format shares, and the id grammar with the helpers that
name a value or a dictionary key in a field path. The types of
:mod:`.problem` declare these limits (so the JSON Schemas carry them);
:mod:`.validation` and :mod:`.codec` word their findings with them. Pure:
the standard library only.
"""

from __future__ import annotations

import re
from typing import Annotated

import msgspec

#: Range of a task's schedule cost (the cost of leaving it out; 0 means
#: mandatory).
MIN_COST, MAX_COST = 0, 5
#: Range of a task's delay cost (per time unit of starting late).
MIN_DELAY_COST, MAX_DELAY_COST = 1, 5

#: Characters allowed in task ids, goal ids, resource names and spacecraft
#: ids. They become Zenoh key chunks (``scheduler/dispatch/<task>``): ``/``
#: would split the key, ``* $ ? #`` are wildcards or refused by Zenoh, and
#: a leading ``@`` marks Zenoh's reserved chunks.
ID_CHARS = "A-Za-z0-9_.-"
#: Longest id accepted. Zenoh fails to send keys of about 64 KiB (a Rust
#: panic in ``put``); ids stay far below that, with room for the prefix.
MAX_ID_LENGTH = 64
_ID_RE = re.compile(f"[{ID_CHARS}]+")
_BAD_ID_CHAR = re.compile(f"[^{ID_CHARS}]")

#: Largest absolute time value (units) in a problem, goal or clock: far
#: beyond any mission, and exact in the solver's double precision.
MAX_TIME = 2**31 - 1

#: Longest horizon (units) a problem or a node plans over: a day at one
#: unit a second (86,400) fits. Past it the time limit no longer bounds
#: the answer: the start plan books a consumable unit by unit (at
#: 1,000,000 units a 1 s limit was answered after 2.6 s, 0.75 s at
#: 100,000), the time-indexed model has a column per unit and start, and
#: 10,000,000 units did not fit in 3 GB.
MAX_HORIZON = 100_000
#: Why, in the words of a rejection.
HORIZON_WHY = (
    "past it the time limit no longer bounds the answer (some passes go "
    "over every unit); plan in coarser units or over a shorter horizon"
)


def shown(value: str, limit: int = 40) -> str:
    """``value`` quoted for a message, cut to ``limit`` characters."""
    if len(value) <= limit:
        return repr(value)
    return f"{value[:limit]!r}... ({len(value)} characters)"


def id_issue(value: str) -> str | None:
    """Why ``value`` is not a key-safe id (None when it is one).

    The grammar: 1 to :data:`MAX_ID_LENGTH` characters out of
    ``[A-Za-z0-9_.-]``.
    """
    if not value:
        return "must not be empty"
    if len(value) > MAX_ID_LENGTH:
        return (
            f"is {len(value)} characters long; ids are at most {MAX_ID_LENGTH}"
        )
    if _ID_RE.fullmatch(value) is None:
        bad = "".join(dict.fromkeys(_BAD_ID_CHAR.findall(value)))
        return (
            f"{shown(value)} has characters outside [{ID_CHARS}] "
            f"({bad!r}); ids are used as bus key chunks"
        )
    return None


def key_path(path: str, key: str) -> str:
    """``path.key`` for a dictionary key (cut when it is not an id)."""
    if id_issue(key) is None:
        return f"{path}.{key}"
    return f"{path}[{shown(key, 20)}]"


#: The most one moved activity may cost under ``stability = "moves"``:
#: above it the move part would dwarf the delays it is weighed against.
MAX_MOVE_COST = 1000

#: Units of the mission clock, zero allowed (a window, a gain: 0 is off).
Span = Annotated[int, msgspec.Meta(ge=0, le=MAX_TIME)]
#: The price of one moved activity.
MoveCost = Annotated[int, msgspec.Meta(ge=1, le=MAX_MOVE_COST)]
