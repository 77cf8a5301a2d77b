"""Energy rows for the kept-set relaxation: what a resource can hold (pure).

The kept-set relaxation (:mod:`.bounds`) decides which tasks to keep with
every kept task at its earliest start; alone it ignores binary and
multiple resources, so on a day whose camera is asked for more time than
the horizon has it keeps every task and its bound says nothing of what
must be left out (seed 63's b30-h1440 of the large suite: a bound of
157,792 against an optimum of 1,014,386, which CP-SAT proves in 0.6 s).

:func:`energy_rows` adds rows that hold in every plan, whatever the
starts. For an interval ``[a, b)`` and a resource of capacity ``C``,
each user ``i`` of amount ``u_i`` runs inside the interval at least
``m_i`` units, the least overlap of its run with the interval over its
start domain (the overlap, as a function of the start, rises, stays and
falls, so its least value is at one end of the domain); the users
together cannot take more than the resource gives there::

    sum of u_i * m_i over the kept users  <=  C * (b - a)

A binary resource is such a resource of capacity 1, and so are the users
of a multiple resource above half its capacity (no two of them run at
once). Intervals run from a user's earliest start to a user's latest
end; a row is kept only where all the users together exceed it (else it
never cuts a kept set), the :data:`MAX_ROWS` most overloaded first.
"""

from __future__ import annotations

import itertools
import math
from typing import TYPE_CHECKING

from .lanes import least_overlaps

if TYPE_CHECKING:
    from collections.abc import Mapping, Sequence

    from ..model.problem import Problem, Task
    from .domains import Domain

#: Rows at most (the most overloaded intervals first). The search copies
#: its rows at every node: on the large suite (seeds 60 and 63, 30-60
#: tasks) 8, 24 and 64 rows gave the same bounds.
MAX_ROWS = 16

#: Intervals times users a group may weigh (a user's least overlap per
#: interval and user). Above it, the starts and the ends are each thinned
#: to evenly spaced ones, the first and the last always among them: 70
#: users each of six groups with every pair of ends took 0.77 s, about
#: 0.37 microseconds a user and interval, in a search set up several
#: times a solve; within this, a group takes about 25 ms at most.
MAX_PAIRS_WORK = 50_000

_EPS = 1e-9

#: A group of users of one capacity: (task, amount) pairs, the capacity
#: (the peak of one that changes) and what a changing one holds up to
#: each unit (:func:`_held`; None for a constant one).
_Group = tuple[list[tuple["Task", float]], float, list[float] | None]


def energy_rows(
    problem: Problem,
    domains: Mapping[str, Domain],
    kept: Sequence[Task],
    max_rows: int | None = None,
) -> tuple[dict[str, list[float]], list[float]]:
    """Energy rows over ``kept``: each task's least use of each row, and
    each row's limit.

    Parameters
    ----------
    problem
        A validated problem; a binary window or a capacity step limits
        each interval's row to what the resource holds over it.
    domains
        Its start domains (those of ``kept`` must not be empty).
    kept
        The tasks the rows are over.
    max_rows
        Rows at most (default :data:`MAX_ROWS`).

    Returns
    -------
    tuple
        The use per task id (one entry per row) and each row's limit, in
        the form of :func:`~fsw_scheduler.analysis.keptset.level_rows`.
    """
    found: list[tuple[float, int, int, dict[str, float], float]] = []
    for users, capacity, held in _groups(problem, kept):
        found.extend(
            _overloaded(users, capacity, domains, held, problem.start)
        )
    found.sort(key=lambda row: (-row[0], row[1], row[2]))
    if max_rows is None:
        max_rows = MAX_ROWS
    uses: dict[str, list[float]] = {task.id: [] for task in kept}
    limits: list[float] = []
    for _, _, _, row, limit in found[:max_rows]:
        limits.append(limit)
        for task in kept:
            uses[task.id].append(row.get(task.id, 0.0))
    return uses, limits


def _groups(problem: Problem, kept: Sequence[Task]) -> list[_Group]:
    """Users of each binary and multiple resource with its capacity, and
    the users of each multiple resource above half its capacity (one at
    a time: capacity 1). A resource whose capacity changes over time has
    its peak and what it holds over each interval (:func:`_held`); the
    users above half of its peak, one at a time, only the peak."""
    resources = problem.resources
    changing = set(resources.changing)
    groups: list[_Group] = []
    for name in resources.binary_names:
        users = [(t, 1.0) for t in kept if t.uses.get(name, 0)]
        groups.append((users, 1.0, _held(problem, name, changing)))
    for name in resources.multiple:
        capacity = resources.peak_capacity(name)
        users = [(t, float(t.uses[name])) for t in kept if t.uses.get(name)]
        groups.append((users, capacity, _held(problem, name, changing)))
        apart = [(t, 1.0) for t, amount in users if amount > capacity / 2]
        groups.append((apart, 1.0, None))
    return [group for group in groups if len(group[0]) > 1]


def _held(
    problem: Problem, name: str, changing: set[str]
) -> list[float] | None:
    """What a changing resource holds up to each unit (``held[k]``: the
    sum of its capacities over ``[start, start + k)``), or None for a
    constant one (its capacity times the interval's length)."""
    if name not in changing:
        return None
    profile = problem.resources.capacity_profile(
        name, problem.start, problem.horizon
    )
    return [0.0, *itertools.accumulate(profile)]


def _thinned(points: list[int], keep: int) -> list[int]:
    """At most ``keep`` (at least 2) of the sorted ``points``, evenly
    spaced by rank, the first and the last among them."""
    if len(points) <= keep:
        return points
    last = len(points) - 1
    return sorted({points[k * last // (keep - 1)] for k in range(keep)})


def _overloaded(
    users: list[tuple[Task, float]],
    capacity: float,
    domains: Mapping[str, Domain],
    held: list[float] | None = None,
    start: int = 0,
) -> list[tuple[float, int, int, dict[str, float], float]]:
    """Intervals that the users, all kept, would overload: (overload
    ratio, a, b, least use per task id, limit) for each. The least
    overlaps are the infeasibility proofs' (:func:`~.lanes.
    least_overlaps`), over intervals from a user's earliest start to a
    user's latest end. The limit is ``capacity`` times the interval's
    length, or with ``held`` (:func:`_held`, from unit ``start``) what
    the resource holds over the interval."""
    if capacity <= 0:
        return []
    starts = sorted({domains[t.id].earliest for t, _ in users})
    ends = sorted({domains[t.id].latest + t.length for t, _ in users})
    if len(starts) * len(ends) * len(users) > MAX_PAIRS_WORK:
        keep = max(2, math.isqrt(MAX_PAIRS_WORK // len(users)))
        starts, ends = _thinned(starts, keep), _thinned(ends, keep)
    amounts = {task.id: amount for task, amount in users}
    spans = [(task, domains[task.id]) for task, _ in users]
    found = []
    for a, b, inside, pieces in least_overlaps(spans, lows=starts, highs=ends):
        row = {
            name: amounts[name] * piece
            for name, piece in zip(inside, pieces, strict=True)
        }
        total = sum(row.values())
        limit = (
            capacity * (b - a)
            if held is None
            else held[b - start] - held[a - start]
        )
        if total > limit + _EPS:
            ratio = total / limit if limit > 0 else math.inf
            found.append((ratio, a, b, row, limit))
    return found
