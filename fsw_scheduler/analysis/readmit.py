"""A better start plan where list scheduling left out too much (pure).

List scheduling places tasks in an order fixed by a priority rule, and a
task that finds no room when its turn comes is left out; an early long
task can thus keep out several later ones that would together be worth
more. When the kept-set bound (:mod:`.bounds`) says a plan may leave out
less than the start plan does, :func:`readmitted` tries each left-out
task at the head of the order (the others keep theirs), list-schedules
again, and keeps the first plan that is better and that the checker
accepts; it sweeps again from a kept improvement, at most
:data:`MAX_PASSES` times and :data:`MAX_TRIES` list schedules in all,
so its cost is bounded in schedules, not in seconds, and its answer is
the same on every machine.

Measured on the 15-task ``all`` problems of the campaign (every resource
kind; seeds 3 and 4, paper and broad generators): it fired on 2 of 28;
on seed 3's b15-all-1 it found the optimum in 17 schedules (0.26 s;
425,194 to 298,911) where the start plan left out 10 tasks, and the
solve took 4.8 s instead of 18.8 s; on the other it changed nothing.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .check import improves
from .greedy import order_of, plan_in_order
from .proofs import reach

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..model.plan import Plan
    from ..model.problem import Problem
    from .domains import Domain

#: Sweeps over the left-out tasks (a sweep follows only an improvement).
MAX_PASSES = 3
#: List schedules in all: each costs about 1 ms for 15 tasks without a
#: consumable and up to about 16 ms with a battery over H = 336.
MAX_TRIES = 30


def readmitted(
    problem: Problem,
    plan: Plan,
    domains: dict[str, Domain],
    *,
    stop: Callable[[], bool] | None = None,
) -> Plan:
    """``plan``, or a better one with a left-out task scheduled first.

    Parameters
    ----------
    problem
        A validated problem.
    plan
        A valid plan of ``problem`` with its objective.
    domains
        The problem's start domains.
    stop
        True when time is up (the caller's deadline; this module reads no
        clock): the plan found so far is returned.

    Returns
    -------
    Plan
        ``plan`` itself when nothing better was found; else a plan of
        status ``feasible`` that the checker accepts, with a lower
        objective.
    """
    if plan.objective is None or not plan.unscheduled:
        return plan
    # The plan's own order first: the list schedule of it is the plan
    # or one that starts no task later.
    order = order_of(problem, plan)
    earlier: dict[str, list[str]] = {}
    for prec in problem.precedences:
        earlier.setdefault(prec.after, []).append(prec.before)
    best = plan
    tries = 0
    for _ in range(MAX_PASSES):
        improved = False
        kept = {a.task for a in best.activities}
        for name in [n for n in order if n not in kept]:
            if tries >= MAX_TRIES or (stop is not None and stop()):
                return best
            tries += 1
            # The task goes first with what must come before it: a list
            # schedule places a task only once its predecessors are, so
            # alone at the head it would still wait for them where they
            # are (broad seed 98's b15-multiple-0: a task whose window
            # closes before its predecessor's place in the order ends).
            before = reach({name}, earlier) - {name}
            head = [*(n for n in order if n in before), name]
            trial = [*head, *(n for n in order if n not in head)]
            found = plan_in_order(problem, trial, domains)
            if found is not None and improves(problem, found, best):
                best, order, improved = found, trial, True
        if not improved:
            break
    return best
