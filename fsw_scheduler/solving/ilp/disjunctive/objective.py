"""The lexicographic objective on starts and "scheduled" binaries.

The same weighted sum as the time-indexed model
(:mod:`fsw_scheduler.solving.ilp.objective`),
``W * unscheduled_cost + delay_cost``, written for task ``i`` with domain
``[e, l]`` as ``W c_i (1 - y_i) + d_i (e - start) y_i + d_i (s_i - e)``:
a scheduled task costs ``d_i (s_i - start)``, a left-out one ``W c_i``
once its start rests at ``e`` (where any optimum puts it, no row binding
the start of a left-out task). So a plan has the same value in both
models, and the optima agree.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..objective import unscheduled_terms

if TYPE_CHECKING:
    from ....model.problem import Problem
    from ..program import Terms
    from .variables import Variables


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
        earliest = variables.domains[task.id].earliest
        column = variables.scheduled(task.id)
        terms[column] = terms.get(column, 0.0) + task.delay_cost * (
            earliest - problem.start
        )
        terms[variables.start(task.id)] = float(task.delay_cost)
        constant -= task.delay_cost * earliest
    return terms, constant
