"""Forecasts of resource profiles: taken in, and judged against the plan.

A forecast (``telemetry/resources/<name>/forecast``) replaces a resource's
profile from its ``at`` on: availability windows, capacity steps or an
external rate (:func:`fsw_scheduler.model.profiles.with_forecast`). The
engine takes it into the running problem at once (:func:`take`); it
replans (trigger ``forecast``) only when the plan it flies breaks under
the new profile (:func:`broken_by`, :func:`judge`). A forecast that
arrives while a solve is in flight is kept and taken into the plan that
solve gives, which is judged the same way (:func:`after_adoption`). Part
of the engine's functional core: no bus, no clock, no solver.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import msgspec

from ..analysis.check import check_plan
from ..model.forecast import forecast_kind, with_forecast
from ..model.mission_rules import forecast_issues
from .events import Log
from .snapshot import QueuedChange

if TYPE_CHECKING:
    from ..analysis.check import Violation
    from ..errors import FieldIssue
    from ..model.plan import Plan
    from ..model.problem import Problem
    from ..replan.schedule import Schedule
    from ..wire.messages import ResourceForecast
    from .events import Command
    from .queue import SolveQueue
    from .state import EngineState
    from .verdicts import Verdicts

__all__ = [
    "after_adoption",
    "broken_by",
    "forecast_problem",
    "issues",
    "judge",
    "take",
    "with_forecasts",
]

#: The rules a new profile can break.
_RESOURCE_RULES = frozenset({"binary", "multiple", "consumable"})


def issues(problem: Problem, forecast: ResourceForecast) -> list[FieldIssue]:
    """Why ``forecast`` cannot be taken into ``problem`` (empty: it can)."""
    return forecast_issues(
        problem.resources,
        forecast.resource,
        forecast.at,
        dict(forecast.fields),
    )


def forecast_problem(problem: Problem, forecast: ResourceForecast) -> Problem:
    """``problem`` with the forecast's profile from its ``at`` on."""
    kind = forecast_kind(problem.resources, forecast.resource)
    assert kind is not None  # checked by :func:`issues`
    values = forecast.fields[kind] or ()
    return problem.replace(
        resources=with_forecast(
            problem.resources, forecast.resource, forecast.at, values
        )
    )


def with_forecasts(
    schedule: Schedule, forecasts: list[ResourceForecast]
) -> Schedule:
    """``schedule`` with ``forecasts`` taken into its problem, in order."""
    problem = schedule.problem
    for forecast in forecasts:
        if not issues(problem, forecast):
            problem = forecast_problem(problem, forecast)
    return msgspec.structs.replace(schedule, problem=problem)


def broken_by(before: Problem, after: Problem, plan: Plan) -> list[Violation]:
    """Resource violations of ``plan`` under ``after`` it had not before.

    A plan that already broke a rule (an execution that ran long) is not
    blamed on the forecast: only what the new profile adds counts.
    """
    old = {
        (v.rule, v.time)
        for v in check_plan(before, plan).violations
        if v.rule in _RESOURCE_RULES
    }
    return [
        v
        for v in check_plan(after, plan).violations
        if v.rule in _RESOURCE_RULES and (v.rule, v.time) not in old
    ]


def take(
    state: EngineState,
    queue: SolveQueue,
    verdicts: Verdicts,
    forecast: ResourceForecast,
    out: list[Command],
) -> None:
    """Take a forecast in (``input_rejected`` with its reasons when it
    cannot be), and judge the plan flown under it."""
    schedule = state.schedule
    problem = schedule.problem if schedule else state.unsolved_initial
    if problem is None:
        return
    found = issues(problem, forecast)
    if found:
        key = f"telemetry/resources/{forecast.resource}/forecast"
        verdicts.reject_input(key, "resource_forecast", found, out)
        return
    if schedule is None:
        state.unsolved_initial = forecast_problem(problem, forecast)
        return
    state.schedule = with_forecasts(schedule, [forecast])
    if queue.busy:
        # The plan in the making is judged when it comes.
        state.forecasts.append(forecast)
        return
    judge(state, queue, schedule.problem, out)


def after_adoption(
    state: EngineState, queue: SolveQueue, out: list[Command]
) -> None:
    """Take the forecasts that came during the solve into the schedule
    just adopted, and judge its plan under them."""
    if not state.forecasts or state.schedule is None:
        return
    before = state.schedule.problem
    state.schedule = with_forecasts(state.schedule, state.forecasts)
    state.forecasts.clear()
    judge(state, queue, before, out)


def judge(
    state: EngineState,
    queue: SolveQueue,
    before: Problem,
    out: list[Command],
) -> None:
    """Queue a replan (trigger ``forecast``) if the plan flown breaks
    under the current profiles where it did not under ``before``'s."""
    schedule = state.schedule
    assert schedule is not None
    broken = broken_by(before, schedule.problem, schedule.plan)
    if not broken:
        out.append(Log("info", "forecast taken; the plan still holds"))
        return
    first = broken[0]
    out.append(
        Log("info", f"forecast breaks the plan: [{first.rule}] {first.detail}")
    )
    queue.add_once(
        QueuedChange("levels", at=state.clock(), trigger="forecast")
    )
