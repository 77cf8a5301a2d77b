"""List schedules with each consumer a capped store cannot feed given a
supply that must run beside it (pure).

A consumer that draws more over its run than a consumable can hold (its
``max``) can only run while something puts into that store: a supply
beside it, or an external rate. List scheduling places each task at its
earliest fitting start and a supply wherever it first fits, which is
rarely beside such a consumer: the store is full long before the
consumer comes, and the consumer never fits. ``tools/fuzz --large``
seed 1519 (37 tasks over H = 700): a forced task pinned at 344 draws 12
units from a battery of at most 10 and needs a 59-unit supply running
into it; no rule, no perturbed order and no model of the forced tasks
in 5 s placed it, and the answer was ``unknown`` where CP-SAT has a
plan.

:func:`paired_plan` makes a supply of each such consumer's store, long
enough to cover it, mandatory and narrows its starts to a range where
it can run beside the consumer (from the consumer's earliest start less
the supply's extra length to the consumer's latest start; then parts of
that range, :data:`SPANS`), then list-schedules that problem: the
supply goes where it first fits, and the consumer where the store
holds, beside it when nothing else feeds it. Every plan of the
narrowed problem is a plan of the problem (a rule was added, none taken
away); the plan found is checked on the problem itself.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import msgspec

from .check import check_plan
from .domains import start_domains
from .greedy import greedy_plan
from .sampling import sampled_plan

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..model.plan import Plan
    from ..model.problem import Problem, Task
    from .domains import Domain


#: Parts of a supply's overlapping starts tried in turn, as shares of
#: the range (from, to): all of it (list scheduling then puts the supply
#: at its first fit), its latest quarter, its latest half, its earliest
#: quarter. ``tools/fuzz --large`` seed 1501: a consumer drawing 76 from
#: a battery of at most 10 fits only late, beside its supply and an
#: external charge that starts at 250 of [100, 400).
SPANS = ((0.0, 1.0), (0.75, 1.0), (0.5, 1.0), (0.0, 0.25))


def needy(problem: Problem) -> list[tuple[Task, str]]:
    """The consumers that draw more of a capped consumable over their run
    than it can hold, with that consumable, in problem order."""
    ceilings = problem.resources.ceilings
    return [
        (task, name)
        for task in problem.tasks
        for name, cap in ceilings.items()
        if task.uses.get(name, 0) * task.length > cap
    ]


def paired_plan(
    problem: Problem, stop: Callable[[], bool] | None = None
) -> Plan | None:
    """A valid plan of ``problem`` by list scheduling with a supply made
    to run beside each needy consumer (:func:`needy`): of the supplies
    of its store at least as long as it whose starts can overlap it, the
    longest not given to another consumer; its starts narrowed to each
    part of that overlap in :data:`SPANS` in turn (the whole of it also
    in perturbed orders). None when no needy consumer has such a supply,
    or no list schedule gives a plan the checker accepts."""
    consumers = needy(problem)
    if not consumers:
        return None
    domains = start_domains(problem)
    for span in SPANS:
        if stop is not None and stop():
            return None
        narrowed = _narrowed(problem, consumers, domains, span)
        if narrowed is None:
            return None
        plan = greedy_plan(narrowed, stop=stop)
        if plan is None and span == SPANS[0]:
            plan = sampled_plan(narrowed, stop=stop)
        if plan is not None:
            report = check_plan(problem, plan)
            if report.ok:
                return plan.replace(objective=report.objective)
    return None


def _narrowed(
    problem: Problem,
    consumers: list[tuple[Task, str]],
    domains: dict[str, Domain],
    span: tuple[float, float],
) -> Problem | None:
    """``problem`` with a supply for each needy consumer made mandatory
    and started where it overlaps the consumer, in the ``span`` of those
    starts (a consumer with no such supply is left to what else feeds
    its store); None when no consumer has one."""
    given: dict[str, tuple[int, int]] = {}
    for consumer, name in consumers:
        own = domains[consumer.id]
        if own.empty:
            return None
        chosen = None
        for supply in sorted(
            problem.tasks, key=lambda t: (t.id in given, -t.length, t.id)
        ):
            if (
                supply.uses.get(name, 0) >= 0
                or supply.length < consumer.length
                or domains[supply.id].empty
            ):
                continue
            low = max(
                domains[supply.id].earliest,
                own.earliest - (supply.length - consumer.length),
            )
            high = min(domains[supply.id].latest, own.latest)
            if supply.id in given:
                low = max(low, given[supply.id][0])
                high = min(high, given[supply.id][1])
            if low <= high:
                chosen = supply.id, (low, high)
                break
        if chosen is None:
            # No supply can run beside it: an external rate may feed it.
            continue
        low, high = chosen[1]
        given[chosen[0]] = (
            low + math.floor(span[0] * (high - low)),
            low + math.ceil(span[1] * (high - low)),
        )
    if not given:
        return None
    return problem.replace(
        tasks=tuple(
            msgspec.structs.replace(
                task,
                schedule_cost=0,
                feasible_interval=given[task.id],
                feasible_interval_applies_to="start",
            )
            if task.id in given
            else task
            for task in problem.tasks
        )
    )
