"""Which generators the forced tasks need placed first (pure).

A mandatory task that consumes more of a consumable than the initial
level can only run after generators have charged it. The start plan's
``supply-first`` rule (:mod:`fsw_scheduler.analysis.greedy`) places the
sets of tasks :func:`supply_sets` lists before anything else.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Set

    from ..model.problem import Problem, Task
    from .domains import Domain


def charges_a_store(problem: Problem, task: Task) -> bool:
    """True if ``task`` puts into a consumable (a negative use)."""
    return any(
        task.uses.get(name, 0) < 0 for name in problem.resources.consumable
    )


def supply_sets(
    problem: Problem, domains: dict[str, Domain], forced: Set[str]
) -> list[set[str]]:
    """``forced`` and enough generators to cover what they consume.

    For each consumable, the forced tasks' total use beyond the initial
    level is a deficit; generators are added, those able to finish
    soonest first, until their whole output covers it (or none is left),
    with every task a chosen generator needs (which may consume more).
    Output that comes too late does not count for less here, so the set
    is followed by larger ones, each with twice as many generators, up
    to all of them; empty when no forced task consumes beyond the
    initial level.
    """
    makers = [
        name
        for _, name in sorted(
            (domains[t.id].earliest + t.length, t.id)
            for t in problem.tasks
            if charges_a_store(problem, t)
            and not domains[t.id].empty
            and t.id not in forced
        )
    ]
    sets = [_supplied(problem, domains, forced)]
    if sets[0] == set(forced):
        return []
    count = len(sets[0] & set(makers))
    while count < len(makers):
        count = min(len(makers), max(1, 2 * count))
        sets.append(_needed(problem, sets[0] | set(makers[:count])))
    return sets


def _supplied(
    problem: Problem, domains: dict[str, Domain], forced: Set[str]
) -> set[str]:
    """The first set of :func:`supply_sets`.

    Forced generators do not count: they may only run after the consumers
    (a precedence can force them in behind one).
    """
    chosen = set(forced)
    stores = problem.resources.initial_levels
    tasks = {t.id: t for t in problem.tasks}
    for name, initial in stores.items():
        makers = iter(
            sorted(
                (domains[t.id].earliest + t.length, t.id)
                for t in problem.tasks
                if t.uses.get(name, 0) < 0
                and not domains[t.id].empty
                and t.id not in forced
            )
        )

        def short(chosen: set[str], name: str = name) -> float:
            """What the chosen tasks lack, the forced generators left out."""
            return sum(
                max(0.0, tasks[n].uses.get(name, 0)) * tasks[n].length
                if n in forced
                else tasks[n].uses.get(name, 0) * tasks[n].length
                for n in chosen
            )

        while initial < short(chosen):
            maker = next(makers, None)
            if maker is None:
                break
            chosen = _needed(problem, chosen | {maker[1]})
    return chosen


def _needed(problem: Problem, names: set[str]) -> set[str]:
    """``names`` with every task they need (as in ``forced_tasks``)."""
    found = set(names)
    changed = True
    while changed:
        changed = False
        for prec in problem.precedences:
            if prec.after in found and prec.before not in found:
                found.add(prec.before)
                changed = True
            if (
                prec.scope == "both"
                and prec.before in found
                and prec.after not in found
            ):
                found.add(prec.after)
                changed = True
    return found
