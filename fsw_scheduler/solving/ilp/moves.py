"""The move term of the objective, for either formulation, in one place.

Under :class:`~fsw_scheduler.model.stability.Stability`, each task ``i``
previously planned at ``p`` adds ``W_move * (y_i - k_i)``, where ``y_i``
is "scheduled" and ``k_i`` is "starts at ``p``": 1 when the task is
scheduled elsewhere, 0 when it stays or is left out (the unscheduled
cost pays for that). ``k_i`` is linear in each formulation's own columns
(:meth:`Variables.starts_at`): with start-step variables it is
``z[i, p] - z[i, p - 1]``; the disjunctive model adds one binary and two
rows binding its start to ``p`` (see its variables). A ``p`` the task can
no longer start at gives ``k_i = 0``: any plan that schedules it moves it.
The unscheduled cost's weight grows with the move part
(:meth:`Stability.weights`), passed to the objective as ``big``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ...model.problem import Problem
    from ...model.stability import Stability
    from .program import Terms


def add_move_terms(
    terms: Terms, problem: Problem, variables: Any, stability: Stability
) -> None:
    """Add the move part of ``stability`` to the objective's ``terms``.

    Parameters
    ----------
    terms
        The objective's terms, changed in place.
    problem
        The problem modelled.
    variables
        Either formulation's variables: ``placeable``, ``scheduled`` and
        ``starts_at``.
    stability
        The previous starts and the price of a move.
    """
    _, per_move = stability.weights(problem)
    if not stability.active or not per_move:
        return
    for name, was in stability.kept(problem).items():
        if not variables.placeable(name):
            continue
        scheduled = variables.scheduled(name)
        terms[scheduled] = terms.get(scheduled, 0.0) + per_move
        for col, coef in variables.starts_at(name, was).items():
            terms[col] = terms.get(col, 0.0) - per_move * coef
