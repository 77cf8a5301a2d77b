"""Infeasibility proofs about consumables (pure).

The tasks every plan must hold cannot all have what they need, whatever
the plan (:func:`~fsw_scheduler.analysis.proofs.infeasibility` asks each
test in turn):

* :func:`drain`: an external rate that empties a store by itself;
* :func:`budget`: what forced consumers must have taken by a time against
  the initial level plus all generation possible by then;
* :func:`store`: a forced consumer that takes more in its run than a
  store with a capacity holds plus what can come in meanwhile.

And the converse, :func:`never_short`: a store that no plan can empty.
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING

from ..model.plan import Blocker

if TYPE_CHECKING:
    from collections.abc import Iterable, Mapping, Sequence

    from ..model.problem import Problem, Task
    from .domains import Domain

_EPS = 1e-9


def drain(
    problem: Problem, domains: Mapping[str, Domain]
) -> tuple[Blocker, ...]:
    """An external rate that empties a store whatever the plan, or ``()``.

    With no task consuming, the level at the end of unit ``t`` is at most
    the initial level, plus the external rate summed up to ``t``, plus
    everything every generator can ever give (with no generator, walked
    with the capacity, which loses charge as the store does); below 0
    there, no plan is valid. The blocker names the resource (no task is
    at fault).
    """
    res = problem.resources
    for name in res.changing:
        if name not in res.consumable:
            continue
        external = res.external_profile(name, problem.start, problem.horizon)
        generation = sum(
            rate * gen.length
            for gen, rate, _ in _generators(problem, domains, name)
        )
        level = res.initial(name) + generation
        # With no generator the capacity binds exactly: what a full store
        # cannot take of the external charge is lost.
        top = res.ceiling(name) if not generation else None
        for unit, rate in enumerate(external):
            level += rate
            if top is not None:
                level = min(top, level)
            if level < -_EPS:
                return (
                    Blocker(
                        name,
                        "consumable",
                        f"{name}: its external rate alone takes the level "
                        f"below 0 by the end of t={problem.start + unit} "
                        f"(initial {res.initial(name):g}, all generation "
                        f"possible {generation:g}"
                        + ("" if top is None else f", capacity {top:g}")
                        + ")",
                    ),
                )
    return ()


def budget(
    problem: Problem,
    forced: list[Task],
    domains: Mapping[str, Domain],
    resource: str,
    initial: float,
) -> tuple[Blocker, ...]:
    """The level test of one consumable over the forced consumers.

    By time ``t`` (the end of unit ``t - 1``) the forced consumers that end
    by ``t`` whatever their start have taken all they need, while no more
    can have come in than the initial level and what every generator
    could deliver by ``t``, each starting at its earliest.
    """
    consumers = sorted(
        (
            (domains[task.id].latest + task.length, task)
            for task in forced
            if task.uses.get(resource, 0) > 0
        ),
        key=lambda item: (item[0], item[1].id),
    )
    generators = _generators(problem, domains, resource)
    charged = _charged(problem, resource)
    need = 0.0
    done: list[str] = []
    for end, task in consumers:
        need += task.uses[resource] * task.length
        done.append(task.id)
        supply = (
            initial
            + _by(problem, charged, end)
            + sum(
                amount * max(0, min(gen.length, end - dom.earliest))
                for gen, amount, dom in generators
            )
        )
        if need > supply + _EPS:
            detail = (
                f"{resource}: tasks that must be scheduled consume "
                f"{need:g} by time {end}, but at most {supply:g} can be "
                "there (initial level and all generation possible by then)"
            )
            return tuple(Blocker(name, "consumable", detail) for name in done)
    return ()


def store(
    problem: Problem,
    forced: list[Task],
    domains: Mapping[str, Domain],
    resource: str,
) -> tuple[Blocker, ...]:
    """The store test of one consumable with a capacity (``max``).

    The level is never above the capacity (or the initial level, if
    higher), so a forced consumer of ``a`` a unit over ``n`` units starts
    with at most that much, and during its run no more can come in than
    the external charge of its best ``n`` units and what every generator
    that can run beside it gives in ``n`` units (none that shares a
    binary resource with it, or whose domain keeps it apart): when ``n a``
    is more than the capacity and those together, the level goes below 0
    whatever the plan (fuzz case 11021: 2 a unit for 13 units, a store of
    10 charged 1 a unit; CBC had not proved it in 20 s).
    """
    res = problem.resources
    top = res.ceiling(resource)
    if top is None:
        return ()
    top = max(top, res.initial(resource))
    charged = _charged(problem, resource)
    binary = set(res.binary)
    generators = _generators(problem, domains, resource)
    for task in forced:
        amount = task.uses.get(resource, 0)
        domain = domains[task.id]
        if amount <= 0 or domain.empty:
            continue
        length = task.length
        mine = {n for n, a in task.uses.items() if a and n in binary}
        beside = sum(
            rate * min(length, gen.length)
            for gen, rate, dom in generators
            if not mine & {n for n, a in gen.uses.items() if a}
            and dom.earliest < domain.latest + length
            and domain.earliest < dom.latest + gen.length
        )
        drain = amount * length
        if drain <= top + beside + _EPS:
            continue  # the store and the generators alone carry it
        # The most external charge in a run of the task: its best window
        # (a scan of its domain, done only for a consumer that can fail).
        charge = max(
            _by(problem, charged, s + length) - _by(problem, charged, s)
            for s in range(domain.earliest, domain.latest + 1)
        )
        if drain > top + charge + beside + _EPS:
            detail = (
                f"{resource}: {task.id} takes {drain:g} in its {length} "
                f"units, more than the store holds ({top:g}) and can take "
                f"in meanwhile ({charge:g} from outside, {beside:g} from "
                "tasks that can run beside it)"
            )
            return (Blocker(task.id, "consumable", detail),)
    return ()


def _generators(
    problem: Problem, domains: Mapping[str, Domain], resource: str
) -> list[tuple[Task, float, Domain]]:
    """The placeable tasks that charge ``resource``, each with its rate
    (positive) and start domain."""
    return [
        (task, -task.uses[resource], domains[task.id])
        for task in problem.tasks
        if task.uses.get(resource, 0) < 0 and not domains[task.id].empty
    ]


def _charged(problem: Problem, resource: str) -> list[float]:
    """Charge from outside by the start of each unit, and after the last:
    the external rate's positive part summed (drain left out: a bound on
    what can have come in)."""
    external = problem.resources.external_profile(
        resource, problem.start, problem.horizon
    )
    return list(
        itertools.accumulate((max(0.0, r) for r in external), initial=0.0)
    )


def _by(problem: Problem, charged: list[float], time: int) -> float:
    """What :func:`_charged` says has come in by ``time`` (clamped to the
    horizon)."""
    return charged[min(max(time - problem.start, 0), len(charged) - 1)]


def never_short(
    initial: float,
    external: Sequence[float],
    users: Iterable[tuple[Task, float]],
) -> bool:
    """True if a consumable can never run short: its consumers, all run
    in full, and its external drain take no more than its ``initial``
    level (charge, from outside or from a task, only raises a level: a
    full store loses the excess, never more).

    ``external`` is its external profile, ``users`` the (task, amount)
    pairs of the tasks that may use it.
    """
    drain = -sum(rate for rate in external if rate < 0)
    drawn = sum(amount * task.length for task, amount in users if amount > 0)
    return drawn + drain <= initial
