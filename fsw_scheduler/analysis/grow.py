"""Kept sets grown one task at a time, list scheduling as the judge (pure).

On a day whose binary resources and battery are asked for far more than
they hold, the start heuristic places tasks at their earliest fitting
starts and leaves out what no longer fits; the kept-set relaxation keeps
sets no plan holds (it reads energy, not order), and the tasks list
scheduling cannot place of such a set are let go together, many of
them the valuable ones. The large suite's b60-h2880 of seed 217 (60
tasks over H = 2880, three binary resources, power, data rate and a
battery): 63 units left out where CP-SAT leaves out 52 (21 % above its
plan), and neither the insertion of left-out tasks
(:mod:`.insert`) nor 16 s of neighbourhood search recovered any.

:func:`grown` works on which tasks are kept instead: from the plan's
kept set, each left-out task in turn, the most valuable first, is added
with the tasks its precedences need, and the set, every task of it
mandatory (:func:`~.bounds.kept_only`), list-scheduled from scratch by
the rules of :data:`GROW_RULES`; when one places the whole set the
task stays in. Then, for each task still out, a kept task of lower
value that shares a binary or multiple resource with it (and the tasks
that need it) is swapped out, the cheapest first (at most
:data:`MAX_RIVALS`), if the set then keeps more value and a rule places
it. Adds first: on the large suites of seeds 216 and 217 they won as
much or more in a fifth to a half of the list schedules (seed 216's
b60-h1440: 50 units left out -> 28 in 32 schedules, 30 in 141 with
each task's swaps tried right after its add). Every set keeps the
tasks every plan must hold and closes over the precedence scopes, so
its plan is a plan of the whole problem; the checker has the last word.
On the day above, from the start heuristic's plan: 53 units left out
instead of 66 in 163 list schedules (2.1 s). The work is
bounded by list schedules tried (:data:`MAX_TRIES`), not by seconds,
so the answer is the same on every machine unless ``stop`` ends it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .bounds import kept_only, widened
from .domains import start_domains
from .greedy import placed_whole
from .proofs import precedence_needs, reach

if TYPE_CHECKING:
    from collections.abc import Callable, Set

    from ..model.plan import Plan
    from ..model.problem import Problem, Task

#: The rules that judge a set (of :data:`~.rules.RULES`), in order. On
#: the day above the deadline rule placed CP-SAT's kept set but one task
#: (the value and density rules left out two or three), and of 300 sets
#: the supply-first and forced-first rules, asked after it, placed none
#: it had not.
GROW_RULES = ("deadline",)

#: List schedules of a set tried at most (each a few milliseconds to
#: 45 ms on 60 tasks over H = 2880 with a battery).
MAX_TRIES = 300

#: Kept tasks tried at most as the one swapped out for a left-out task
#: (the cheapest first).
MAX_RIVALS = 6

#: Passes over the left-out tasks (a pass follows only one that grew
#: the set).
MAX_PASSES = 3


def grown(
    problem: Problem,
    plan: Plan,
    *,
    stop: Callable[[], bool] | None = None,
) -> Plan | None:
    """A valid plan keeping more value than ``plan``, or None.

    Parameters
    ----------
    problem
        A part without groups of alternatives (their options are not cut
        to a set here: None).
    plan
        A valid plan of ``problem`` with its objective.
    stop
        True when time is up: the best set found so far is answered.

    Returns
    -------
    Plan or None
        Status ``feasible`` with its objective, checked; None when no
        set keeping more value was placed.
    """
    if problem.alternatives or plan.objective is None:
        return None
    tasks = {t.id: t for t in problem.tasks}
    needs = precedence_needs(problem)
    needed_by: dict[str, list[str]] = {name: [] for name in tasks}
    for name, partners in needs.items():
        for partner in partners:
            needed_by[partner].append(name)
    required = {t.id for t in problem.tasks if problem.required(t)}
    shared = set(problem.resources.binary) | set(problem.resources.multiple)
    domains = start_domains(problem)
    # Each task with the tasks its precedences need: what comes in with it.
    closure = {name: reach({name}, needs) for name in tasks}
    # The tasks that may come in, the most valuable first: none of what
    # comes with them is unplaceable.
    candidates = [
        t
        for t in sorted(problem.tasks, key=lambda t: (-t.schedule_cost, t.id))
        if t.schedule_cost > 0
        and not any(domains[n].empty for n in closure[t.id])
    ]
    kept = set(plan.starts())
    best: Plan | None = None
    tries = 0

    def value(names: Set[str]) -> int:
        return sum(tasks[n].schedule_cost for n in names)

    def placed(names: set[str]) -> Plan | None:
        nonlocal tries
        tries += 1
        alone = kept_only(problem, names)
        found = placed_whole(alone, GROW_RULES, start_domains(alone))
        return None if found is None else widened(problem, found)

    def spent() -> bool:
        return tries >= MAX_TRIES or (stop is not None and stop())

    for _ in range(MAX_PASSES):
        grew = False
        left_out = [t for t in candidates if t.id not in kept]
        # Each task added as it is first: cheap, and where most is won.
        for task in left_out:
            if task.id in kept:
                continue  # came in with another's precedences
            if spent():
                return best
            added = closure[task.id]
            found = placed(kept | added)
            if found is not None:
                kept |= added
                best, grew = found, True
        # Then swapped in for a cheaper kept task on its resources.
        for task in left_out:
            if task.id in kept:
                continue
            added = closure[task.id]
            worth = value(added)
            rivals = _rivals(task, kept - required, tasks, worth, shared)
            for rival in rivals[:MAX_RIVALS]:
                if spent():
                    return best
                gone = reach({rival.id}, needed_by)
                swapped = (kept | added) - gone
                if (
                    gone & required
                    or not added <= swapped
                    or value(swapped) <= value(kept)
                ):
                    continue
                found = placed(swapped)
                if found is not None:
                    kept = swapped
                    best, grew = found, True
                    break
        if not grew:
            break
    return best


def _rivals(
    task: Task,
    kept: Set[str],
    tasks: dict[str, Task],
    worth: int,
    resources: Set[str],
) -> list[Task]:
    """Kept tasks worth less than ``worth`` that use one of the
    ``resources`` (binary and multiple) ``task`` uses, the cheapest first
    (then by name)."""
    wanted = {n for n, amount in task.uses.items() if amount > 0} & resources
    return sorted(
        (
            tasks[name]
            for name in kept
            if tasks[name].schedule_cost < worth
            and any(tasks[name].uses.get(n, 0) > 0 for n in wanted)
        ),
        key=lambda t: (t.schedule_cost, t.id),
    )
