"""The lexicographic objective of the problem format, as one weighted sum.

``total = W * unscheduled_cost + delay_cost`` with
``W = 1 + sum_i delay_cost_i * horizon``: any one unit of unscheduled cost
outweighs every possible delay, so minimising the sum minimises the
unscheduled cost first. On the steps, a scheduled task's start offset is
``s_i - start = (l - start) * z[i, l] - sum_{t=e}^{l-1} z[i, t]`` for domain
``[e, l]``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ...model.plan import objective_weight

if TYPE_CHECKING:
    from ...model.problem import Problem
    from .program import Terms
    from .variables import Variables


def weight(problem: Problem) -> int:
    """W: the price of one unit of unscheduled cost."""
    return objective_weight(
        [task.delay_cost for task in problem.tasks], problem.horizon
    )


def objective(
    problem: Problem, variables: Variables, big: int | None = None
) -> tuple[Terms, float]:
    """The objective's terms and its constant part (``big``: the weight of
    the unscheduled cost, default :func:`weight`; a move part makes it
    larger)."""
    big = weight(problem) if big is None else big
    terms: Terms = {}
    constant = 0.0
    for task in problem.tasks:
        constant += big * task.schedule_cost
        if not variables.placeable(task.id):
            continue
        steps = variables.steps[task.id]
        latest = variables.domains[task.id].latest
        scheduled = steps[-1]
        # Tasks may share columns (:func:`.variables.shared_steps`).
        terms[scheduled] = terms.get(scheduled, 0.0) + (
            -big * task.schedule_cost
            + task.delay_cost * (latest - problem.start)
        )
        for var in steps[:-1]:
            terms[var] = terms.get(var, 0.0) - task.delay_cost
    return terms, constant
