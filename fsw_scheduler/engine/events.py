"""What the engine takes in (events) and gives out (commands).

Events are what the shell saw: a tick of the bus clock, a goal, an
execution report, a level, a rejected input, a stalled clock, the end of
a solve or of an explanation. Commands are what the shell must do:
publish a message, start a solve or an explanation, write a log line.
Both are plain frozen Structs, never encoded: the journal records the
bus bytes they came from and went to.
"""

from __future__ import annotations

from typing import Literal

import msgspec

from ..errors import FieldIssue
from ..model.goal import Goal
from ..model.plan import Blocker, Plan
from ..model.problem import Problem
from ..wire.messages import (
    ActivityReport,
    Facts,
    ResourceForecast,
    ResourceLevel,
)


class Tick(msgspec.Struct, frozen=True, tag=True):
    """Time advanced to ``now`` (bus clock or the node's own clock)."""

    now: int


class GoalArrived(msgspec.Struct, frozen=True, tag=True):
    """A decoded goal from ``scheduler/goals``."""

    goal: Goal


class ReportArrived(msgspec.Struct, frozen=True, tag=True):
    """An execution report from ``telemetry/activities/<task>``."""

    report: ActivityReport


class LevelArrived(msgspec.Struct, frozen=True, tag=True):
    """A consumable level from ``telemetry/resources/<name>``."""

    level: ResourceLevel


class ForecastArrived(msgspec.Struct, frozen=True, tag=True):
    """A profile forecast from ``telemetry/resources/<name>/forecast``."""

    forecast: ResourceForecast


class InputRejected(msgspec.Struct, frozen=True, tag=True):
    """An input the shell could not decode; reported, never fatal."""

    key: str
    kind: str
    errors: tuple[FieldIssue, ...]
    goal_id: str | None = None


class ClockStalled(msgspec.Struct, frozen=True, tag=True):
    """No bus clock message for ``seconds`` (wall clock) since ``last``."""

    seconds: float
    last: int | None = None


class NodePaused(msgspec.Struct, frozen=True, tag=True):
    """This node's process did not run for ``seconds`` since unit
    ``last``; the next clock jump is its own pause, not the bus's."""

    seconds: float
    last: int | None = None


class TermBegan(msgspec.Struct, frozen=True, tag=True):
    """This node commands from now on, in command term ``term``.

    The shell decides the term (higher than any it has seen) and journals
    it before it commands; the engine stamps it on every plan, dispatch
    and status it publishes from then on.
    """

    term: int
    node_id: str = ""
    reason: str = ""
    lost: str = ""
    unverified: str = ""


class FactsArrived(msgspec.Struct, frozen=True, tag=True):
    """A commander that stood down handed over what it commanded."""

    facts: Facts


class Explained(msgspec.Struct, frozen=True, tag=True):
    """Why tasks of plan ``plan_id`` (from solve ``solve_id``) are out."""

    solve_id: int
    plan_id: int
    why: tuple[Blocker, ...] = ()


class SolveDone(msgspec.Struct, frozen=True, tag=True):
    """The result of a :class:`StartSolve`."""

    solve_id: int
    plan: Plan


class SolveFailed(msgspec.Struct, frozen=True, tag=True):
    """A :class:`StartSolve` raised (solver missing, crashed)."""

    solve_id: int
    error: str


Event = (
    Tick
    | GoalArrived
    | ReportArrived
    | LevelArrived
    | ForecastArrived
    | InputRejected
    | ClockStalled
    | NodePaused
    | Explained
    | TermBegan
    | FactsArrived
    | SolveDone
    | SolveFailed
)


class Publish(msgspec.Struct, frozen=True):
    """Publish ``message`` on ``fsw/<sc>/<suffix>``."""

    suffix: str
    message: msgspec.Struct


class StartSolve(msgspec.Struct, frozen=True):
    """Solve ``problem`` (warm-started from ``warm``); reply with SolveDone.

    ``explain`` asks for the reasons of left-out tasks whatever the node's
    settings (the shedding solve: an alarm must say why). ``previous``
    holds the starts of the activities planned before this replan (what a
    move term prices, see the ``stability`` setting).
    """

    solve_id: int
    trigger: str
    problem: Problem
    warm: Plan | None = None
    explain: bool = False
    previous: dict[str, int] = {}


class StartExplain(msgspec.Struct, frozen=True):
    """Explain why tasks of the plan just published are out.

    Runs after the plan is out, so it never delays it; the shell answers
    with :class:`Explained`.
    """

    solve_id: int
    plan_id: int
    problem: Problem
    plan: Plan


class Log(msgspec.Struct, frozen=True):
    """A line for the component's log."""

    level: Literal["debug", "info", "warning", "error"]
    text: str


Command = Publish | StartSolve | StartExplain | Log


def input_message(event: Event | None) -> msgspec.Struct | None:
    """The wire message a report or level event carries, else None."""
    if isinstance(event, ReportArrived):
        return event.report
    return event.level if isinstance(event, LevelArrived) else None
