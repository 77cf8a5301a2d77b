"""Which formulation to build for a part: disjunctive or time-indexed.

:func:`pick` picks the disjunctive model of
:mod:`fsw_scheduler.solving.ilp.disjunctive` where the time-indexed model is
weak: parts whose hard part is sharing binary or multiple resources. The
time-indexed model's root LP there is large and degenerate (n = 15,
binary: 0.59 of 0.72 s in a 4,924 x 2,669 LP whose MIP start was already
optimal), while the disjunctive model has a few columns per task and one
pair of order binaries per pair of users that may collide. The
time-indexed model is kept

* for consumables: levels over time are what its rows express, and the
  disjunctive model has none;
* for parts without a binary or multiple resource in use (precedences
  only): its LP is tight there and the part is small;
* for multiple resources where three or more users exceed the capacity
  only together (not :func:`pairwise_exact`). The disjunctive model
  handles them with load rows at each start (see :mod:`.constraints`)
  and, without a MIP start (20 s), proved all 14 of the 15-task multiple
  problems (broad and paper) in 36.7 s against 12 of 14 in 65.9 s; but
  through :func:`~fsw_scheduler.solving.solve.solve` (greedy MIP start,
  cost caps) the time-indexed model was faster on 5 of the 7 broad ones
  (``tools/bench --generator broad --solvers cbc,cpsat --only
  b15-multiple --time-limit 10``: median 0.19 s against 1.30 s, 14.8x
  against 74.3x CP-SAT, 6/7 proved either way), so it is kept there.

For binary resources the same command (``--only b15-binary``) gave a
median of 2.07 s, 100.5x CP-SAT and 5/7 proved for the time-indexed
model, 0.34 s, 28.4x and 7/7 for the disjunctive one.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

if TYPE_CHECKING:
    from collections.abc import Mapping

    from ....analysis.domains import Domain
    from ....model.problem import Problem, ResourceKind

Formulation = Literal["time-indexed", "disjunctive"]
FORMULATIONS: tuple[Formulation, ...] = ("time-indexed", "disjunctive")


def pairwise_exact(amounts: list[float], capacity: float) -> bool:
    """True if every set of users over ``capacity`` has a pair over it.

    Sorted ascending, a set of users is pairwise within the capacity iff
    its two largest are; the heaviest such set whose largest member is
    ``a_k`` is ``a_k`` with every earlier ``a_j`` such that
    ``a_j + a_k <= capacity``. Time is ignored, which can only say
    False where the pairs would do.
    """
    ordered = sorted(a for a in amounts if a > 0)
    for k, largest in enumerate(ordered):
        if largest > capacity:
            break  # alone over it: such a user is never scheduled
        beside = [a for a in ordered[:k] if a + largest <= capacity]
        if sum(beside) + largest > capacity:
            return False
    return True


def pick(problem: Problem, domains: Mapping[str, Domain]) -> Formulation:
    """The formulation to build for ``problem`` (one independent part).

    Parameters
    ----------
    problem
        The part's problem.
    domains
        Its start domains; tasks that cannot be placed are not counted.

    Returns
    -------
    str
        ``disjunctive`` when the part uses a binary or multiple resource,
        no consumable, and every multiple resource is
        :func:`pairwise_exact`; ``time-indexed`` otherwise.
    """
    kinds = used_kinds(problem, domains)
    if "consumable" in kinds or not kinds:
        return "time-indexed"
    for name, capacity in problem.resources.multiple.items():
        amounts = [
            task.uses.get(name, 0)
            for task in problem.tasks
            if not domains[task.id].empty
        ]
        if not pairwise_exact(amounts, capacity):
            return "time-indexed"
    return "disjunctive"


def used_kinds(
    problem: Problem, domains: Mapping[str, Domain]
) -> set[ResourceKind]:
    """The resource kinds some placeable task of ``problem`` uses."""
    kinds: set[ResourceKind] = set()
    for task in problem.tasks:
        if domains[task.id].empty:
            continue
        for name, amount in task.uses.items():
            kind = problem.resources.kind_of(name)
            if amount and kind is not None:
                kinds.add(kind)
    return kinds
