"""The priority rules of the list scheduler (pure).

Each rule gives the key of a *group* (tasks tied by tight precedences,
member id to start offset) by which :mod:`.greedy` takes the ready
groups, highest first. One order suits no problem class (see
:mod:`.greedy`), so :func:`~.greedy.greedy_plan` runs each rule of
:data:`RULES` and keeps the best plan.
"""

from __future__ import annotations

from collections.abc import Callable, Set
from typing import TYPE_CHECKING

from .domains import Domain

if TYPE_CHECKING:
    from ..model.problem import Problem, Task


def _mandatory_first(
    problem: Problem,
    forced: Set[str],
    rest: Callable[[list[Task]], tuple],
) -> Callable[[dict[str, int]], tuple]:
    """A group's key: mandatory groups first, then ``rest`` of members.

    Only mandatory tasks, not every forced one
    (:func:`~fsw_scheduler.analysis.proofs.forced_tasks`): putting the optional
    tasks they need first too made plans worse where an optional task
    fits before them; the ``forced-first`` rule covers the other case.
    """
    del forced
    tasks = {t.id: t for t in problem.tasks}

    def key(group: dict[str, int]) -> tuple:
        members = [tasks[n] for n in group]
        return (any(t.mandatory for t in members), *rest(members))

    return key


def _value(members: list[Task]) -> float:
    """Schedule cost, with delay cost as a tie-break."""
    return sum(t.schedule_cost + 0.01 * t.delay_cost for t in members)


def by_value(
    problem: Problem, domains: dict[str, Domain], forced: Set[str]
) -> Callable[[dict[str, int]], tuple]:
    """Mandatory first, then schedule cost, then delay cost."""
    return _mandatory_first(
        problem,
        forced,
        lambda members: (
            sum(t.schedule_cost for t in members),
            sum(t.delay_cost for t in members),
        ),
    )


def by_density(
    problem: Problem, domains: dict[str, Domain], forced: Set[str]
) -> Callable[[dict[str, int]], tuple]:
    """Mandatory, then net generators, then value per consumable share.

    A task's share is what it takes of each consumable's initial level
    (amount x length / initial); a knapsack's greedy order.
    """
    initial = problem.resources.initial_levels

    def share(task: Task) -> float:
        return sum(
            amount * task.length / max(initial[name], 1.0)
            for name, amount in task.uses.items()
            if name in initial
        )

    def rest(members: list[Task]) -> tuple:
        net = sum(share(t) for t in members)
        return (net < 0, _value(members) / (1.0 + max(net, 0.0)))

    return _mandatory_first(problem, forced, rest)


def by_delay_rate(
    problem: Problem, domains: dict[str, Domain], forced: Set[str]
) -> Callable[[dict[str, int]], tuple]:
    """Schedule cost, then delay cost per unit of length (Smith's rule)."""
    return _mandatory_first(
        problem,
        forced,
        lambda members: (
            sum(t.schedule_cost for t in members),
            sum(t.delay_cost for t in members)
            / sum(t.length for t in members),
        ),
    )


def by_value_rate(
    problem: Problem, domains: dict[str, Domain], forced: Set[str]
) -> Callable[[dict[str, int]], tuple]:
    """Value per unit of length: many short tasks before one long one."""
    return _mandatory_first(
        problem,
        forced,
        lambda members: (_value(members) / sum(t.length for t in members),),
    )


def by_deadline(
    problem: Problem, domains: dict[str, Domain], forced: Set[str]
) -> Callable[[dict[str, int]], tuple]:
    """Latest start soonest first (earliest deadline), then schedule cost.

    Placing every task at its earliest start lets tasks with wide windows
    take the early slots that tasks with narrow ones need; on the scaling
    set this rule gave the best plan for 11 of the 24 problems (at 30
    tasks, H = 336, as little left out as CP-SAT's optimum).
    """
    return _mandatory_first(
        problem,
        forced,
        lambda members: (
            -min(domains[t.id].latest for t in members),
            sum(t.schedule_cost for t in members),
        ),
    )


def by_deadline_forced_first(
    problem: Problem, domains: dict[str, Domain], forced: Set[str]
) -> Callable[[dict[str, int]], tuple]:
    """The deadline rule, in two passes: forced tasks, then the others.

    A forced task that waits for an optional predecessor's group can find
    its slots taken by the time it is ready; placing every forced task
    first keeps the plan at least as good as the trivial one in almost
    every case (:func:`_list_schedule` runs the two passes).
    """
    return by_deadline(problem, domains, forced)


def by_supply(
    problem: Problem, domains: dict[str, Domain], forced: Set[str]
) -> Callable[[dict[str, int]], tuple]:
    """Generators first, then the deadline rule, in two passes.

    The first pass places the forced tasks and the generators they need
    (:func:`~fsw_scheduler.analysis.supply.supply_sets`), each generator
    before the consumers, so that a mandatory task that needs more than
    the initial level finds the charge there; the second pass places the
    rest. :func:`greedy_plan` runs it once more with every task that
    charges a store in the first pass: where only optional tasks need
    the charge, the generators with early windows otherwise lost the
    camera to long tasks worth more, and every consumer they feed went
    with them (the large suite's b45-h1440 of seed 197: 13 tasks left
    out, 8.83 M; this way 5, 3.44 M, in 0.1 s).
    """
    tasks = {t.id: t for t in problem.tasks}
    stores = problem.resources.initial_levels

    def key(group: dict[str, int]) -> tuple:
        members = [tasks[n] for n in group]
        # Net over the group: a consumer tied to a small generator waits.
        charges = any(
            sum(t.uses.get(name, 0) * t.length for t in members) < 0
            for name in stores
        )
        return (
            charges,
            any(t.mandatory for t in members),
            -min(domains[t.id].latest for t in members),
            sum(t.schedule_cost for t in members),
        )

    return key


Rule = Callable[
    ["Problem", dict[str, Domain], Set[str]],
    Callable[[dict[str, int]], tuple],
]

#: Priority rules, tried in this order.
RULES: dict[str, Rule] = {
    "value": by_value,
    "density": by_density,
    "delay-rate": by_delay_rate,
    "value-rate": by_value_rate,
    "deadline": by_deadline,
    "forced-first": by_deadline_forced_first,
    "supply-first": by_supply,
}
