"""Clique rows that strengthen a multiple resource's knapsack rows.

The time-indexed model writes one knapsack row per time unit for a
multiple resource, ``sum_i a_i R(i, t) <= C(t)``
(:meth:`.constraints.Constraints._capacity_rows`). Its LP lets users that
cannot run together each run a fraction (two users of 6 under a capacity
of 10: 1.67 of them), and CBC spent long root cut passes lifting it. The
rows here state a priori, for each unit ``t`` with the users that may run
there, what no two of them allow. Two users conflict when ``a_i + a_j >
C(t)``; the conflict graph of a knapsack is a threshold graph, whose
maximal cliques are easy to list. Sorted by amount, largest first:

* the pairwise prefix: the largest ``m`` users whose two smallest
  conflict (all but the last are above ``C / 2``),
  ``sum_{i <= m} R(i, t) <= 1`` (:func:`pairwise_prefix`);
* for each user ``j`` at most ``C / 2`` (two of those never conflict),
  ``j`` with the users ``a_i > C - a_j``: ``R(j, t) + sum_i R(i, t) <= 1``
  (:func:`clique_sets`).

A row is written only where it can bind (two or more users may run at
``t``) and the knapsack row does not imply it. Every row holds for every
integer plan (its users conflict pairwise), and ``C(t)`` is the unit's
own capacity, so capacity steps are honoured.

Measured with the product's solve (``tools/bench --suite campaign
--solvers cbc,cpsat --time-limit 20 --only 15-multiple|15-all``, beside
the code without the rows, twice): on seeds 7 and 8 (not tuned on), 14
problems per class and generator, the summed wall time of the paper
``all`` problems went 38.7 -> 28.0 s and 30.2 -> 21.4 s, the broad ones
104.6 -> 99.2 s and 89.9 -> 89.9 s (their unproved problems take the
limit either way); the multiple class stayed where it was (paper
26.0 -> 27.9 s, broad 74.7 -> 67.0 s). Neither class meets the target
of 3x CP-SAT's median and 20x its time on the worst problem. Details
in docs/benchmarks.md, "Clique rows for multiple resources".

Cardinality rows for larger counts as well (of the ``m`` largest users
at most ``k`` run, ``k`` as many of their smallest as fit) were measured
and not kept: on the 14 problems of seeds 1-4 (tuning) where the rows
changed CBC's time most, CBC's CPU time summed to 32.2 s with them,
31.9 s with them and no cliques, 28.9 s with the cliques alone, 47.1 s
without any row (two of those not proved in 20 s).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Iterator, Sequence

    from ...model.problem import Task
    from .program import Terms
    from .variables import Variables

#: Amounts within this of the capacity count as equal (float amounts).
EPS = 1e-9


def pairwise_prefix(amounts: Sequence[float], capacity: float) -> int:
    """How many of the largest amounts conflict pairwise, where that set's
    row ``sum R <= 1`` says more than the knapsack row; else 0.

    ``amounts`` must be sorted largest first. The ``m`` largest conflict
    pairwise iff their two smallest do (``a_{m-1} + a_m > C``); the row
    needs ``m >= 2`` and is implied by the knapsack row when even the
    smallest of them needs the whole capacity.
    """
    size = 0
    for m in range(2, len(amounts) + 1):
        if amounts[m - 2] + amounts[m - 1] <= capacity + EPS:
            break
        size = m
    if size and amounts[size - 1] >= capacity - EPS:
        return 0
    return size


def clique_sets(
    amounts: Sequence[float], capacity: float
) -> list[tuple[int, int]]:
    """The clique rows of one unit beyond the pairwise prefix, as
    ``(j, p)``: user ``j`` (at most half the capacity) conflicts with each
    of the ``p`` largest users, which conflict pairwise.

    ``amounts`` must be sorted largest first. For each ``j`` at most
    ``capacity / 2``, ``p`` counts the users with ``a_i > capacity -
    a_j``; the clique is kept when ``p >= 1``. Each is maximal among
    cliques (``j`` and another user at most half the capacity fit
    together), but one may lie inside the :func:`pairwise_prefix` (``j``
    next after the ``p`` largest): :func:`strengthening_rows` leaves
    those out.
    """
    half = capacity / 2
    cliques: list[tuple[int, int]] = []
    for j, small in enumerate(amounts):
        if small > half + EPS:
            continue
        p = sum(1 for big in amounts if big > capacity - small + EPS)
        # p largest all exceed capacity - small >= half: they are before j.
        if p:
            cliques.append((j, p))
    return cliques


def strengthening_rows(
    variables: Variables,
    users: Sequence[tuple[Task, float]],
    capacity: Sequence[float],
    start: int,
) -> Iterator[tuple[Terms, float]]:
    """The clique rows of one multiple resource, as
    ``(terms, rhs)`` of ``terms <= rhs``, unit by unit.

    Parameters
    ----------
    variables
        The step variables (``R(i, t)`` is written on them).
    users
        The placeable tasks using the resource and their amounts (> 0).
    capacity
        The capacity of every unit, index ``i`` for unit ``start + i``.
    start
        The first unit.
    """
    horizon = len(capacity)
    # Users that may run at each unit, largest amount first (ties in
    # problem order: rows are the same run after run).
    order = sorted(range(len(users)), key=lambda idx: (-users[idx][1], idx))
    running: list[list[int]] = [[] for _ in range(horizon)]
    for idx in order:
        task, _ = users[idx]
        for time in variables.running_units(task, start, horizon):
            running[time - start].append(idx)
    cache: dict[tuple[tuple[int, ...], float], list[tuple[list[int], int]]]
    cache = {}
    for offset, (present, top) in enumerate(
        zip(running, capacity, strict=True)
    ):
        if len(present) < 2:
            continue
        key = (tuple(present), top)
        sets = cache.get(key)
        if sets is None:
            sets = _sets([users[idx][1] for idx in present], top, present)
            cache[key] = sets
        time = start + offset
        for members, bound in sets:
            terms: Terms = {}
            for idx in members:
                variables.add_running([terms], users[idx][0], 1.0, time)
            yield terms, float(bound)


def _sets(
    amounts: list[float], capacity: float, present: list[int]
) -> list[tuple[list[int], int]]:
    """The rows of one unit as (users, bound); ``amounts`` of ``present``,
    largest first."""
    pairwise = pairwise_prefix(amounts, capacity)
    sets = [(present[:pairwise], 1)] if pairwise else []
    # A clique inside the pairwise set (j its last, right after the p
    # largest) is implied by its row.
    sets.extend(
        ([*present[:p], present[j]], 1)
        for j, p in clique_sets(amounts, capacity)
        if j >= pairwise
    )
    return sets
