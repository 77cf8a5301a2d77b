"""Busy-time and energy rows: what shared users take, without order columns.

The order rows of :mod:`.constraints` are big-M rows, and their LP
relaxation lets every user of a resource start at its earliest time at
once: the root bound ignores the resource. These rows bound the starts
from below without any order column.

For a set ``S`` of users of a resource of capacity ``C``, each task
``j`` using ``a_j`` for ``p_j`` units of time (energy ``w_j = a_j p_j``)
and none starting before ``E``: the load profile ``u(t) <= C`` holds the
energy ``W = sum w_j`` of the scheduled users, and ``sum_j w_j (s_j - E
+ p_j / 2)`` is the integral of ``(t - E) u(t)``, which is least when
``u = C`` from ``E`` on: at least ``W^2 / (2 C)`` (the mean busy time
bound). On one machine (users that pairwise never overlap, ``a = C =
1``) it is Queyranne's inequality, ``sum p_j (s_j - E) >= sum_{i<j} p_i
p_j``. Only the scheduled users count, so the right-hand side is
quadratic in the "scheduled" binaries ``y``; each product ``y_i y_j`` is
replaced by ``y_i + y_j - 1``, which is never above it, and a left-out
user keeps ``s_j >= E``: the row holds in every plan.

The sets written for a resource (see :func:`busy_sets`) are those whose
rows define the LP optimum of the one-machine problem: users by release
(every user starting at or after some user's earliest start) and the
prefixes of Smith's order (delay cost per energy, highest first).
Only binary resources get busy-time rows (see :func:`add_busy_rows`). On the
15-task binary problems (paper and broad) they lifted the root bound
and, with CBC's cuts off, took the slowest from 0.20-0.29 s to 0.09 s
(b15-binary-0) and 0.11 to 0.05 s (b15-binary-2).

:func:`add_energy_rows` adds, on the "scheduled" columns alone, the
kept-set relaxation's energy rows (:mod:`fsw_scheduler.analysis.
energetic`): what the users must run inside an interval within what
the resource gives there, for binary resources and multiple ones alike.
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING

from ....analysis import keptset
from ..program import GE, LE

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    from ....model.problem import Problem, Task
    from ..program import Program
    from .variables import Variables

#: Rows are written for sets of at most this many users, so that a
#: resource of many users gets rows of bounded density.
MAX_SET = 40


def busy_sets(
    users: Sequence[tuple[Task, float]], earliest: dict[str, int]
) -> list[list[int]]:
    """Index sets of ``users`` that get a row (fixed order, no repeats).

    Parameters
    ----------
    users
        Tasks with their amounts.
    earliest
        Earliest start of each task.

    Returns
    -------
    list of list of int
        Sets of two or more indices into ``users``: for each distinct
        earliest start, the users released from it on; and the prefixes
        of the users by delay cost per energy, highest first.
    """
    count = len(users)
    seen: set[frozenset[int]] = set()
    sets: list[list[int]] = []

    def keep(members: list[int]) -> None:
        key = frozenset(members)
        if 2 <= len(members) <= MAX_SET and key not in seen:
            seen.add(key)
            sets.append(sorted(members))

    for release in sorted({earliest[task.id] for task, _ in users}):
        keep([k for k in range(count) if earliest[users[k][0].id] >= release])
    smith = sorted(
        range(count),
        key=lambda k: (
            -users[k][0].delay_cost / (users[k][1] * users[k][0].length),
            k,
        ),
    )
    for size in range(2, count + 1):
        keep(smith[:size])
    return sets


def add_busy_row(
    program: Program,
    variables: Variables,
    members: Sequence[tuple[Task, float]],
    capacity: float,
) -> None:
    """The mean busy time row of ``members`` (tasks and amounts).

    ``sum_j w_j s_j - sum_j c_j y_j >= E W - P / C`` with
    ``c_j = w_j (W - w_j / 2) / C - a_j p_j^2 / 2`` and
    ``P = sum_{i<j} w_i w_j``: the bound of the module docstring with
    each ``y_i y_j`` replaced by ``y_i + y_j - 1``. Coefficients are
    divided by the largest energy, to keep them near the others'.
    """
    release = min(variables.domains[task.id].earliest for task, _ in members)
    energies = [amount * task.length for task, amount in members]
    total = sum(energies)
    pairs = sum(a * b for a, b in itertools.combinations(energies, 2))
    scale = max(energies)
    terms: dict[int, float] = {}
    for (task, amount), energy in zip(members, energies, strict=True):
        terms[variables.start(task.id)] = energy / scale
        gain = (
            energy * (total - energy / 2) / capacity
            - amount * task.length**2 / 2
        )
        terms[variables.scheduled(task.id)] = -gain / scale
    program.add_row(terms, GE, (release * total - pairs / capacity) / scale)


def add_busy_rows(
    program: Program,
    variables: Variables,
    problem: Problem,
    users_of: Callable[[str], list[tuple[Task, float]]],
) -> None:
    """Queyranne's rows for the users of every binary resource.

    Multiple resources get none: on the 15-task multiple problems (paper
    and broad) both the load rows and the one-machine rows of cliques of
    users that pairwise exceed the capacity made CBC slower (b15-multiple-3:
    1.7-2.3 s without, 3.1 s with load rows, 3.4-4.4 s with clique rows),
    although they raised the root bound.
    """
    earliest = {
        task_id: domain.earliest
        for task_id, domain in variables.domains.items()
        if not domain.empty
    }
    for resource in problem.resources.binary:
        machine = [(task, 1.0) for task, _ in users_of(resource)]
        for members in busy_sets(machine, earliest):
            add_busy_row(program, variables, [machine[k] for k in members], 1)


def add_energy_rows(
    program: Program, variables: Variables, problem: Problem
) -> int:
    """The kept-set relaxation's energy rows, on the "scheduled" columns.

    :func:`~fsw_scheduler.analysis.keptset.energy` (the placeable
    tasks' :func:`~fsw_scheduler.analysis.energetic.energy_rows`): over an
    interval, the least time each user must run inside it, summed over
    the scheduled users, within what the resource gives there. The order
    rows are big-M rows and the busy-time rows bound the starts only: a
    camera asked for more time than the horizon has still lets the LP
    keep every task, and its bound is the delays alone (broad seed 133's
    b15-binary-3: 426 camera units asked of 336; CBC's bound stayed at
    6,126 under a plan of 130,218 for 20 s; with these rows `optimal` in
    0.6 s, CP-SAT 0.08 s). Rows are written only where the users
    together exceed the interval, the most overloaded first, so a day
    that fits gets none. The problem here is the model's (blocks added,
    capacities at their peak: :mod:`.blocks`), whose blocks are pinned
    users that take their share of each interval. On the 168 15-task
    binary problems of ``tools/bench --only 15-bin`` seeds 121-132 (both
    generators) 13.9 -> 11.1 s in total, none slower by more than 0.05
    s; on the 84 multiple ones of seeds 127-132, 12.0 -> 11.7 s. The
    large parts' relaxation leaves them out (see
    :class:`~fsw_scheduler.solving.relaxed._Apart`).

    Returns
    -------
    int
        The rows written.
    """
    uses, limits = keptset.energy(problem, variables.domains)
    written = 0
    for row, limit in enumerate(limits):
        terms: dict[int, float] = {}
        for task_id, amounts in uses.items():
            if amounts[row] > 0:
                column = variables.scheduled(task_id)
                terms[column] = terms.get(column, 0.0) + amounts[row]
        written += program.add_row(terms, LE, limit)
    return written
