"""How many forced tasks a multiple resource can run at once (pure).

Part of :func:`~fsw_scheduler.analysis.proofs.infeasibility`: forced
users of a multiple resource of which no ``m + 1`` fit in its capacity
together run at most ``m`` at a time, so over an interval ``[a, b)``
their least overlaps with it must fit in ``m`` lanes of ``b - a`` units.
The energetic test (work against capacity) misses this: five tasks each
needing 34 % of the capacity need only 1.7 lengths of energy per
length of time. :func:`least_overlaps` is the interval sweep of this
test, of the "no two at once" cliques and of the energetic test.
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING

from ..model.plan import Blocker

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator, Mapping, Sequence

    from ..model.problem import Problem, Task
    from .domains import Domain

_EPS = 1e-9

#: "At most m at once" (:func:`crowded`) is tried up to this m: above
#: it the energetic test (work against capacity) is nearly as strong.
MAX_LANES = 8


def _lanes(amounts: list[float], capacity: float) -> int:
    """How many of ``amounts`` (sorted, smallest first) fit together in
    ``capacity``: the most that can run at once."""
    total, count = 0.0, 0
    for amount in amounts:
        total += amount
        if total > capacity + _EPS:
            break
        count += 1
    return count


def crowded(
    problem: Problem,
    forced: list[Task],
    domains: Mapping[str, Domain],
    resource: str,
    profile: list[float],
    stop: Callable[[], bool] | None = None,
) -> tuple[Blocker, ...]:
    """The "at most m at once" test of one multiple resource.

    Of the forced users taken by decreasing use, the largest set of which
    no ``m + 1`` fit together in the capacity, for each ``m`` from 2 to
    :data:`MAX_LANES` (``m = 1`` is the "no two at once" cliques'): at each
    unit at most ``m_t`` of them run (``m_t`` from the capacity at ``t``),
    so over ``[low, high)`` their least overlaps with it cannot exceed the
    sum of ``m_t``. Five tasks each needing 34 % of the capacity in a
    window shorter than 2.5 lengths need 1.7 lengths of energy, which the
    energetic test lets pass; two lanes cannot hold them. Interval ends
    are those of the energetic test (:func:`overloaded`).
    """
    users = sorted(
        (task for task in forced if task.uses.get(resource, 0) > 0),
        key=lambda t: (-t.uses[resource], t.id),
    )
    peak = max(profile, default=0.0)
    # The largest prefix for each number of lanes.
    chosen: dict[int, list[Task]] = {}
    # Smallest first: the users are by decreasing use.
    ascending = [t.uses[resource] for t in reversed(users)]
    for size in range(3, len(users) + 1):
        lanes = _lanes(ascending[len(users) - size :], peak)
        if lanes > MAX_LANES:
            break
        if 2 <= lanes < size:
            chosen[lanes] = users[:size]
    for lanes, members in sorted(chosen.items()):
        amounts = ascending[len(users) - len(members) :]
        per_unit = {cap: _lanes(amounts, cap) for cap in set(profile)}
        allowed = list(
            itertools.accumulate((per_unit[c] for c in profile), initial=0)
        )
        spans = [(task, domains[task.id]) for task in members]
        found = overloaded(problem, spans, allowed, stop, lanes)
        if found is not None:
            inside, need, low, high, rounds = found
            if rounds:
                why = (
                    f"{rounds} of them must run one after the other: "
                    f"{need} time units in [{low}, {high}), which has "
                    f"{high - low}"
                )
            else:
                why = (
                    f"they need {need} time units in [{low}, {high}), "
                    f"where {lanes} at a time have "
                    f"{room(problem, allowed, low, high)}"
                )
            detail = (
                f"{', '.join(inside)} must be scheduled and at most {lanes} "
                f"of them can run at once on {resource} (any {lanes + 1} "
                f"need more than its capacity {peak:g}), but {why}"
            )
            return tuple(Blocker(name, "multiple", detail) for name in inside)
    return ()


def room(
    problem: Problem, allowed: Sequence[float], low: int, high: int
) -> float:
    """``allowed[high] - allowed[low]``, the ends clipped to the horizon
    (``allowed``: a running sum from the problem's start, of lanes or of
    capacity)."""
    last = len(allowed) - 1
    first = min(max(low - problem.start, 0), last)
    end = min(max(high - problem.start, 0), last)
    return allowed[end] - allowed[first]


def overloaded(
    problem: Problem,
    spans: list[tuple[Task, Domain]],
    allowed: list[int],
    stop: Callable[[], bool] | None = None,
    lanes: int = 1,
) -> tuple[list[str], int, int, int, int] | None:
    """The first interval whose tasks cannot fit: (task ids, need, low,
    high, rounds), or None (also once ``stop()`` is true).

    Over ``[low, high)`` each task runs at least its least overlap with
    it, whatever its start. They cannot fit when those overlaps exceed
    the room ``allowed`` gives (``rounds`` 0), or, at most ``lanes`` of
    them running at once (so the pieces are ``lanes`` machines' work, an
    interval graph being coloured by its largest clique), when of the
    ``k x lanes + 1`` longest pieces ``k + 1`` share a lane: the ``k + 1``
    shortest of them, ``rounds = k + 1``, longer in all than the interval
    (five pieces of 7 on two lanes need 21 units, not 17.5).
    """
    for low, high, inside, pieces in least_overlaps(spans, stop):
        need = sum(pieces)
        if need > room(problem, allowed, low, high):
            return inside, need, low, high, 0
        width = high - low
        if lanes > 1 and len(pieces) > lanes and need > width:
            found = _shared_lane(pieces, lanes, width)
            if found is not None:
                return inside, found[1], low, high, found[0]
    return None


def least_overlaps(
    spans: Sequence[tuple[Task, Domain]],
    stop: Callable[[], bool] | None = None,
    *,
    lows: Sequence[int] | None = None,
    highs: Sequence[int] | None = None,
) -> Iterator[tuple[int, int, list[str], list[int]]]:
    """Each interval ``[low, high)`` between the ends of the tasks'
    ranges and of their compulsory parts, with the tasks that overlap it
    whatever their starts and those least overlaps: (low, high, task ids,
    overlaps), the tasks in ``spans`` order. Ends once ``stop()`` is
    true. ``lows`` and ``highs`` (sorted) replace the intervals' ends
    (the energy rows of :mod:`.energetic` take their own)."""
    if lows is None:
        lows = sorted(
            {d.earliest for _, d in spans} | {d.latest for _, d in spans}
        )
    if highs is None:
        highs = sorted(
            {d.latest + t.length for t, d in spans}
            | {d.earliest + t.length for t, d in spans}
        )
    # (id, length, earliest end, latest start): a task overlaps
    # [low, high) whatever its start only if its earliest end is past low
    # and its latest start before high.
    ranges = [
        (t.id, t.length, d.earliest + t.length, d.latest) for t, d in spans
    ]
    for low in lows:
        if stop is not None and stop():
            return
        after = [r for r in ranges if r[2] > low]
        for high in highs:
            if high <= low:
                continue
            width = high - low
            pieces, inside = [], []
            for name, length, early_end, latest in after:
                if latest >= high:
                    continue
                pieces.append(
                    min(length, width, early_end - low, high - latest)
                )
                inside.append(name)
            yield low, high, inside, pieces


def _shared_lane(
    pieces: list[int], lanes: int, width: int
) -> tuple[int, int] | None:
    """(k + 1, their sum) when the ``k + 1`` shortest of the ``k x lanes
    + 1`` longest ``pieces`` exceed ``width``, for the first such ``k``;
    else None."""
    longest = sorted(pieces, reverse=True)
    k = 1
    while k * lanes + 1 <= len(longest):
        top = k * lanes + 1
        together = sum(longest[top - k - 1 : top])
        if together > width:
            return k + 1, together
        k += 1
    return None
