"""Delay that tasks sharing one machine cannot avoid (pure).

Tasks of which no two may run at once (the users of a binary resource,
the users of a multiple resource that need more than half its capacity)
form a *machine*. Each has a release ``r`` (its earliest start), a
length ``p`` and a delay cost ``w``; a plan pays ``w (s - r)`` beyond
the delay of its earliest start. Kept together on one machine they
cannot all start at their releases, and :func:`machine_delay` bounds
what they pay by sequencing alone:

* the mean busy time of a task run in one piece from ``s`` is
  ``M = s + p / 2``, so ``sum w (s - r) = sum w M - sum w (p / 2 + r)``;
* over *preemptive* schedules (any schedule in one piece is one), the
  least ``sum w M`` is reached by running, at every moment, the released
  task of largest ``w / p`` still unfinished (preemptive WSPT; M. X.
  Goemans, "Improved approximation algorithms for scheduling with
  release dates", SODA 1997).

So that schedule's ``sum w M``, less ``sum w (p / 2 + r)``, bounds the
sequencing delay of every plan that keeps those tasks; with integer
starts it is rounded up. It grows with the set (a task added only takes
machine time from the others), which lets a search over kept sets cut
with the part of a set it has decided (:mod:`.keptset`).
"""

from __future__ import annotations

import heapq
import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Mapping, Sequence

    from ..model.problem import Problem, Task
    from .domains import Domain

#: Rounding slack: a bound within this of an integer is that integer.
_EPS = 1e-6

#: One task on a machine: (release, length, delay cost).
Job = tuple[int, int, int]


def job(task: Task, domains: Mapping[str, Domain]) -> Job:
    """``task`` as a job on its machine, released at its earliest start."""
    return (domains[task.id].earliest, task.length, task.delay_cost)


def machine_delay(jobs: Sequence[Job]) -> int:
    """The least sequencing delay of ``jobs`` on one machine (a lower bound).

    Parameters
    ----------
    jobs
        (release, length, delay cost) of each task; lengths at least 1,
        costs at least 0.

    Returns
    -------
    int
        A lower bound on ``sum w (s - r)`` over every schedule that runs
        each job in one piece from an integer ``s >= r``, no two at once
        (0 for fewer than two jobs).
    """
    if len(jobs) < 2:
        return 0
    ordered = sorted(jobs)
    heap: list[tuple[float, int]] = []
    left = [float(length) for _, length, _ in ordered]
    now = float(ordered[0][0])
    busy = 0.0  # sum of w M over the preemptive WSPT schedule
    k = 0
    n = len(ordered)
    while k < n or heap:
        if not heap and now < ordered[k][0]:
            now = float(ordered[k][0])
        while k < n and ordered[k][0] <= now:
            _, length, cost = ordered[k]
            heapq.heappush(heap, (-cost / length, k))
            k += 1
        ratio, j = heapq.heappop(heap)
        _, length, cost = ordered[j]
        release_next = ordered[k][0] if k < n else math.inf
        run = min(left[j], release_next - now)
        # This piece's share of the task's mean busy time.
        busy += cost * run / length * (now + run / 2)
        left[j] -= run
        now += run
        if left[j] > 0:
            heapq.heappush(heap, (ratio, j))
    floor = busy - sum(
        cost * (length / 2 + release) for release, length, cost in ordered
    )
    return max(0, math.ceil(floor - _EPS))


def machines(
    problem: Problem, domains: Mapping[str, Domain]
) -> list[tuple[str, ...]]:
    """Machines of the placeable tasks, each task on one at most.

    Each binary resource's users, then each multiple resource's users
    above half its peak capacity (any two of them exceed it), in the
    problem's order; a task already on a machine is not put on another,
    so that the machines' delays add up (each bounds its own tasks').
    Machines of fewer than two tasks are left out.
    """
    res = problem.resources
    placeable = [t for t in problem.tasks if not domains[t.id].empty]
    taken: set[str] = set()
    found: list[tuple[str, ...]] = []

    def add(users: list[Task]) -> None:
        free = tuple(t.id for t in users if t.id not in taken)
        if len(free) >= 2:
            found.append(free)
            taken.update(free)

    for name in res.binary:
        add([t for t in placeable if t.uses.get(name, 0) > 0])
    for name in res.multiple:
        half = res.peak_capacity(name) / 2
        add([t for t in placeable if t.uses.get(name, 0) > half + _EPS])
    return found
