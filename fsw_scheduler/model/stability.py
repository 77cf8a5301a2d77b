"""Stability: what a replan pays for moving what was already planned.

A replan re-solves its window from scratch; the previous plan is only a
start. :class:`Stability` adds a price for each previously planned
activity whose start changes (one the new plan leaves out is not moved:
the unscheduled cost pays for it), in one of two ways:

* ``moves``: ``total = W' * unscheduled + delay + move_cost * moves``
  with ``W' = 1 + sum(d_i) * H + move_cost * N`` (``N`` previously
  planned tasks in the problem): the move part sits with the delay part,
  and one unit of unscheduled cost still outweighs both.
* ``lexicographic``: plans compare by unscheduled cost, then moves, then
  delay: ``total = W2 * unscheduled + W1 * moves + delay`` with
  ``W1 = 1 + sum(d_i) * H`` (one move outweighs any delay) and
  ``W2 = W1 * (N + 1)`` (one unit of unscheduled cost outweighs them).

``off`` is the paper's objective. The solver (both formulations), the
start plans, the checker and the CP-SAT baseline all read the objective
from here. Pure: no solver, no bus, no clock.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

import msgspec

from .plan import Objective, Plan, objective_weight

if TYPE_CHECKING:
    from collections.abc import Mapping

    from .problem import Problem

Mode = Literal["off", "moves", "lexicographic"]

__all__ = ["Mode", "Stability", "rescored"]


class Stability(msgspec.Struct, frozen=True, omit_defaults=True):
    """The previous starts a solve may move, and the price of a move.

    Attributes
    ----------
    previous
        Task id to the start it had in the plan replaced (planned, not
        yet dispatched).
    mode
        ``off``, ``moves`` or ``lexicographic`` (see the module
        docstring).
    move_cost
        The price of one moved activity under ``moves``.
    """

    previous: dict[str, int] = {}
    mode: Mode = "off"
    move_cost: int = 5

    @property
    def active(self) -> bool:
        """Whether the objective has a move part (the mode is not off)."""
        return self.mode != "off"

    def kept(self, problem: Problem) -> dict[str, int]:
        """The previous starts of ``problem``'s tasks, in problem order."""
        return {
            task.id: self.previous[task.id]
            for task in problem.tasks
            if task.id in self.previous
        }

    def weights(self, problem: Problem) -> tuple[int, int]:
        """``(W_unscheduled, W_move)`` of ``problem``; the delay weighs 1.

        Off: the paper's ``W`` and no move part.
        """
        base = objective_weight(
            [task.delay_cost for task in problem.tasks], problem.horizon
        )
        count = len(self.kept(problem))
        if self.mode == "moves":
            return base + self.move_cost * count, self.move_cost
        if self.mode == "lexicographic":
            return base * (count + 1), base
        return base, 0

    def moves(self, problem: Problem, starts: Mapping[str, int]) -> int:
        """Previously planned tasks of ``problem`` scheduled elsewhere in
        ``starts`` (task id to start; a task left out is not moved)."""
        return sum(
            1
            for name, was in self.kept(problem).items()
            if name in starts and starts[name] != was
        )

    def objective(
        self,
        problem: Problem,
        unscheduled_cost: int,
        delay_cost: int,
        starts: Mapping[str, int],
    ) -> Objective:
        """The objective of a plan with these parts and starts."""
        big, per_move = self.weights(problem)
        if not self.active:
            return Objective(
                unscheduled_cost,
                delay_cost,
                big * unscheduled_cost + delay_cost,
            )
        moves = self.moves(problem, starts)
        return Objective(
            unscheduled_cost,
            delay_cost,
            big * unscheduled_cost + per_move * moves + delay_cost,
            moves=moves,
            move_cost=self.move_cost
            if self.mode == "moves"
            else msgspec.UNSET,
        )


def rescored(problem: Problem, plan: Plan, stability: Stability) -> Plan:
    """``plan`` with its objective recomputed under ``stability`` (a plan
    without an objective, or stability off, is returned as it is)."""
    if plan.objective is None or not stability.active:
        return plan
    objective = stability.objective(
        problem,
        plan.objective.unscheduled_cost,
        plan.objective.delay_cost,
        plan.starts(),
    )
    return plan.replace(objective=objective)
