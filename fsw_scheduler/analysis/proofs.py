"""Cheap infeasibility proofs and the tasks every plan must hold (pure).

A problem is infeasible only when the tasks that every plan must schedule
cannot all be placed. Those are the *forced* tasks (:func:`forced_tasks`):
the mandatory ones, every task a forced task needs (its ``before`` in any
precedence) and every task a forced task drags in (its ``after`` in a
``both`` precedence). Anything else may be left out, so a contradiction
elsewhere only means that some tasks cannot be scheduled together, which
the model and the heuristic handle by leaving one of them out.

:func:`infeasibility` looks for a proof among the forced tasks alone,
without a solver, in time polynomial in their number:

* a forced task without a start time (``window``, ``precedence`` or
  ``consumable``, from :func:`fsw_scheduler.analysis.domains.start_domains`);
* tight precedences among forced tasks that fix the same start difference
  in two different ways (:func:`tight_conflicts`);
* binary and multiple resources: over an interval ``[a, b)``, the work
  forced tasks must do inside it (each at its least overlap, whatever its
  start in its domain) exceeding ``capacity x (b - a)``: the energetic
  test of cumulative scheduling, which also covers a task that alone
  needs more than the capacity;
* consumables: by the end of the latest possible end of some forced
  consumers, their consumption exceeding the initial level plus all the
  generation any task could have delivered by then.

Each proof is reported as :class:`~fsw_scheduler.model.plan.Blocker`\\ s
naming the tasks and the constraint.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

from ..model.plan import Blocker

if TYPE_CHECKING:
    from collections.abc import Collection, Mapping

    from ..model.problem import Precedence, Problem, Task
    from .domains import Domain

_EPS = 1e-9


def forced_tasks(problem: Problem) -> set[str]:
    """Tasks that every valid plan schedules.

    The mandatory tasks, closed under "needs": the ``before`` of any
    precedence whose ``after`` is forced, and the ``after`` of a ``both``
    precedence whose ``before`` is forced.
    """
    forced = {task.id for task in problem.tasks if task.mandatory}
    changed = bool(forced)
    while changed:
        changed = False
        for prec in problem.precedences:
            if prec.after in forced and prec.before not in forced:
                forced.add(prec.before)
                changed = True
            if (
                prec.scope == "both"
                and prec.before in forced
                and prec.after not in forced
            ):
                forced.add(prec.after)
                changed = True
    return forced


class TightConflict(NamedTuple):
    """A tight precedence that contradicts earlier ones.

    ``position`` is its index in ``problem.precedences``; it needs
    ``start(after) - start(before) = gap`` where the earlier tight
    precedences already imply ``implied``.
    """

    position: int
    prec: Precedence
    gap: int
    implied: int


def tight_conflicts(
    problem: Problem, among: Collection[str] | None = None
) -> list[TightConflict]:
    """Tight precedences whose fixed start differences contradict.

    A weighted union-find keeps, for each task, its start offset from the
    root of its tight group; a new tight precedence inside a group must
    agree with the offset already implied. Only precedences with both ends
    in ``among`` are considered (default: all).
    """
    length = {task.id: task.length for task in problem.tasks}
    parent: dict[str, str] = {}
    shift: dict[str, int] = {}  # s_task - s_parent

    def find(name: str) -> tuple[str, int]:
        total = 0
        while parent.get(name, name) != name:
            total += shift[name]
            name = parent[name]
        return name, total

    conflicts = []
    for idx, prec in enumerate(problem.precedences):
        if prec.kind != "tight":
            continue
        if among is not None and (
            prec.before not in among or prec.after not in among
        ):
            continue
        gap = length[prec.before] + prec.offset  # s_after - s_before
        root_b, off_b = find(prec.before)
        root_a, off_a = find(prec.after)
        if root_b == root_a:
            if off_a - off_b != gap:
                conflicts.append(TightConflict(idx, prec, gap, off_a - off_b))
            continue
        parent[root_a] = root_b
        shift[root_a] = off_b + gap - off_a
    return conflicts


def infeasibility(
    problem: Problem, domains: Mapping[str, Domain]
) -> tuple[Blocker, ...]:
    """A proof that the forced tasks cannot all be placed, or ``()``.

    Parameters
    ----------
    problem
        A validated problem.
    domains
        Its :func:`~fsw_scheduler.analysis.domains.start_domains`.

    Returns
    -------
    tuple[Blocker, ...]
        The forced tasks concerned and the constraint that excludes them;
        empty when no cheap proof exists (the problem may still be
        infeasible).
    """
    forced = forced_tasks(problem)
    if not forced:
        return ()
    tasks = [task for task in problem.tasks if task.id in forced]
    stuck = tuple(
        Blocker(task.id, domains[task.id].cause, domains[task.id].detail)
        for task in tasks
        if domains[task.id].empty
    )
    if stuck:
        return stuck
    for conflict in tight_conflicts(problem, forced):
        prec = conflict.prec
        detail = (
            f"tight precedences among tasks that must be scheduled "
            f"contradict: precedences[{conflict.position}] needs "
            f"start({prec.after}) - start({prec.before}) = {conflict.gap}, "
            f"others imply {conflict.implied}"
        )
        return (
            Blocker(prec.before, "precedence", detail),
            Blocker(prec.after, "precedence", detail),
        )
    res = problem.resources
    capacities = {name: 1.0 for name in res.binary}
    capacities.update(res.multiple)
    for name, capacity in capacities.items():
        found = _energy(problem, tasks, domains, name, capacity)
        if found:
            return found
    for name, initial in res.initial_levels.items():
        found = _budget(problem, tasks, domains, name, initial)
        if found:
            return found
    return ()


def _energy(
    problem: Problem,
    forced: list[Task],
    domains: Mapping[str, Domain],
    resource: str,
    capacity: float,
) -> tuple[Blocker, ...]:
    """Energetic test of one capacity resource over the forced users."""
    kind = problem.resources.kind_of(resource)
    users = [
        (task, task.uses[resource], domains[task.id])
        for task in forced
        if task.uses.get(resource, 0) > 0
    ]
    for task, amount, _ in users:
        if amount > capacity + _EPS:
            return (
                Blocker(
                    task.id,
                    kind or "multiple",
                    f"needs {amount:g} {resource}, more than its capacity "
                    f"{capacity:g}",
                ),
            )
    if sum(a * t.length for t, a, _ in users) <= capacity + _EPS:
        return ()  # not even two units of work: nothing to find
    # Interval ends at the ends of the tasks' ranges and of their
    # compulsory parts ([latest, earliest + length) when not empty).
    lows = sorted(
        {d.earliest for _, _, d in users} | {d.latest for _, _, d in users}
    )
    highs = sorted(
        {d.latest + t.length for t, _, d in users}
        | {d.earliest + t.length for t, _, d in users}
    )
    for low in lows:
        for high in highs:
            if high <= low:
                continue
            need, inside = 0.0, []
            for task, amount, dom in users:
                # Least overlap with [low, high) over the task's starts.
                least = min(
                    task.length,
                    high - low,
                    max(0, dom.earliest + task.length - low),
                    max(0, high - dom.latest),
                )
                if least > 0:
                    need += amount * least
                    inside.append(task.id)
            if need > capacity * (high - low) + _EPS:
                detail = (
                    f"{resource}: tasks that must be scheduled need "
                    f"{need:g} units of work in [{low}, {high}), where "
                    f"capacity {capacity:g} allows "
                    f"{capacity * (high - low):g}"
                )
                return tuple(
                    Blocker(name, kind or "multiple", detail)
                    for name in inside
                )
    return ()


def _budget(
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
    generators = [
        (task, -task.uses[resource], domains[task.id])
        for task in problem.tasks
        if task.uses.get(resource, 0) < 0 and not domains[task.id].empty
    ]
    need = 0.0
    done: list[str] = []
    for end, task in consumers:
        need += task.uses[resource] * task.length
        done.append(task.id)
        supply = initial + sum(
            amount * max(0, min(gen.length, end - dom.earliest))
            for gen, amount, dom in generators
        )
        if need > supply + _EPS:
            detail = (
                f"{resource}: tasks that must be scheduled consume "
                f"{need:g} by time {end}, but at most {supply:g} can be "
                "there (initial level and all generation possible by then)"
            )
            return tuple(Blocker(name, "consumable", detail) for name in done)
    return ()
