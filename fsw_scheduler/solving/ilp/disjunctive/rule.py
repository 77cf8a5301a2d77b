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
  only): its LP is tight there and the part is small.

Multiple resources where three or more users exceed the capacity only
together get load rows at each start as well (see
:mod:`.constraints`); measured on the 15-task multiple classes without a
MIP start (CBC, 20 s limit), the disjunctive model proved all 14
optimal in 17.2 s (broad) and 19.5 s (paper) in all, the time-indexed
model 12 of 14 in 39.4 s and 26.5 s, one at the limit without a plan.
It is slower on some easy ones (0.4 -> 2.1 s at worst), faster on the
hard ones.
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
        ``disjunctive`` when the part uses a binary or multiple resource
        and no consumable; ``time-indexed`` otherwise.
    """
    kinds = used_kinds(problem, domains)
    if "consumable" in kinds or not kinds:
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
