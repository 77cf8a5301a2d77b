"""Spans of the horizon where the checker's resource rules read alike.

The checker (:mod:`.check`) judges binary, multiple and consumable
resources on *spans*: runs of units with the same running users,
windows, capacity and external rate. Within a span each unit is judged
alike, and a consumable's level moves by the same net rate every unit,
so a span is judged in closed form: a check costs the plan's size, not
the horizon's. Pure: the standard library only.
"""

from __future__ import annotations

from itertools import pairwise
from typing import TYPE_CHECKING, NamedTuple

if TYPE_CHECKING:
    from collections.abc import Iterable, Iterator, Sequence

    from ..model.plan import Activity
    from ..model.problem import Problem, Task

TOLERANCE = 1e-9
"""Slack allowed on float resource sums (capacity and consumable level)."""


def resource_users(
    tasks: dict[str, Task], known: Sequence[Activity], resource: str
) -> list[tuple[Activity, float]]:
    return [
        (a, tasks[a.task].uses[resource])
        for a in known
        if resource in tasks[a.task].uses
    ]


class Hit(NamedTuple):
    """Time units ``t..last`` where a resource rule is broken alike."""

    t: int
    key: tuple[str, ...]  # who is running: consecutive equal keys merge
    value: float  # use (multiple) or level (consumable); count (binary)
    last: int  # the last unit of the span (``t`` for a single unit)


def runs(hits: Sequence[Hit]) -> Iterator[list[Hit]]:
    """Group consecutive time units with the same running tasks.

    One overlap of two long tasks would otherwise fill a report with a
    line per time unit; a run becomes one violation naming its span.
    """
    run: list[Hit] = []
    for hit in hits:
        if run and (hit.t != run[-1].last + 1 or hit.key != run[-1].key):
            yield run
            run = []
        run.append(hit)
    if run:
        yield run


def span_text(run: Sequence[Hit]) -> str:
    first, last = run[0].t, run[-1].last
    return f"t={first}" if first == last else f"t={first}..{last}"


def segments(
    problem: Problem,
    users: Sequence[tuple[Activity, float]],
    cuts: Iterable[int] = (),
) -> Iterator[tuple[int, int, list[tuple[Activity, float]]]]:
    """Yield the horizon as spans ``[t, end)`` with the users running.

    A span ends where a user starts or ends or at one of ``cuts`` (where
    a window, a capacity step or an external rate changes), so within
    one every unit has the same running users and the same rules: each
    unit of it would be judged alike. Walking spans instead of units
    keeps the check linear in the plan, not in the horizon (a horizon of
    10,000 units took seconds per check unit by unit).
    """
    low, high = problem.start, problem.start + problem.horizon
    marks = {low, high}
    for a, _ in users:
        marks.update((a.start, a.end))
    marks.update(cuts)
    bounds = sorted(t for t in marks if low <= t <= high)
    for t, end in pairwise(bounds):
        yield (
            t,
            end,
            [(a, amount) for a, amount in users if a.start <= t < a.end],
        )


def running_key(running: Iterable[tuple[Activity, float]]) -> tuple[str, ...]:
    return tuple(a.task for a, _ in running)


def steps_at(steps: Sequence[tuple[int, float]], t: int) -> float | None:
    """The value of the last step at or before ``t`` (None before all)."""
    value = None
    for since, amount in steps:
        if since > t:
            break
        value = float(amount)
    return value


def level_after(level: float, rate: float, units: int, top: float) -> float:
    """The level after ``units`` units of net change ``rate`` from
    ``level`` (at most ``top``): what a unit by unit sum gives."""
    if units <= 0:
        return level
    return min(top, level + units * rate)


def below_zero(
    t0: int, end: int, level: float, rate: float, top: float
) -> list[Hit]:
    """Hits for the units of ``[t0, end)`` whose level is below zero.

    The level after ``k`` units is :func:`level_after` (``k`` from 1):
    falling (``rate < 0``) it is below zero from some ``k`` to the end,
    rising only up to some ``k``. At most two hits: the first unit (its
    level is the run's first) and the rest (their lowest level).
    """
    units = end - t0
    if units <= 0:
        return []

    def below(k: int) -> bool:
        return level_after(level, rate, k, top) < -TOLERANCE

    if rate < 0:
        if not below(units):
            return []
        low, high = 1, units  # first k below zero: in [low, high]
        while low < high:
            mid = (low + high) // 2
            if below(mid):
                high = mid
            else:
                low = mid + 1
        first, last = low, units
    else:
        if not below(1):
            return []
        low, high = 1, units  # last k below zero: in [low, high]
        while low < high:
            mid = (low + high + 1) // 2
            if below(mid):
                low = mid
            else:
                high = mid - 1
        first, last = 1, low
    hits = [
        Hit(
            t0 + first - 1,
            (),
            level_after(level, rate, first, top),
            t0 + first - 1,
        )
    ]
    if last > first:
        lowest = min(
            level_after(level, rate, first + 1, top),
            level_after(level, rate, last, top),
        )
        hits.append(Hit(t0 + first, (), lowest, t0 + last - 1))
    return hits
