"""The goal ledger: every goal id answered once, across restarts.

A sender that hears nothing re-sends; a standby that takes over has the
ledger in the state it adopts; a node that resumes has it in its journal.
So a goal id is accepted at most once per spacecraft:

* the same goal again (same content, whatever the JSON spelling) gets its
  first verdict again and changes nothing;
* other content under an id already queued or accepted is rejected,
  naming the id;
* a goal accepted long ago (its tasks may have flown) is never executed
  again while its id is in the ledger: the ids of the last
  ``max_goal_ids`` accepted goals (1,024 by default) and of every queued
  one. A rejected goal leaves no entry: its id may be used again, for a
  corrected goal.
"""

from __future__ import annotations

import hashlib
from typing import TYPE_CHECKING

import msgspec

from .snapshot import GoalRecord

if TYPE_CHECKING:
    from ..model.goal import Goal

_encoder = msgspec.json.Encoder()


def goal_digest(goal: Goal) -> str:
    """The content of ``goal``, named: the first 128 bits of the SHA-256
    of its canonical encoding (decoded first, so key order and spacing do
    not matter); half the ledger's size, still never equal by chance."""
    return hashlib.sha256(_encoder.encode(goal)).hexdigest()[:32]


class GoalLedger:
    """Goal id -> :class:`~fsw_scheduler.engine.snapshot.GoalRecord`.

    Parameters
    ----------
    records
        From a snapshot (oldest first).
    limit
        Accepted goals remembered (``EngineConfig.max_goal_ids``).
    """

    def __init__(
        self, records: dict[str, GoalRecord] | None = None, limit: int = 1024
    ) -> None:
        self.records = dict(records or {})
        self.limit = limit

    def seen(self, goal_id: str) -> GoalRecord | None:
        """The entry of ``goal_id`` (None: a new id)."""
        return self.records.get(goal_id)

    def queue(
        self,
        goal_id: str,
        digest: str,
        at: int,
        term: int,
        tasks: tuple[str, ...] = (),
    ) -> None:
        """``goal_id`` (of ``tasks``) was accepted for processing."""
        self.records[goal_id] = GoalRecord(digest, "queued", at, term, tasks)

    def accept(self, goal_id: str) -> None:
        """The goal is in a plan: ``accepted`` for good (see the limit)."""
        record = self.records.pop(goal_id, None)
        if record is not None:
            self.records[goal_id] = msgspec.structs.replace(
                record, verdict="accepted"
            )
        self._prune()

    def forget(self, goal_id: str) -> None:
        """The goal was rejected after all: its id is free again."""
        record = self.records.get(goal_id)
        if record is not None and record.verdict == "queued":
            del self.records[goal_id]

    def _prune(self) -> None:
        accepted = [
            g for g, r in self.records.items() if r.verdict == "accepted"
        ]
        for goal_id in accepted[: max(0, len(accepted) - self.limit)]:
            del self.records[goal_id]
