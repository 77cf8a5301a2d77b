"""The engine's whole state as data, for resume and hot standby.

A node journals every input and output; :class:`EngineSnapshot` is the
state those inputs built, written at the start of each journal file (so a
file is enough to resume from, whatever came before it) and, on a bus with
a standby, published before each step's outputs. Pure data: msgspec
Structs of the pure model, no behaviour.
"""

from __future__ import annotations

from typing import Literal

import msgspec

from ..model.goal import Goal
from ..model.plan import Plan
from ..model.problem import Problem
from ..replan.schedule import Replan, Schedule
from ..wire.messages import (
    ActivityReport,
    Counters,
    PlanMessage,
    ResourceForecast,
    SolveSummary,
)

#: Bumped when a field's meaning changes; new fields get defaults instead.
SNAPSHOT_VERSION = 1

Lifecycle = Literal[
    "planned",
    "dispatched",
    "running",
    "completed",
    "failed",
    "preempted",
    "obsolete",
    "missed",
    "cancelling",
    "cancelled",
    "unknown",
]
Health = Literal["ok", "degraded", "error"]


class PendingSolve(msgspec.Struct, frozen=True):
    """A solve in flight, with everything needed to ask for it again.

    ``stage`` is ``plan`` for an ordinary solve; when a replan the world
    forced (not a goal) is infeasible, ``shed`` finds which mandatory
    tasks to keep, then ``degraded`` solves without the others (see
    :mod:`fsw_scheduler.shed`); ``infeasible`` keeps the plan that
    started it. ``previous`` holds the starts of the activities planned
    and not dispatched when the replan started (what the new plan may
    move), ``pins`` the starts the commit window fixed in ``problem``,
    and ``released`` the pins a solve without them gave up because they
    left no plan (see :mod:`fsw_scheduler.replan.commit`).
    """

    solve_id: int
    trigger: str
    problem: Problem
    replan: Replan | None
    goals: tuple[str, ...]
    started_at: int
    dispatches_at_start: int
    stage: Literal["plan", "shed", "degraded"] = "plan"
    infeasible: Plan | None = None
    warm: Plan | None = None
    explain: bool = False
    previous: dict[str, int] = {}
    pins: dict[str, int] = {}
    released: dict[str, int] = {}


class QueuedChange(msgspec.Struct, frozen=True):
    """A queued trigger: a goal, a failure or measured levels."""

    kind: Literal["goal", "failure", "levels"]
    goal: Goal | None = None
    task: str = ""
    at: int = 0
    levels: dict[str, float] = {}
    trigger: str = ""


class GoalRecord(msgspec.Struct, frozen=True, omit_defaults=True):
    """The ledger's entry for one goal id: what was decided, on what.

    ``digest`` names the goal's content (SHA-256 of its canonical
    encoding), ``verdict`` is ``queued`` (accepted for processing,
    waiting for its solve) or ``accepted`` (in a plan), ``at`` the time
    unit it arrived at and ``term`` the command term that took it.
    ``tasks`` are the ids of its tasks: a goal of which something was
    commanded is a fact a heal carries over, not a goal to send again.
    """

    digest: str
    verdict: Literal["queued", "accepted"]
    at: int = 0
    term: int = 0
    tasks: tuple[str, ...] = ()


class EngineSnapshot(msgspec.Struct, frozen=True, omit_defaults=True):
    """Everything :class:`~fsw_scheduler.engine.Engine` holds.

    ``Engine.restore(config, snapshot)`` gives an engine that behaves
    exactly like the one ``Engine.snapshot()`` was taken from: the same
    events then give the same commands. Attributes mirror the engine's.
    """

    initial: Problem
    unsolved_initial: Problem | None = None
    schedule: Schedule | None = None
    plan_id: int | None = None
    now: int | None = None
    solve_id: int = 0
    pending: PendingSolve | None = None
    queue: tuple[QueuedChange, ...] = ()
    dispatched: dict[str, int] = {}
    lifecycle: dict[str, Lifecycle] = {}
    reported: dict[str, Lifecycle] = {}
    sent: dict[str, tuple[int, int]] = {}
    cancelling: dict[str, int] = {}
    numbers: dict[str, int] = {}
    held: tuple[ActivityReport, ...] = ()
    counters: Counters = Counters()
    last_solve: SolveSummary | None = None
    inputs: int = 0
    health: Health = "ok"
    health_detail: str = ""
    plan_message: PlanMessage | None = None
    term: int = 0
    ledger: dict[str, GoalRecord] = {}
    forecasts: tuple[ResourceForecast, ...] = ()
    version: int = SNAPSHOT_VERSION
    paused_at: int | None = None
