"""Optimality proofs for start plans that leave tasks out (pure).

:func:`~fsw_scheduler.solving.solve.at_lower_bound` proves a start plan
optimal when every task is at its earliest start. Many plans of problems
with a scarce consumable have that shape except that some tasks are left
out: no plan can start anything sooner, and the question is only whether
another choice of tasks to keep leaves less out. :func:`kept_set_optimal`
answers it with a relaxation that needs no solver:

* every kept task is placed at its earliest start for the delay it
  costs (no plan starts it sooner);
* for each consumable, the level must stay ``>= 0`` at each checkpoint
  when consumers run as *late* as their domains allow and generators as
  *early* (any real placement consumes at least as much and generates at
  most as much by then, and a capacity only lowers a level);
* precedence scopes hold (``both``: both or neither; ``at_least_first``:
  the later one needs the earlier one);
* binary and multiple resources are ignored.

Every valid plan keeps a set of tasks that the relaxation accepts, at a
cost no lower than the relaxed one. If no accepted set costs less than the
start plan, the start plan is optimal. A depth-first search over kept sets
decides it, bounded by :data:`MAX_NODES` (beyond it: no proof, the solver
decides). On the paper campaign's consumable problems this proves 4 of
the 7 at 15 tasks that used to need CBC (each ~0.1-0.3 s there).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..model.plan import objective_weight

if TYPE_CHECKING:
    from collections.abc import Mapping

    from ..model.plan import Plan
    from ..model.problem import Problem, Task
    from .domains import Domain

#: Search nodes after which :func:`kept_set_optimal` gives up (no proof).
#: At 15 tasks the proofs it finds take well under 1 000 nodes; a cap keeps
#: hundreds of tasks from costing more than the solve it would spare.
MAX_NODES = 20_000

#: Row entries the search may touch in all (nodes times rows), so that a
#: part with many tasks and checkpoints gives up within milliseconds.
MAX_WORK = 400_000

#: Parts with more placeable tasks are not searched (the recursion is one
#: level per task).
MAX_TASKS = 200

_EPS = 1e-9


def _units(task: Task, start: int, point: int) -> int:
    """Units of ``task`` started at ``start`` run in ``[start, point]``."""
    return max(0, min(point - start + 1, task.length))


def _checkpoints(
    problem: Problem,
    domains: Mapping[str, Domain],
    users: list[tuple[Task, float]],
) -> list[int]:
    """Units at whose end some relaxed level can be lowest.

    With consumers fixed at their latest start and generators at their
    earliest, a level falls only while consumers run and rises only while
    generators do: its minima lie at the last unit of a consumer, the unit
    before a generator starts, or the end of the horizon.
    """
    points = {problem.end - 1}
    for task, amount in users:
        domain = domains[task.id]
        if amount > 0:
            points.add(domain.latest + task.length - 1)
        else:
            points.add(domain.earliest - 1)
    return sorted(p for p in points if problem.start <= p < problem.end)


def _level_rows(
    problem: Problem, domains: Mapping[str, Domain], kept: list[Task]
) -> tuple[dict[str, list[float]], list[float]]:
    """Relaxed level rows: each task's use by each checkpoint, and limits.

    Returns the use per task id (one entry per row, of every consumable
    together) and each row's initial level. Consumables that the tasks
    cannot exhaust get no row.
    """
    uses: dict[str, list[float]] = {task.id: [] for task in kept}
    limits: list[float] = []
    for name, initial in problem.resources.initial_levels.items():
        users = [
            (task, task.uses[name])
            for task in kept
            if task.uses.get(name, 0) != 0
        ]
        if sum(a * t.length for t, a in users if a > 0) <= initial + _EPS:
            continue
        for point in _checkpoints(problem, domains, users):
            limits.append(initial)
            for task in kept:
                amount = task.uses.get(name, 0)
                domain = domains[task.id]
                start = domain.latest if amount > 0 else domain.earliest
                uses[task.id].append(amount * _units(task, start, point))
    return uses, limits


def kept_set_optimal(
    problem: Problem,
    plan: Plan,
    domains: Mapping[str, Domain],
    max_nodes: int = MAX_NODES,
) -> bool:
    """True if ``plan`` is optimal by the kept-set relaxation.

    Parameters
    ----------
    problem
        A validated problem.
    plan
        A valid plan of ``problem`` with its objective (a start plan).
    domains
        The problem's :func:`~fsw_scheduler.analysis.domains.start_domains`.
    max_nodes
        Search nodes before giving up.

    Returns
    -------
    bool
        True only when no set of tasks that the relaxation accepts (see
        the module docstring) costs less than ``plan``; False when one
        does, when ``plan`` starts a task after its earliest start, or
        when the search stopped at ``max_nodes``.
    """
    if plan.objective is None:
        return False
    starts = plan.starts()
    if any(
        starts[task.id] != domains[task.id].earliest
        for task in problem.tasks
        if task.id in starts
    ):
        return False  # its own kept set costs less in the relaxation
    weight = objective_weight(
        [t.delay_cost for t in problem.tasks], problem.horizon
    )
    placeable = [t for t in problem.tasks if not domains[t.id].empty]
    if len(placeable) > MAX_TASKS:
        return False
    # Cost of a kept set: weight * (cost of all) - sum of the kept values.
    total = weight * sum(t.schedule_cost for t in problem.tasks)
    value = {
        t.id: weight * t.schedule_cost
        - t.delay_cost * (domains[t.id].earliest - problem.start)
        for t in placeable
    }
    need = total - plan.objective.total + 1  # value of a better kept set
    uses, limits = _level_rows(problem, domains, placeable)
    # Mandatory tasks are decided first (kept), then by value: leaving
    # out a valuable task drops the bound at once.
    order = sorted(
        placeable,
        key=lambda t: (not t.mandatory, -value[t.id], t.id),
    )
    index = {t.id: k for k, t in enumerate(order)}
    # Precedence scopes as (earlier decided, later decided, kind).
    links: list[list[tuple[int, bool, bool]]] = [[] for _ in order]
    for prec in problem.precedences:
        a, b = index.get(prec.before), index.get(prec.after)
        if b is None:
            if a is not None and prec.scope == "both":
                links[a].append((-1, True, True))  # a is never kept
            continue
        if a is None:
            links[b].append((-1, True, True))  # b needs a: never kept
            continue
        both = prec.scope == "both"
        first, second = min(a, b), max(a, b)
        # keep[second] must satisfy: both -> equal; at_least_first ->
        # after kept needs before kept.
        links[second].append((first, both, second == b))
    rest = [0] * (len(order) + 1)  # best value still to come
    for k in range(len(order) - 1, -1, -1):
        rest[k] = rest[k + 1] + max(0, value[order[k].id])
    # Generators still undecided can lower each row by this much.
    credit = [[0.0] * len(limits) for _ in range(len(order) + 1)]
    for k in range(len(order) - 1, -1, -1):
        row = uses[order[k].id]
        credit[k] = [
            c + min(0.0, u) for c, u in zip(credit[k + 1], row, strict=True)
        ]
    keep = [False] * len(order)
    nodes = 0
    # Each node copies the rows: bound the work, not only the nodes.
    max_nodes = min(max_nodes, MAX_WORK // (len(limits) + 1))

    def allowed(k: int, kept: bool) -> bool:
        for first, both, is_after in links[k]:
            if first < 0:
                if kept:
                    return False
                continue
            if both and keep[first] != kept:
                return False
            if not both:
                if is_after and kept and not keep[first]:
                    return False
                if not is_after and keep[first] and not kept:
                    return False
        return True

    def better(k: int, got: int, rows: list[float]) -> bool | None:
        """True if a better kept set extends this one; None at the cap."""
        nonlocal nodes
        nodes += 1
        if nodes > max_nodes:
            return None
        if got + rest[k] < need:
            return False
        if any(
            r + c > lim + _EPS
            for r, c, lim in zip(rows, credit[k], limits, strict=True)
        ):
            return False
        if k == len(order):
            return True
        task = order[k]
        choices = (True,) if task.mandatory else (True, False)
        for kept in choices:
            if not allowed(k, kept):
                continue
            keep[k] = kept
            if kept:
                grown = [
                    r + u for r, u in zip(rows, uses[task.id], strict=True)
                ]
                found = better(k + 1, got + value[task.id], grown)
            else:
                found = better(k + 1, got, rows)
            if found is None or found:
                return found
        return False

    return better(0, 0, [0.0] * len(limits)) is False
