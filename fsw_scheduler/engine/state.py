"""The engine's state as one record: what a snapshot holds, outside the queue.

:class:`EngineState` is the data the engine's parts share: the schedule
being flown, the plan and its identity, time, the term, the goal ledger,
the dispatch lifecycle and the counters. It holds no behaviour beyond
reading the clock and counting; the parts that change it
(:class:`~fsw_scheduler.engine.execution.Execution`,
:class:`~fsw_scheduler.engine.solves.Replanner`,
:class:`~fsw_scheduler.engine.verdicts.Verdicts` and the handlers of
:class:`~fsw_scheduler.engine.core.Engine`) each own their rules. The solve
queue keeps its own state (:class:`~fsw_scheduler.engine.queue.SolveQueue`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import msgspec

from ..wire.messages import (
    Counters,
    PlanMessage,
    ResourceForecast,
    SolveSummary,
)
from .dispatch import Dispatches
from .ledger import GoalLedger

if TYPE_CHECKING:
    from ..model.problem import Problem
    from ..replan.schedule import Schedule
    from ..wire.messages import ActivityReport
    from .config import EngineConfig
    from .snapshot import EngineSnapshot, Health


#: The start of the health detail while the bus clock is stalled; only a
#: tick clears it (a plan adopted meanwhile does not).
CLOCK_STALLED = "bus clock stalled"


class EngineState:
    """The shared state of an engine (see the module docstring).

    Parameters
    ----------
    config
        Engine settings.
    initial
        The initial problem.

    Attributes
    ----------
    schedule
        The schedule being flown (None before the first plan).
    plan_id, now, term
        Identity of the current plan, the latest time unit seen, and the
        command term stamped on every plan, dispatch and status so that
        receivers fence a stale commander.
    unsolved_initial
        The initial problem until its first solve starts.
    ledger, dispatches
        The goal ids seen and the lifecycle of every activity.
    counters, last_solve, inputs
        What the status reports: totals, the last solve, events seen.
    health, health_detail
        The status ``state`` and why.
    plan_message
        The current plan as published.
    held
        Execution reports whose ``at`` lay ahead of the clock (within
        ``report_ahead``), in arrival order, until the clock reaches them.
    paused_at
        The unit at which this node said it had paused (a stall under
        its lease), until the next tick: what that tick's jump passed
        over is dispatched late, not missed.
    forecasts
        Forecasts that arrived while a solve was in flight: taken into the
        plan it gives (:mod:`.forecasts`).
    """

    def __init__(self, config: EngineConfig, initial: Problem) -> None:
        self.config = config
        self.initial = initial
        self.unsolved_initial: Problem | None = initial
        self.schedule: Schedule | None = None
        self.plan_id: int | None = None
        self.now: int | None = None
        self.term = 0
        self.ledger = GoalLedger(limit=config.max_goal_ids)
        self.dispatches = Dispatches()
        self.counters = Counters()
        self.last_solve: SolveSummary | None = None
        self.inputs = 0
        self.health: Health = "ok"
        self.health_detail = ""
        self.plan_message: PlanMessage | None = None
        self.held: list[ActivityReport] = []
        self.paused_at: int | None = None
        #: Forecasts taken while a solve was in flight, for its plan.
        self.forecasts: list[ResourceForecast] = []

    @classmethod
    def restore(
        cls, config: EngineConfig, snapshot: EngineSnapshot
    ) -> EngineState:
        """The state ``snapshot`` holds (its queue aside)."""
        state = cls(config, snapshot.initial)
        state.unsolved_initial = snapshot.unsolved_initial
        state.schedule = snapshot.schedule
        state.plan_id = snapshot.plan_id
        state.now = snapshot.now
        state.term = snapshot.term
        state.ledger = GoalLedger(snapshot.ledger, config.max_goal_ids)
        state.forecasts = list(snapshot.forecasts)
        state.dispatches = Dispatches(
            lifecycle=snapshot.lifecycle,
            dispatched=snapshot.dispatched,
            sent=snapshot.sent,
            reported=snapshot.reported,
            cancelling=snapshot.cancelling,
            numbers=snapshot.numbers,
        )
        state.held = list(snapshot.held)
        state.counters = snapshot.counters
        state.last_solve = snapshot.last_solve
        state.inputs = snapshot.inputs
        state.health = snapshot.health
        state.health_detail = snapshot.health_detail
        state.plan_message = snapshot.plan_message
        state.paused_at = snapshot.paused_at
        return state

    def clock(self) -> int:
        """The current time unit (0 before the first event)."""
        return self.now if self.now is not None else 0

    def count(self, **changes: int) -> None:
        """Set counters (``Counters`` field names) to new values."""
        self.counters = msgspec.structs.replace(self.counters, **changes)

    @property
    def clock_stalled(self) -> bool:
        """Whether the health says the bus clock stopped (until a tick)."""
        return self.health_detail.startswith(CLOCK_STALLED)

    def set_health(self, state: Health, detail: str) -> None:
        """Set the status ``state`` and the reason it gives."""
        self.health, self.health_detail = state, detail
