"""What-if: the verdict and plan a goal would get, from a copy of the state.

An operator asks what a goal would do before sending it.
:func:`what_if` answers from a copy of the engine (restored from its
snapshot): the goal arrives there, every solve that copy asks for is run
with the caller's solve (the same settings and limits as a goal), and the
verdict and plan it ends with are the answer. The engine the copy was
taken from never sees it: its plan, ``plan_id``, goal ledger and
lifecycle stay as they were, so a later real goal with the same id is new
to it. The same snapshot, goal and solves give the same answer, which is
how ``replay --verify`` checks a journaled what-if. Pure: the solver and
the explanation are functions passed in; no bus, no clock.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import msgspec

from ..analysis.moved import why_moved
from ..errors import FieldIssue
from ..model.plan import Plan
from ..replan.commit import moved_activities
from ..wire import topics
from ..wire.messages import (
    PlanMessage,
    Reason,
    SolveRecord,
    Status,
    WhatIfAnswer,
    WhatIfPlan,
)
from .core import Engine
from .events import (
    Command,
    GoalArrived,
    Publish,
    SolveDone,
    StartExplain,
    StartSolve,
)

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..model.goal import Goal
    from ..model.plan import Blocker, Moved
    from ..model.problem import Problem
    from .config import EngineConfig
    from .snapshot import EngineSnapshot

__all__ = ["MAX_SOLVES", "WhatIf", "rejected", "what_if"]

#: Solves one what-if may make: the goal's, the solve without the commit
#: window's pins, and any change queued before the goal. Far above what a
#: goal needs; it bounds the answer's time.
MAX_SOLVES = 6

_VERDICTS = ("goal_accepted", "goal_rejected")


class WhatIf(msgspec.Struct, frozen=True):
    """A what-if's answer and the solve records it made (for the journal)."""

    answer: WhatIfAnswer
    solves: tuple[SolveRecord, ...] = ()


def rejected(
    goal_id: str | None, reasons: tuple[FieldIssue, ...] | list[FieldIssue]
) -> WhatIfAnswer:
    """The answer for a goal refused before any state is read (it does
    not decode, or is not a goal)."""
    return WhatIfAnswer(
        verdict="goal_rejected", reasons=tuple(reasons), goal_id=goal_id
    )


def what_if(
    snapshot: EngineSnapshot,
    config: EngineConfig,
    goal: Goal,
    solve: Callable[[StartSolve], Plan],
    explain: Callable[[Problem, Plan], tuple[Blocker, ...]] | None = None,
) -> WhatIf:
    """What sending ``goal`` now would do to the engine ``snapshot`` holds.

    Parameters
    ----------
    snapshot
        The engine's state (:meth:`Engine.snapshot`); it is not changed.
    config
        The engine's settings.
    goal
        The goal, decoded.
    solve
        Runs a solve as a real goal's would be run.
    explain
        Why tasks of a plan are out, when the engine explains a plan only
        after publishing it (``explain_after_plan``); None: not said.

    Returns
    -------
    WhatIf
        The answer, and the solve records of the copy.
    """
    engine = Engine.restore(config, snapshot)
    now = engine.now or 0
    out = engine.step(GoalArrived(goal), now)
    commands = list(out)
    for _ in range(MAX_SOLVES):
        if _verdict(commands, goal.goal_id) is not None:
            break
        starts = [c for c in out if isinstance(c, StartSolve)]
        if not starts:
            break
        command = starts[0]
        out = engine.step(SolveDone(command.solve_id, solve(command)), now)
        commands += out
    solves = tuple(
        c.message
        for c in commands
        if isinstance(c, Publish) and isinstance(c.message, SolveRecord)
    )
    verdict = _verdict(commands, goal.goal_id)
    if verdict is None:
        return WhatIf(
            rejected(
                goal.goal_id,
                [FieldIssue("", "no verdict within the what-if's solves")],
            ),
            solves,
        )
    if verdict.event == "goal_rejected":
        return WhatIf(rejected(goal.goal_id, verdict.errors), solves)
    message = _last_plan(commands)
    assert message is not None  # accepted: a plan carries the goal
    why = message.why
    asked = [c for c in commands if isinstance(c, StartExplain)]
    if explain is not None and asked and not why:
        why = explain(asked[-1].problem, asked[-1].plan)
    adopted = engine.schedule
    assert adopted is not None  # a plan was adopted
    moved = _moved(snapshot, goal, message, adopted.problem)
    reasons = {b.task: Reason(b.cause, b.detail) for b in why}
    reasons.update({m.task: Reason("moved", m.why) for m in moved if m.why})
    fields = {
        name: getattr(message, name)
        for name in PlanMessage.__struct_fields__
        if name != "plan_id"
    }
    fields["why"] = why
    return WhatIf(
        WhatIfAnswer(
            verdict="goal_accepted",
            plan=WhatIfPlan(**fields),
            moved=moved,
            unscheduled=message.unscheduled,
            why=reasons,
            goal_id=goal.goal_id,
        ),
        solves,
    )


def _verdict(commands: list[Command], goal_id: str) -> Status | None:
    for command in commands:
        message = getattr(command, "message", None)
        if (
            isinstance(message, Status)
            and message.goal_id == goal_id
            and message.event in _VERDICTS
        ):
            return message
    return None


def _last_plan(commands: list[Command]) -> PlanMessage | None:
    plans = [
        c.message
        for c in commands
        if isinstance(c, Publish)
        and c.suffix == topics.PLAN
        and isinstance(c.message, PlanMessage)
    ]
    return plans[-1] if plans else None


def _moved(
    snapshot: EngineSnapshot,
    goal: Goal,
    message: PlanMessage,
    problem: Problem,
) -> tuple[Moved, ...]:
    """What the plan moves: its own ``moved`` where plans report it, else
    the same comparison, made here (an operator asking wants to know),
    with why each moved (:func:`why_moved` on ``problem``)."""
    if message.moved is not msgspec.UNSET:
        assert isinstance(message.moved, tuple)
        return message.moved
    schedule = snapshot.schedule
    if schedule is None:
        return ()
    gone = {r.task for r in message.removed} | set(schedule.continuing)
    gone |= {t.id for t in goal.tasks}
    previous = {
        a.task: a.start
        for a in schedule.plan.activities
        if snapshot.lifecycle.get(a.task, "planned") == "planned"
        and a.task not in gone
    }
    shown = Plan(message.status, message.objective, message.activities)
    reasons = why_moved(problem, shown, previous)
    return moved_activities(previous, shown, reasons)
