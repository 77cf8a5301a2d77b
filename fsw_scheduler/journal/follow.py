"""Following a journal record by record: an engine kept by its changes.

A node's state is its journal: a snapshot, then every input and solve
result in processing order. :class:`Follower` steps an engine through
such records one at a time, as a resume does (no solver run: each solve's
result is in its solve record, handed over where the original arrived).
A resume reads them from the files (:func:`~fsw_scheduler.journal.replay.
rebuild`); a hot standby gets them from the commander as they are
journaled (``scheduler/changes``), so that it keeps the commander's state
without being sent the whole of it with every step.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import msgspec

from ..engine.core import Engine
from ..engine.events import SolveDone, StartSolve
from ..runtime.inputs import InputDecoder
from ..runtime.policy import engine_config
from ..wire import messages
from ..wire import topics as keys

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..engine.snapshot import EngineSnapshot
    from ..model.plan import Plan
    from ..runtime.config import NodeConfig

#: Output kinds: journaled, but not what an engine steps on.
OUTPUT_KINDS = frozenset(
    {"plan", "dispatch", "status", "profiles", "level_check", "log"}
)
#: Journaled kinds a follower skips: outputs, settings, states, sources.
SKIPPED_KINDS = OUTPUT_KINDS | {"snapshot", "node_info", "input_source"}


def needed(topics: keys.Topics, topic: str) -> bool:
    """Whether a follower steps on a journal record of ``topic`` (what a
    commander sends its standby: inputs and solve results only)."""
    return topics.schema_kind(topic) not in SKIPPED_KINDS


class Follower:
    """An engine stepped through journal records (see the module).

    Parameters
    ----------
    config
        The node settings the records were made with.
    snapshot
        Where the records start (None: the initial ``problem``).
    problem
        The initial problem, without a snapshot.
    solve_fn
        Run for a solve record without its result (older journals).

    Attributes
    ----------
    engine
        The engine, after the last record applied.
    now
        The last time unit seen.
    last_tick
        The last time unit a clock record carried (None: none yet).
    records
        Records applied (snapshots and settings not counted).
    solves_rerun
        Solve results missing from their records, computed again.
    """

    def __init__(
        self,
        config: NodeConfig,
        snapshot: EngineSnapshot | None = None,
        problem: object = None,
        solve_fn: Callable[[NodeConfig, StartSolve], Plan] | None = None,
    ) -> None:
        self.config = config
        self.topics = keys.Topics(config.spacecraft)
        self.engine = (
            Engine.restore(engine_config(config), snapshot)
            if snapshot is not None
            else Engine(engine_config(config), problem)  # type: ignore[arg-type]
        )
        self.decoder = InputDecoder(
            self.topics, config.clock, config.max_clock_step
        )
        self.now = (snapshot.now or 0) if snapshot is not None else 0
        self.last_tick = snapshot.now if snapshot is not None else None
        self.records = 0
        self.solves_rerun = 0
        self._solve_fn = solve_fn
        self._requested: dict[int, StartSolve] = {}
        pending = self.engine.pending_solve()
        if pending is not None:
            self._requested[pending.solve_id] = pending

    def apply(self, topic: str, payload: bytes) -> None:
        """Step the engine on one journal record (outputs, settings and
        snapshots are skipped: they are what the steps said or started
        from)."""
        kind = self.topics.schema_kind(topic)
        if kind in ("snapshot", "node_info"):
            return
        self.records += 1
        if kind == "what_if":
            self.engine.note_what_if()  # the only trace a what-if leaves
            return
        if kind == "solve_record":
            record = msgspec.json.decode(payload, type=messages.SolveRecord)
            command = self._requested.pop(record.solve_id, None)
            if command is None:
                return
            plan = record.result
            if plan is None:
                from ..runtime.policy import run_solve

                plan = (self._solve_fn or run_solve)(self.config, command)
                self.solves_rerun += 1
            self._note(
                self.engine.step(SolveDone(record.solve_id, plan), self.now)
            )
            return
        if kind in OUTPUT_KINDS:
            return
        event = self.decoder.event(topic, payload)
        if event is None:
            return
        if hasattr(event, "now"):
            self.now = max(self.now, event.now)
            self.last_tick = self.now
        self._note(self.engine.step(event, self.now))

    def _note(self, commands: list) -> None:
        for command in commands:
            if isinstance(command, StartSolve):
                self._requested[command.solve_id] = command
