"""A solution read back as a plan, the same for either formulation."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ...model.plan import Activity, Objective, Plan
from .objective import weight

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    from ...model.plan import SolveStatus
    from ...model.problem import Problem


def decode_plan(
    problem: Problem,
    start_of: Callable[[str, Sequence[float]], int | None],
    status: SolveStatus,
    values: Sequence[float],
) -> Plan:
    """The plan of solution ``values``, read by a model's ``start_of``.

    The objective is recomputed from the starts, not taken from the solver.
    """
    activities, unscheduled = [], []
    delay = unscheduled_cost = 0
    for task in problem.tasks:
        start = start_of(task.id, values)
        if start is None:
            unscheduled.append(task.id)
            unscheduled_cost += task.schedule_cost
            continue
        activities.append(Activity(task.id, start, start + task.length))
        delay += task.delay_cost * (start - problem.start)
    activities.sort(key=lambda a: (a.start, a.task))
    total = weight(problem) * unscheduled_cost + delay
    return Plan(
        status=status,
        objective=Objective(unscheduled_cost, delay, total),
        activities=tuple(activities),
        unscheduled=tuple(unscheduled),
    )
