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
* for multiple resources where some three or more users exceed the
  capacity only together: the pairwise order binaries would not see them
  (:func:`pairwise_exact`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

if TYPE_CHECKING:
    from collections.abc import Mapping

    from ....analysis.domains import Domain
    from ....model.problem import Problem

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
    resources = problem.resources
    shared = False
    amounts: dict[str, list[float]] = {n: [] for n in resources.multiple}
    for task in problem.tasks:
        if domains[task.id].empty:
            continue
        for name, amount in task.uses.items():
            if not amount:
                continue
            kind = resources.kind_of(name)
            if kind == "consumable":
                return "time-indexed"
            shared = True
            if kind == "multiple":
                amounts[name].append(amount)
    if not shared:
        return "time-indexed"
    for name, used in amounts.items():
        if not pairwise_exact(used, resources.multiple[name]):
            return "time-indexed"
    return "disjunctive"
