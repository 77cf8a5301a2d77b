"""Binary windows and capacity steps in the disjunctive model, as blocks.

Each stretch a binary resource is unavailable, or a multiple resource
runs under its peak capacity, is held by a pinned task of its own.

The disjunctive model reads one capacity per resource (its pair and
load rows, :mod:`.constraints`). A *block* is a pinned, mandatory task
without costs that uses a binary resource during a stretch outside its
windows, or ``peak - c`` of a multiple resource during a stretch of
capacity ``c``: with the blocks the peak capacity holds exactly where
the profile did (the load of the real users at any unit is within the
profile iff the load with the blocks is within the peak). So a part
whose changing resources are binary or multiple is modelled as before
on the problem with blocks (:func:`blocked`), and its solution read
back on the tasks of the problem as given (the blocks have no costs
and no place in a plan).

Where this pays: a part of 22 tasks over H = 300 with three cameras
that have a 3-unit gap in their windows (tools/fuzz seed 16075) went to
the time-indexed model, 6,600 columns whose LP took 0.6 s, and CBC
proved it in 11-16 s (CP-SAT 0.07 s).

Consumables with an external rate stay with the time-indexed model, as
every consumable does; so do parts with more than :data:`MAX_BLOCKS`
blocks (each pairs with every user of its resource).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ....analysis.domains import Domain
from ....model.problem import Resources, Task

if TYPE_CHECKING:
    from collections.abc import Iterable, Mapping

    from ....model.problem import Problem

#: Blocks a part may have in all, or it keeps the time-indexed model:
#: each block is a user of its resource, with an order pair for every
#: real user it may overlap. An orbit's day of sunlight steps or ground
#: passes has a few dozen.
MAX_BLOCKS = 48

#: Block task ids start with this (no task id may: ids are letters,
#: digits, ``_``, ``-`` and ``.``), then the resource and the start.
PREFIX = "~"


def changing_in_use(
    problem: Problem, domains: Mapping[str, Domain]
) -> list[str]:
    """Resources whose capacity changes over time that a placeable task
    of ``problem`` uses, and every consumable with an external rate, used
    or not (its level rows bind with no task): what the disjunctive model
    cannot read as one capacity (:func:`modelled`)."""
    changing = set(problem.resources.changing)
    # An external rate is a use of its consumable that no task makes.
    drained = [n for n in problem.resources.consumable if n in changing]
    return sorted(
        {*drained}
        | {
            name
            for task in problem.tasks
            if not domains[task.id].empty
            for name, amount in task.uses.items()
            if amount and name in changing
        }
    )


def modelled(
    problem: Problem, domains: Mapping[str, Domain]
) -> tuple[Problem, Mapping[str, Domain]] | None:
    """What the disjunctive model reads for ``problem``: the problem and
    its domains as they are when no resource in use changes over time,
    else with the blocks of its windows and steps (:func:`blocked`);
    None when one cannot be held so (a consumable's external rate, more
    than :data:`MAX_BLOCKS` blocks)."""
    changing = changing_in_use(problem, domains)
    if not changing:
        return problem, domains
    return blocked(problem, domains, changing)


def _stretches(problem: Problem, name: str) -> tuple[float, list[Task]] | None:
    """The peak of binary or multiple resource ``name`` over the horizon
    and its blocks, or None for another kind.

    A block holds a stretch: a maximal run of units with the same
    shortfall from the resource's peak capacity over the horizon (1 for
    a binary resource outside its windows).
    """
    res = problem.resources
    kind = res.kind_of(name)
    if kind not in ("binary", "multiple"):
        return None
    profile = res.capacity_profile(name, problem.start, problem.horizon)
    # A binary resource is 1 where it is available: one user at a time
    # (a resource never available is blocked over the whole horizon).
    peak = 1.0 if kind == "binary" else max(profile, default=0.0)
    out: list[Task] = []
    run_from = 0
    for index in range(1, len(profile) + 1):
        if index < len(profile) and profile[index] == profile[run_from]:
            continue
        short = peak - profile[run_from]
        if short > 0:
            begin = problem.start + run_from
            out.append(
                Task(
                    id=f"{PREFIX}{name}@{begin}",
                    length=index - run_from,
                    delay_cost=0,
                    schedule_cost=0,
                    uses={name: short},
                    fixed_start=begin,
                )
            )
        run_from = index
    return peak, out


def blocked(
    problem: Problem,
    domains: Mapping[str, Domain],
    names: Iterable[str],
) -> tuple[Problem, dict[str, Domain]] | None:
    """``problem`` with the resources ``names`` at their peak capacity and
    their blocks added, and its domains with the blocks'; None when a
    resource cannot be blocked or the blocks exceed :data:`MAX_BLOCKS`.

    Only the resources named change: the others keep their profiles
    (none, when ``names`` is every changing resource in use).
    """
    peaks: dict[str, float] = {}
    added: list[Task] = []
    for name in sorted(set(names)):
        found = _stretches(problem, name)
        if found is None:
            return None
        peaks[name], more_blocks = found
        added += more_blocks
    if len(added) > MAX_BLOCKS:
        return None
    res = problem.resources
    multiple = {
        name: peaks.get(name, spec) for name, spec in res.multiple.items()
    }
    binary: tuple[str, ...] | dict = res.binary
    if isinstance(res.binary, dict):
        binary = {
            name: (type(spec)() if name in peaks else spec)
            for name, spec in res.binary.items()
        }
    wide = problem.replace(
        tasks=(*problem.tasks, *added),
        resources=Resources(
            binary=binary, multiple=multiple, consumable=res.consumable
        ),
    )
    more = dict(domains)
    for task in added:
        assert task.fixed_start is not None
        more[task.id] = Domain(task.fixed_start, task.fixed_start)
    return wide, more
