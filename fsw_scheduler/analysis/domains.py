"""Start-time domains tightened by precedences (pure).

Every task starts in ``[earliest, latest]`` given by horizon, feasible
interval and pin (:meth:`Problem.start_bounds`). Precedences shrink these
ranges further whenever both ends would be scheduled together; the ILP uses
the result to create fewer variables, and the explanations use it to say
when a precedence alone makes a task impossible. The rules, for a
precedence ``i -> j`` with gap ``g = length_i + offset``:

* any kind: ``j`` scheduled implies ``i`` scheduled with ``s_j >= s_i + g``,
  so ``earliest_j >= earliest_i + g``;
* tight: also ``s_j <= s_i + g``, so ``latest_j <= latest_i + g``;
* scope ``both``: ``i`` scheduled implies ``j`` scheduled, so
  ``latest_i <= latest_j - g`` and, when tight,
  ``earliest_i >= earliest_j - g``.

A task whose range becomes empty can never be scheduled; with scope
``both`` that empties its partner too. So does a task whose tight
precedences fix the tasks it needs so that they overlap on a resource or
contradict (:func:`~fsw_scheduler.analysis.proofs.block_conflicts`). So
does a consumer that alone needs more of a consumable than the initial
level plus everything the other tasks could generate before it ends
(:func:`_over_budget`), or more than the consumable's capacity plus what
can be generated while it runs (:func:`_over_capacity`). A capacity
only loses generation, so a level with one is never above the level
without it, and the first rule stays sound as it is.

:func:`cost_caps` adds a bound of another kind: once a plan that leaves
nothing out is known, no better plan can start a task later than the delay
that plan leaves to spare (see there).
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING

import msgspec

from .proofs import block_conflicts

if TYPE_CHECKING:
    from collections.abc import Callable, Mapping, Sequence

    from ..model.plan import Plan
    from ..model.problem import Precedence, Problem, Task


class Domain(msgspec.Struct, frozen=True):
    """Allowed start times ``[earliest, latest]`` of one task.

    ``cause`` says what emptied the range (``window`` or ``precedence``)
    and ``detail`` says how, when :attr:`empty`.
    """

    earliest: int
    latest: int
    cause: str = ""
    detail: str = ""

    @property
    def empty(self) -> bool:
        """True when no start time is allowed."""
        return self.earliest > self.latest


def start_count(domains: Mapping[str, Domain]) -> int:
    """Start times in ``domains`` in all: the time-indexed model's
    columns, the measure of a part's size that the solver's rules read."""
    return sum(
        d.latest - d.earliest + 1 for d in domains.values() if not d.empty
    )


def start_domains(
    problem: Problem, caps: Mapping[str, int] | None = None
) -> dict[str, Domain]:
    """Return each task's start domain after precedence propagation.

    Parameters
    ----------
    problem
        A validated problem.
    caps
        Extra latest starts by task id (see :func:`cost_caps`), propagated
        like the windows.

    Returns
    -------
    dict[str, Domain]
        Keyed by task id, in problem task order.
    """
    length = {task.id: task.length for task in problem.tasks}
    ranges = _Ranges({}, {}, {})
    low, high, cause = ranges.low, ranges.high, ranges.cause
    empty, kill = ranges.empty, ranges.kill
    for task in problem.tasks:
        low[task.id], high[task.id] = problem.start_bounds(task)
        if caps is not None and task.id in caps:
            high[task.id] = min(high[task.id], caps[task.id])
        if low[task.id] > high[task.id]:
            cause[task.id] = (
                "window",
                "feasible interval and horizon leave no start time",
            )

    for name, (kind, why) in block_conflicts(problem).items():
        kill(name, why, kind)
    # Precedences in topological order: the cycle search and the
    # propagation below both go along them.
    forward = _in_order(problem)
    for name, why in positive_cycles(problem, forward).items():
        kill(name, why)

    # Resources that change over time: a start whose run meets a unit
    # where the capacity is below the task's own amount (outside every
    # window of a binary resource) is no start at all.
    for task in problem.tasks:
        if not empty(task.id):
            found = _open_starts(problem, task, low[task.id], high[task.id])
            if found is not None:
                low[task.id], high[task.id], kind, why = found
                if empty(task.id):
                    cause[task.id] = (kind, why)

    if problem.resources.consumable:
        following: dict[str, list[tuple[str, int, int]]] = {}
        for prec in problem.precedences:
            following.setdefault(prec.before, []).append(
                (prec.after, prec.offset, length[prec.before] + prec.offset)
            )
        # Charge from outside over the whole horizon, once per resource
        # (per task it cost a walk of the horizon each).
        charges = {
            resource: problem.resources.external_charge(
                resource, problem.start, problem.horizon
            )
            for resource in problem.resources.initial_levels
        }
        for task in problem.tasks:
            if not empty(task.id):
                why = _over_budget(
                    problem, task, high[task.id], following, charges
                ) or _over_capacity(problem, task, low[task.id], high[task.id])
                if why:
                    kill(task.id, why, "consumable")

    # Passes in topological order and back settle a chain in two, in
    # whatever order the problem lists its precedences (2,000 tasks
    # listed last to first took 2,000 passes, 3.6 s). Where that empties
    # no domain, the bounds are the listed order's (the same fixpoint);
    # where it does, the listed order runs instead, so the precedence
    # named as the reason stays the one it always was.
    trial = ranges.copy()
    _settle(
        problem,
        length,
        trial,
        lambda rank: forward if rank % 2 == 0 else forward[::-1],
    )
    if any(trial.empty(name) and not empty(name) for name in length):
        _settle(problem, length, ranges, lambda _: problem.precedences)
    else:
        ranges = trial
    return {
        name: Domain(
            ranges.low[name],
            ranges.high[name],
            *ranges.cause.get(name, ("", "")),
        )
        for name in length
    }


class _Ranges:
    """Start ranges being narrowed, and why each emptied one is empty.

    Parameters
    ----------
    low, high
        Earliest and latest start by task id (empty when low > high).
    cause
        Task id to (kind, detail) of what emptied its range.
    """

    def __init__(
        self,
        low: dict[str, int],
        high: dict[str, int],
        cause: dict[str, tuple[str, str]],
    ) -> None:
        self.low = low
        self.high = high
        self.cause = cause

    def copy(self) -> _Ranges:
        """An independent copy (a trial propagation works on it)."""
        return _Ranges(dict(self.low), dict(self.high), dict(self.cause))

    def empty(self, name: str) -> bool:
        """True when ``name`` has no start left."""
        return self.low[name] > self.high[name]

    def kill(self, name: str, why: str, kind: str = "precedence") -> bool:
        """Empty ``name``'s range for ``why``; False if it already was."""
        if self.empty(name):
            return False
        self.high[name] = self.low[name] - 1
        self.cause[name] = (kind, why)
        return True


def _settle(
    problem: Problem,
    length: dict[str, int],
    ranges: _Ranges,
    order: Callable[[int], Sequence[Precedence]],
) -> None:
    """Propagate the precedences into ``ranges`` (in place) until nothing
    changes, pass ``rank`` going along ``order(rank)``; a task left
    without a start gets its reason."""
    low, high, cause = ranges.low, ranges.high, ranges.cause
    empty, kill = ranges.empty, ranges.kill
    # Each pass only shrinks ranges, so this terminates; the cap bounds
    # the work on long positive lax cycles, where any intermediate state
    # is still a valid relaxation.
    for rank in range(2 * len(length) + 4):
        changed = False
        for prec in order(rank):
            i, j = prec.before, prec.after
            gap = length[i] + prec.offset
            if empty(i):
                changed |= kill(j, f"needs {i}, which cannot be placed")
            if prec.scope == "both" and empty(j):
                changed |= kill(
                    i, f"must be scheduled with {j}, which cannot be placed"
                )
            if empty(i) or empty(j):
                continue
            bounds = [(j, "low", low[i] + gap)]
            if prec.kind == "tight":
                bounds.append((j, "high", high[i] + gap))
            if prec.scope == "both":
                bounds.append((i, "high", high[j] - gap))
                if prec.kind == "tight":
                    bounds.append((i, "low", low[j] - gap))
            for name, side, value in bounds:
                if side == "low" and value > low[name]:
                    low[name], changed = value, True
                elif side == "high" and value < high[name]:
                    high[name], changed = value, True
                if empty(name) and name not in cause:
                    cause[name] = (
                        "precedence",
                        f"{prec.kind} precedence {i} -> {j} "
                        f"(offset {prec.offset}) leaves no start time "
                        "inside the windows",
                    )
        if not changed:
            break


def cost_caps(
    problem: Problem, domains: Mapping[str, Domain], plan: Plan
) -> dict[str, int] | None:
    """Latest starts that every plan at least as good as ``plan`` keeps.

    Only for a ``plan`` that leaves no cost out (else None). Any plan as
    good must then leave nothing of cost out either, so it schedules every
    task of positive schedule cost, and every mandatory one, at or after
    its earliest start ``e``; that already costs ``D_min = sum d (e -
    start)`` in delay. Whatever ``plan``'s delay ``D`` has beyond that,
    ``slack = D - D_min``, bounds how late any one task may start: ``e +
    slack // d`` for a task that must be scheduled, ``start + slack // d``
    for one that may be left out. Tasks without delay cost get no cap.

    Parameters
    ----------
    problem
        A validated problem.
    domains
        Its :func:`start_domains`.
    plan
        A valid plan of ``problem`` with its objective.

    Returns
    -------
    dict[str, int] | None
        Task id to latest start, for tasks with a delay cost.
    """
    objective = plan.objective
    if objective is None or objective.unscheduled_cost != 0:
        return None

    member = problem.groups.member

    def must(task_id: str) -> bool:
        # A group member need not be scheduled: another option may be.
        task = problem.task(task_id)
        if task_id in member:
            return task.fixed_start is not None
        return problem.required(task) or task.schedule_cost > 0

    floor = {
        task.id: domains[task.id].earliest - problem.start
        if must(task.id) and not domains[task.id].empty
        else 0
        for task in problem.tasks
    }
    least = sum(task.delay_cost * floor[task.id] for task in problem.tasks)
    slack = objective.delay_cost - least
    if slack < 0:
        return None  # not a valid plan of this problem
    return {
        task.id: problem.start + floor[task.id] + slack // task.delay_cost
        for task in problem.tasks
        if task.delay_cost > 0
    }


def _over_budget(
    problem: Problem,
    task: Task,
    latest: int,
    following: Mapping[str, list[tuple[str, int, int]]],
    charges: Mapping[str, float],
) -> str:
    """Why ``task`` alone exhausts a consumable, or "" if it does not.

    Started at ``latest`` it runs the fewest units inside the horizon; by
    its end the level is at most the initial level plus all generation by
    tasks that can run before it ends and all external charge, minus what
    it took. Tasks that
    follow it through precedences starting no earlier than its end (the
    first link with offset >= 0, later links with gap >= 0) cannot help;
    ``following`` maps a task to its ``(successor, offset, gap)`` links;
    ``charges`` maps a consumable to all its external charge over the
    horizon (a bound: every positive rate summed).
    """
    after: set[str] | None = None
    for resource, initial in problem.resources.initial_levels.items():
        amount = task.uses.get(resource, 0)
        if amount <= 0:
            continue
        if after is None:
            after = _after_end(task.id, following)
        need = amount * max(0, min(task.length, problem.end - latest))
        supply = (
            initial
            + charges[resource]
            + sum(
                -other.uses.get(resource, 0) * other.length
                for other in problem.tasks
                if other.uses.get(resource, 0) < 0 and other.id not in after
            )
        )
        if need > supply + 1e-9:
            return (
                f"needs {need:g} {resource} on its own; at most {supply:g} "
                "can be there (initial level and generation before it ends)"
            )
    return ""


def _over_capacity(
    problem: Problem, task: Task, earliest: int, latest: int
) -> str:
    """Why ``task`` alone needs more than a full store gives, or "".

    With a capacity ``max`` the level before ``task`` starts is at most
    ``max``; while it runs, only generation by tasks whose start range
    lets them overlap its run comes in, each for at most the shorter of
    the two lengths (the capacity can only lose some of it, and other
    consumers only take more). So it needs at most ``max`` plus that.
    """
    for resource, top in problem.resources.ceilings.items():
        amount = task.uses.get(resource, 0)
        if amount <= 0:
            continue
        need = amount * task.length  # every task ends inside the horizon
        first, last = earliest, latest + task.length
        # Charge from outside in the units it may run in: a bound.
        inflow = problem.resources.external_charge(
            resource, first, max(0, last - first)
        )
        for other in problem.tasks:
            rate = -other.uses.get(resource, 0)
            if rate <= 0 or other.id == task.id:
                continue
            low, high = problem.start_bounds(other)
            overlap = min(last, high + other.length) - max(first, low)
            inflow += rate * max(0, min(other.length, task.length, overlap))
        if need > top + inflow + 1e-9:
            return (
                f"needs {need:g} {resource} on its own; at most "
                f"{top + inflow:g} can be there (capacity {top:g} and "
                "generation while it runs)"
            )
    return ""


def _open_starts(
    problem: Problem, task: Task, earliest: int, latest: int
) -> tuple[int, int, str, str] | None:
    """The first and last start in ``[earliest, latest]`` whose run meets
    no unit too small for ``task`` (None: no resource of it changes).

    An empty range (first > last) comes with the kind and words of why.
    """
    res = problem.resources
    changing = [n for n in res.changing if task.uses.get(n, 0) > 0]
    changing = [n for n in changing if n not in res.consumable]
    if not changing:
        return None
    closed = [False] * problem.horizon
    for name in changing:
        amount = task.uses[name]
        profile = res.capacity_profile(name, problem.start, problem.horizon)
        for idx, top in enumerate(profile):
            if top + 1e-9 < amount:
                closed[idx] = True
    # blocked[k]: closed units among the first k units of the horizon.
    blocked = list(itertools.accumulate(closed, initial=0))

    def fits(start: int) -> bool:
        first = start - problem.start
        last = first + task.length
        return (
            first >= 0
            and last <= problem.horizon
            and (blocked[last] == blocked[first])
        )

    starts = [s for s in range(earliest, latest + 1) if fits(s)]
    if not starts:
        kind = res.kind_of(changing[0]) or "multiple"
        words = (
            f"{', '.join(changing)} never available for its whole length"
            if kind == "binary"
            else f"{', '.join(changing)} capacity below its use at every start"
        )
        return earliest, earliest - 1, kind, words
    return starts[0], starts[-1], "", ""


def _after_end(
    task_id: str, following: Mapping[str, list[tuple[str, int, int]]]
) -> set[str]:
    """Tasks that can only start once ``task_id`` has ended."""
    found: set[str] = set()
    frontier = [
        after for after, offset, _ in following.get(task_id, ()) if offset >= 0
    ]
    while frontier:
        name = frontier.pop()
        if name in found or name == task_id:
            continue
        found.add(name)
        frontier += [
            after for after, _, gap in following.get(name, ()) if gap >= 0
        ]
    return found


def _in_order(problem: Problem) -> list[Precedence]:
    """The precedences by the topological rank of their ``before`` task
    (Kahn's order; tasks on cycles after the others, in problem order),
    then of their ``after`` task, then as listed."""
    following: dict[str, list[str]] = {t.id: [] for t in problem.tasks}
    waiting = dict.fromkeys(following, 0)
    for prec in problem.precedences:
        following[prec.before].append(prec.after)
        waiting[prec.after] += 1
    ready = [name for name, count in waiting.items() if count == 0]
    rank: dict[str, int] = {}
    while ready:
        name = ready.pop()
        rank[name] = len(rank)
        for other in following[name]:
            waiting[other] -= 1
            if waiting[other] == 0:
                ready.append(other)
    for task in problem.tasks:
        rank.setdefault(task.id, len(rank))
    listed = {id(prec): idx for idx, prec in enumerate(problem.precedences)}
    return sorted(
        problem.precedences,
        key=lambda p: (rank[p.before], rank[p.after], listed[id(p)]),
    )


def positive_cycles(
    problem: Problem, ordered: Sequence[Precedence] | None = None
) -> dict[str, str]:
    """Tasks held by precedences in a cycle that needs more time than a
    cycle has: task id to why (``ordered``: the precedences in
    topological order, if already known).

    Every precedence makes its ``after`` need its ``before`` (and the
    reverse with scope ``both``), so the tasks of one strongly connected
    set of that relation are scheduled all or none. If their start
    differences (``s_j >= s_i + length_i + offset``, both ways when
    tight) go round a cycle of positive length, they cannot all be:
    none is. The propagation of :func:`start_domains` finds this too, but
    a unit of length per pass at best (two tasks in a lax cycle over a
    horizon of 2,880 held it past its cap, and CBC then spent the limit).
    """
    length = {task.id: task.length for task in problem.tasks}
    needs: dict[str, list[str]] = {name: [] for name in length}
    for prec in problem.precedences:
        needs[prec.after].append(prec.before)
        if prec.scope == "both":
            needs[prec.before].append(prec.after)
    found: dict[str, str] = {}
    if ordered is None:
        ordered = _in_order(problem)  # a chain settles in one round
    for members in _strongly_connected(needs):
        if len(members) < 2:
            continue
        inside = set(members)
        edges: list[tuple[str, str, int]] = []
        for prec in ordered:
            if prec.before in inside and prec.after in inside:
                gap = length[prec.before] + prec.offset
                edges.append((prec.before, prec.after, gap))
                if prec.kind == "tight":
                    edges.append((prec.after, prec.before, -gap))
        # Longest paths from every member at once: still growing after
        # len(members) rounds means a positive cycle (Bellman-Ford). A
        # start difference past the horizon cannot be either: that ends
        # it sooner (2,000 tasks in one cycle: 50 rounds, not 2,000).
        dist = dict.fromkeys(members, 0)
        growing = False
        for _ in range(len(members)):
            growing = False
            for first, second, gap in edges:
                if dist[first] + gap > dist[second]:
                    dist[second] = dist[first] + gap
                    growing = True
            if not growing or max(dist.values()) >= problem.horizon:
                break
        if growing:
            names = ", ".join(sorted(members))
            for name in members:
                found[name] = (
                    f"precedences among {names} (each needs the others) "
                    "go round a cycle longer than zero: they cannot all "
                    "be scheduled"
                )
    return found


def _strongly_connected(graph: Mapping[str, list[str]]) -> list[list[str]]:
    """The strongly connected sets of ``graph`` (Kosaraju, without
    recursion: chains of hundreds of tasks)."""
    order: list[str] = []
    seen: set[str] = set()
    for root in graph:
        if root in seen:
            continue
        seen.add(root)
        stack = [(root, iter(graph[root]))]
        while stack:
            node, rest = stack[-1]
            nxt = next((n for n in rest if n not in seen), None)
            if nxt is None:
                stack.pop()
                order.append(node)
            else:
                seen.add(nxt)
                stack.append((nxt, iter(graph[nxt])))
    reverse: dict[str, list[str]] = {node: [] for node in graph}
    for node, targets in graph.items():
        for target in targets:
            reverse[target].append(node)
    sets: list[list[str]] = []
    placed: set[str] = set()
    for root in reversed(order):
        if root in placed:
            continue
        placed.add(root)
        members, todo = [], [root]
        while todo:
            node = todo.pop()
            members.append(node)
            for other in reverse[node]:
                if other not in placed:
                    placed.add(other)
                    todo.append(other)
        sets.append(members)
    return sets
