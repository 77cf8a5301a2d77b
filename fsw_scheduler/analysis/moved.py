"""Why a replan moved an activity that was already planned.

For each activity a new plan starts elsewhere than the plan it replaces,
:func:`why_moved` puts the moved activities back at their old starts in
the new plan (together: a chain that moved as one is judged as one) and
asks the independent checker what that breaks for each: the old start is
no longer allowed (its window, the horizon, a precedence settled by what
ran), it would overlap what now holds a resource, a precedence with a task the
new plan placed would break, or nothing breaks and the move only lowers
the objective (delay saved for its price, under ``stability = moves``, or
no price at all). Cheap: one check, no solve. Pure: no
solver, no bus, no clock.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from ..model.plan import Activity
from .check import check_plan
from .domains import start_domains

if TYPE_CHECKING:
    from collections.abc import Mapping

    from ..model.plan import Plan
    from ..model.problem import Problem

__all__ = ["why_moved"]


def why_moved(
    problem: Problem, plan: Plan, previous: Mapping[str, int]
) -> dict[str, str]:
    """Plain words for each activity ``plan`` moved from ``previous``.

    Parameters
    ----------
    problem
        The problem ``plan`` solves.
    plan
        The new plan.
    previous
        Task id to its start in the plan replaced.

    Returns
    -------
    dict
        Task id to why it is not at its old start, for each task of
        ``plan`` scheduled at another start than in ``previous``.
    """
    tasks = {task.id: task for task in problem.tasks}
    moved = [
        a
        for a in plan.activities
        if a.task in previous and previous[a.task] != a.start
    ]
    if not moved:
        return {}
    domains = start_domains(problem)
    # Every moved activity back where it was at once: a chain that moved
    # together is judged together (one back alone would only collide
    # with its own partner, moved too).
    back = {
        a.task: Activity(
            a.task, previous[a.task], previous[a.task] + (tasks[a.task].length)
        )
        for a in moved
    }
    trial = plan.replace(
        objective=None,
        activities=tuple(back.get(a.task, a) for a in plan.activities),
    )
    broken = [
        v
        for v in check_plan(problem, trial).violations
        if v.rule != "objective"
    ]
    out = {}
    for activity in moved:
        was = previous[activity.task]
        domain = domains[activity.task]
        if not domain.earliest <= was <= domain.latest:
            allowed = (
                f"[{domain.earliest}, {domain.latest}]"
                if not domain.empty
                else "none"
            )
            out[activity.task] = (
                f"its old start {was} is no longer allowed (starts "
                f"{allowed} by its window, the horizon and its precedences)"
            )
            continue
        named = [
            v
            for v in broken
            if v.task == activity.task or _names(v.detail, activity.task)
        ]
        if named:
            out[activity.task] = (
                f"back at {was} it would break {named[0].rule}: "
                f"{named[0].detail}"
            )
        else:
            out[activity.task] = (
                f"{was} is still free; starting at {activity.start} "
                "costs less: the delay it saves outweighs any price of a "
                "move"
            )
    return out


def _names(text: str, task: str) -> bool:
    """Whether ``text`` names ``task`` as a whole word."""

    return (
        re.search(rf"(?<![\w.-]){re.escape(task)}(?![\w.-])", text) is not None
    )
