"""Predicted consumable profiles of a plan, and measured levels against them.

:func:`plan_profiles` turns a plan and the problem it solves into the
``scheduler/profiles`` message the node publishes with each plan: the
level every consumable is predicted to have at the start of each time
unit of the plan's horizon. :func:`level_check` sets a measured level
(``telemetry/resources/<name>``) beside the prediction of the plan in
force, which is what a plot of "battery, predicted against measured"
needs on one channel (``scheduler/levels``, journal only).

Pure: no bus, no clock, no solver. The levels follow the problem format
(initial level minus amount times the units run; negative amounts
generate; never above a consumable's capacity) through
:func:`fsw_scheduler.model.levels.resource_profiles`, the same function
the Gantt pictures draw.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import msgspec

from ..model.levels import resource_profiles
from ..model.plan import Plan

if TYPE_CHECKING:
    from ..model.problem import Problem
    from .messages import PlanMessage, ResourceLevel

__all__ = ["LevelCheck", "Profiles", "level_check", "plan_profiles"]


class Profiles(msgspec.Struct, frozen=True, omit_defaults=True):
    """``scheduler/profiles``: predicted consumable levels over a plan.

    Attributes
    ----------
    plan_id
        The plan these levels belong to (published right after it).
    issued_at
        Time unit at which the plan was adopted.
    times
        ``horizon_start .. horizon_end`` inclusive: the time units at
        whose start each level holds (one more than the horizon length:
        the last one is the level left at the end).
    levels
        Consumable name to its predicted level at the start of each unit
        of ``times`` (the first is the problem's initial level), with the
        plan's activities running as planned.
    capacities
        The capacity of each consumable that has one (its level never
        goes above it); absent when none has.
    """

    plan_id: int
    issued_at: int
    times: tuple[int, ...]
    levels: dict[str, tuple[float, ...]]
    capacities: dict[str, float] = {}

    def level_at(self, resource: str, at: int) -> float | None:
        """Predicted level of ``resource`` at the start of unit ``at``.

        None when the resource has no profile or ``at`` is outside
        ``times``.
        """
        values = self.levels.get(resource)
        if values is None or not self.times:
            return None
        idx = at - self.times[0]
        if not 0 <= idx < len(values):
            return None
        return values[idx]


class LevelCheck(msgspec.Struct, frozen=True, omit_defaults=True):
    """``scheduler/levels``: one measured level beside the plan's prediction.

    Attributes
    ----------
    resource
        Consumable name.
    at
        Time unit at whose start the level was measured.
    measured
        The reported level.
    predicted
        What the plan in force predicted then (None: no plan, or ``at``
        outside its horizon).
    plan_id
        The plan in force.
    departure
        ``measured - predicted`` (None without a prediction).
    """

    resource: str
    at: int
    measured: float
    predicted: float | None = None
    plan_id: int | None = None
    departure: float | None = None


def plan_profiles(problem: Problem, plan: PlanMessage) -> Profiles:
    """The predicted consumable levels of a plan over its horizon.

    Parameters
    ----------
    problem
        The problem the plan solves (the node's solve record holds it):
        its start, horizon, initial levels and task uses.
    plan
        The plan message; only its id, issue time and activities are read.

    Returns
    -------
    Profiles
        One level per consumable at the start of each unit
        ``problem.start .. problem.end``.

    Raises
    ------
    ValueError
        If an activity names a task that is not in the problem.
    """
    ends = resource_profiles(
        problem,
        Plan(
            status=plan.status,
            objective=plan.objective,
            activities=plan.activities,
        ),
    )
    levels = {
        name: (float(initial), *(float(v) for v in ends[name]))
        for name, initial in problem.resources.initial_levels.items()
    }
    return Profiles(
        plan_id=plan.plan_id,
        issued_at=plan.issued_at,
        times=tuple(range(problem.start, problem.end + 1)),
        levels=levels,
        capacities={
            name: float(v) for name, v in problem.resources.ceilings.items()
        },
    )


def level_check(profiles: Profiles | None, level: ResourceLevel) -> LevelCheck:
    """A measured level beside the prediction of the plan in force.

    Parameters
    ----------
    profiles
        The profiles of the plan in force (None before the first plan).
    level
        The measurement.

    Returns
    -------
    LevelCheck
        With ``predicted`` and ``departure`` when the plan covers it.
    """
    predicted = (
        None
        if profiles is None
        else profiles.level_at(level.resource, level.at)
    )
    return LevelCheck(
        resource=level.resource,
        at=level.at,
        measured=float(level.level),
        predicted=predicted,
        plan_id=None if profiles is None else profiles.plan_id,
        departure=(
            None if predicted is None else float(level.level) - predicted
        ),
    )
