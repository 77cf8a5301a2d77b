"""What stays wrong until it is mended: a status answer says it.

A bus-only alarm (:mod:`.fenced`, :mod:`.confirm`, a journal that cannot
be written) is published once, when its episode begins. An operator or a
tool that asks ``scheduler/status`` later must still hear it: the node's
engine knows nothing of the bus, so its status says ``ok``. While a
condition stands, a query's answer says ``degraded`` and names each one
in ``detail`` (and ``durable`` false while the journal cannot be
written). It ends when the cause does: a fence no higher than the
node's term, a standby that holds the state again, a journal written
again. A term mark (``term.json``) that could not be written at the
start of a term stands for the whole term.

Published statuses of a step keep the engine's word: they are journaled,
and replay reproduces them from the journal alone (these conditions are
not decisions and leave no record).
"""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING

import msgspec

if TYPE_CHECKING:
    from ..wire import messages

#: The conditions, in the order a status names them.
FENCE = "fence"
STANDBY_LEFT = "standby_left"
STANDBY_LATE = "standby_late"
JOURNAL = "journal"
TERM_MARK = "term_mark"
ORDER = (FENCE, JOURNAL, TERM_MARK, STANDBY_LEFT, STANDBY_LATE)

#: The most characters of one condition's detail in an answer.
MAX_DETAIL = 300


class Standing:
    """The standing conditions of a commanding node (thread-safe: the
    election thread sets the fence, the node's loop the others, queries
    read them on Zenoh's threads)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._held: dict[str, str] = {}

    def put(self, key: str, detail: str | None) -> bool:
        """Hold ``key`` with ``detail``, or end it (None); whether that
        changed anything."""
        with self._lock:
            before = self._held.get(key)
            if detail is None:
                self._held.pop(key, None)
            else:
                self._held[key] = detail[:MAX_DETAIL]
            return before != self._held.get(key)

    def held(self) -> dict[str, str]:
        """The conditions that stand now, in :data:`ORDER`."""
        with self._lock:
            return {k: self._held[k] for k in ORDER if k in self._held}

    def apply(self, status: messages.Status) -> messages.Status:
        """``status`` as a query answers it while conditions stand: state
        ``degraded`` (unless it says worse), each condition in ``detail``,
        ``durable`` false while the journal cannot be written."""
        held = self.held()
        if not held:
            return status
        said = "; ".join(f"{key}: {detail}" for key, detail in held.items())
        return msgspec.structs.replace(
            status,
            state="degraded" if status.state == "ok" else status.state,
            detail=f"{status.detail}; {said}" if status.detail else said,
            durable=status.durable and JOURNAL not in held,
        )
