"""The lexicographic objective of the problem format, as one weighted sum.

``total = W * unscheduled_cost + delay_cost`` with
``W = 1 + sum_i delay_cost_i * horizon``: any one unit of unscheduled cost
outweighs every possible delay, so minimising the sum minimises the
unscheduled cost first. On the steps, a scheduled task's start offset is
``s_i - start = (l - start) * z[i, l] - sum_{t=e}^{l-1} z[i, t]`` for domain
``[e, l]``.

The unscheduled part, the same in both formulations, is
:func:`unscheduled_terms`: it is the one place that prices leaving tasks
and groups out.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ...model.plan import objective_weight
from .alternatives import heads

if TYPE_CHECKING:
    from ...model.problem import Problem
    from .alternatives import Columns
    from .program import Terms
    from .variables import Variables


def weight(problem: Problem) -> int:
    """W: the price of one unit of unscheduled cost."""
    return objective_weight(
        [task.delay_cost for task in problem.tasks], problem.horizon
    )


def unscheduled_terms(
    problem: Problem, columns: Columns, big: int | None = None
) -> tuple[Terms, float]:
    """``W * unscheduled_cost`` on the "scheduled" columns, and its constant.

    A task that is no group member costs ``W c_i (1 - y_i)``; a group
    costs ``W c_g (1 - sum of its viable options' heads)``
    (:mod:`.alternatives`), its members' own costs unused. A group none
    of whose tasks is in ``problem`` (another part's) costs nothing.
    ``big`` is ``W`` (default :func:`weight`; a move part makes it
    larger).
    """
    big = weight(problem) if big is None else big
    member = problem.groups.member
    present = {task.id for task in problem.tasks}
    terms: Terms = {}
    constant = 0.0
    for task in problem.tasks:
        if task.id in member:
            continue
        constant += big * task.schedule_cost
        if columns.placeable(task.id):
            column = columns.scheduled(task.id)
            # Tasks may share columns (:func:`.variables.shared_steps`).
            terms[column] = terms.get(column, 0.0) - big * task.schedule_cost
    for group in problem.alternatives:
        if not any(n in present for option in group.options for n in option):
            continue
        constant += big * group.schedule_cost
        for head in heads(problem, columns, group):
            if head is not None:
                terms[head] = terms.get(head, 0.0) - big * group.schedule_cost
    return terms, constant


def objective(
    problem: Problem, variables: Variables, big: int | None = None
) -> tuple[Terms, float]:
    """The objective's terms and its constant part (``big``: the weight of
    the unscheduled cost, default :func:`weight`; a move part makes it
    larger)."""
    terms, constant = unscheduled_terms(problem, variables, big)
    for task in problem.tasks:
        if not variables.placeable(task.id):
            continue
        steps = variables.steps[task.id]
        latest = variables.domains[task.id].latest
        scheduled = steps[-1]
        terms[scheduled] = terms.get(scheduled, 0.0) + task.delay_cost * (
            latest - problem.start
        )
        # Each step taken saves the delay up to the next one.
        for var, width in zip(
            steps[:-1], variables.widths(task.id), strict=True
        ):
            terms[var] = terms.get(var, 0.0) - task.delay_cost * width
    return terms, constant
