"""Cardinality and clique rows that strengthen a multiple resource's knapsacks.

The time-indexed model writes one knapsack row per time unit for a
multiple resource, ``sum_i a_i R(i, t) <= C(t)``
(:meth:`.constraints.Constraints._capacity_rows`). Its LP lets many users
run a fraction each where no two or three of them fit together, and CBC
spends long root cut passes (knapsack covers) lifting it. The rows here
state a priori, for each unit ``t`` with the users that may run there,
what the covers would find:

* cardinality rows: sorted by amount, largest first, the users ``P_m``
  down to the ``m``-th can have at most ``k_m`` of them running, ``k_m``
  being how many of ``P_m``'s smallest fit in ``C(t)`` together:
  ``sum_{i in P_m} R(i, t) <= k_m``. ``k_m`` grows with ``m``; only the
  largest ``P_m`` of each ``k_m`` is written (it implies the smaller
  ones), and only where the knapsack row does not already imply it (the
  ``k_m`` smallest leave room in ``C(t)``) and it can bind
  (``m > k_m``);
* clique rows: the conflict graph of a knapsack (two users conflict when
  ``a_i + a_j > C``) is a threshold graph; its maximal cliques are the
  users above ``C / 2`` (a cardinality row with ``k = 1``) and, for each
  user ``j`` at most ``C / 2``, ``j`` with the users ``a_i > C - a_j``:
  ``R(j, t) + sum_i R(i, t) <= 1``.

Both are valid for every integer plan (a cardinality row counts users
that cannot all run at once; a clique's members conflict pairwise), and
``C(t)`` is the unit's own capacity, so capacity steps are honoured.

Measured (``tools/bench --suite campaign --solvers cbc,cpsat --time-limit
20 --only 15-multiple|15-all``): see docs/benchmarks.md, "Stronger rows
for multiple resources".
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


def cardinality_sets(
    amounts: Sequence[float], capacity: float
) -> list[tuple[int, int]]:
    """The cardinality rows of one unit as ``(m, k)``: at most ``k`` of the
    ``m`` largest amounts may be in use together.

    ``amounts`` must be sorted largest first. A row is kept where it can
    bind (``m > k``), where no larger set has the same ``k`` (that set's
    row implies it), where ``k >= 1`` (``k = 0`` is the knapsack row
    itself: its users exceed the capacity alone) and where the knapsack
    row does not imply it: its LP lets ``k`` smallest run and the next
    fill what is left, so with no room left it already caps the count.
    """
    # Per m: k_m and the room the k_m smallest leave; k_m never falls
    # as m grows, so the last m of each k is the set to keep.
    last: dict[int, tuple[int, float]] = {}
    for m in range(1, len(amounts) + 1):
        total = 0.0
        k = 0
        for amount in reversed(amounts[:m]):
            if total + amount > capacity + EPS:
                break
            total += amount
            k += 1
        last[k] = (m, capacity - total)
    return [
        (m, k)
        for k, (m, room) in last.items()
        if k >= 1 and m > k and room > EPS
    ]


def clique_sets(
    amounts: Sequence[float], capacity: float
) -> list[tuple[int, int]]:
    """The clique rows of one unit beyond the cardinality rows, as
    ``(j, p)``: user ``j`` (at most half the capacity) conflicts with each
    of the ``p`` largest users, which conflict pairwise.

    ``amounts`` must be sorted largest first. For each ``j`` at most
    ``capacity / 2``, ``p`` counts the users with ``a_i > capacity -
    a_j``; the clique is kept when ``p >= 1``. Each is maximal among
    cliques (``j`` and another user at most half the capacity fit
    together), but one may lie inside a cardinality row with ``k = 1``
    (``j`` next after the ``p`` largest): :func:`strengthening_rows`
    leaves those out.
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
    """The cardinality and clique rows of one multiple resource, as
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
    counted = cardinality_sets(amounts, capacity)
    sets = [(present[:m], k) for m, k in counted]
    # A clique inside the k = 1 row (j right after the p largest) is
    # implied by it.
    pairwise = max((m for m, k in counted if k == 1), default=0)
    sets.extend(
        ([*present[:p], present[j]], 1)
        for j, p in clique_sets(amounts, capacity)
        if j >= pairwise
    )
    return sets
