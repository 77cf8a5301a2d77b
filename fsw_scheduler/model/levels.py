"""Consumable level arithmetic: what a plan leaves in each store.

One place computes levels, so that the replan rules (the prediction a
replan starts from), the published profiles and the pictures agree:
:func:`predicted_levels` at one time unit, :func:`resource_profiles` and
:func:`lost_charge` unit by unit over a plan. A consumable with a
capacity is walked unit by unit, ``min(max, level - net use)``, since
generation a full store cannot take is lost.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ..errors import FieldIssue, InputError

if TYPE_CHECKING:
    from collections.abc import Iterable, Mapping, Sequence

    from .plan import Activity, Plan
    from .problem import Problem, Task

__all__ = [
    "check_now",
    "cut_to_capacity",
    "levels_at",
    "lost_charge",
    "predicted_levels",
    "resource_profiles",
    "tasks_by_id",
    "walk_level",
]


def predicted_levels(
    problem: Problem, plan: Plan, now: int
) -> dict[str, float]:
    """Consumable levels at the start of unit ``now`` if the plan ran so far.

    ``level = initial - sum(amount * units run before now)`` over the plan's
    activities, the initial level being the problem's (at
    ``problem.start``); a consumable with a capacity is walked unit by
    unit, ``min(max, level - net use)``.

    Parameters
    ----------
    problem
        The problem the plan solves.
    plan
        The running plan.
    now
        Time unit, ``>= problem.start``.

    Returns
    -------
    dict
        Resource name to level, for every consumable resource.
    """
    check_now(problem, now)
    spans = {
        a.task: (a.start, min(a.end, now))
        for a in plan.activities
        if a.start < now
    }
    return levels_at(problem, spans, now)


def levels_at(
    problem: Problem, spans: Mapping[str, tuple[int, int]], now: int
) -> dict[str, float]:
    """Consumable levels at the start of ``now``, given what ran before.

    The one computation behind :func:`predicted_levels` (a plan run as
    planned) and the execution state of a replan (the plan corrected by
    the reports): ``initial - amount * units run`` for a consumable
    without a capacity, the level walked unit by unit for one with a
    capacity (:func:`walk_level`).

    Parameters
    ----------
    problem
        The problem the tasks belong to (initial levels, capacities, uses).
    spans
        Task id to the units ``[since, until)`` it ran, all before ``now``.
    now
        Time unit, ``>= problem.start``.

    Returns
    -------
    dict
        Resource name to level, for every consumable resource.
    """
    runs = {
        task: max(0, until - since) for task, (since, until) in spans.items()
    }
    return _capped(problem, _levels(problem, runs), spans, now)


def _levels(problem: Problem, runs: Mapping[str, int]) -> dict[str, float]:
    levels = problem.resources.initial_levels
    for task in problem.tasks:
        units = runs.get(task.id, 0)
        for name, amount in task.uses.items():
            if name in levels and units:
                levels[name] -= amount * units
    return levels


def _capped(
    problem: Problem,
    levels: dict[str, float],
    spans: Mapping[str, tuple[int, int]],
    now: int,
) -> dict[str, float]:
    """``levels`` with every consumable that has a capacity walked again.

    Units run add up for a consumable without a capacity (``levels`` as
    :func:`_levels` gives them); with one, generation a full store cannot
    take is lost, so the level depends on when each unit ran and is
    walked unit by unit from the problem's start. So is a consumable with
    an external rate (it adds in every unit, ``external`` of the mission
    model).
    """
    ceilings = problem.resources.ceilings
    walked = [*ceilings, *problem.resources.changing]
    for name in dict.fromkeys(walked):
        if name not in levels:
            continue  # a binary or multiple resource
        levels[name] = walk_level(
            problem,
            spans,
            name,
            problem.resources.initial(name),
            (problem.start, now),
            ceilings.get(name),
        )
    return levels


def walk_level(
    problem: Problem,
    spans: Mapping[str, tuple[int, int]],
    name: str,
    level: float,
    window: tuple[int, int],
    top: float | None,
) -> float:
    """The level of a consumable with a capacity, walked over a window.

    Parameters
    ----------
    problem
        The problem the tasks belong to (their uses of ``name``).
    spans
        Task id to the units ``[since, until)`` it ran.
    name
        The consumable.
    level
        Its level at the start of ``window[0]``.
    window
        The units ``[first, last)`` to walk.
    top
        Its capacity (None: none).

    Returns
    -------
    float
        The level at the start of ``window[1]``: ``min(top, level +
        external - net use)`` unit by unit (:func:`walk`).
    """
    first, last = window
    # The external rate is negative use.
    rates = [
        0.0 - rate
        for rate in problem.resources.external_profile(
            name, first, max(0, last - first)
        )
    ]
    for task in problem.tasks:
        amount = task.uses.get(name, 0)
        span = spans.get(task.id)
        if not amount or span is None:
            continue
        for t in range(max(span[0], first), min(span[1], last)):
            rates[t - first] += amount
    levels, _ = walk(level, rates, top)
    if levels:
        return levels[-1]
    return level if top is None else min(top, level)


def walk(
    level: float, rates: Sequence[float], top: float | None
) -> tuple[list[float], list[float]]:
    """The one level walk: ``min(top, level - net use)`` unit by unit.

    Parameters
    ----------
    level
        Level at the start of the first unit (above ``top`` counts as
        full).
    rates
        Net use in each unit (negative amounts generate).
    top
        The capacity, or None for a store without one.

    Returns
    -------
    tuple
        The level at the end of each unit, and the amount cut off at the
        capacity in each unit (generation a full store cannot take).
    """
    if top is not None:
        level = min(top, level)
    levels, lost = [], []
    for used in rates:
        level -= used
        cut = 0.0
        if top is not None and level > top:
            level, cut = top, level - top
        levels.append(level)
        lost.append(cut)
    return levels, lost


def cut_to_capacity(
    problem: Problem, levels: Mapping[str, float]
) -> dict[str, float]:
    """``levels`` with each one above its consumable's capacity cut to it.

    A store cannot hold more than its capacity: a measurement above it
    (sensor noise) means full.
    """
    ceilings = problem.resources.ceilings
    return {
        name: min(level, ceilings.get(name, math.inf))
        for name, level in levels.items()
    }


def check_now(problem: Problem, now: int) -> None:
    """Refuse a ``now`` before the problem's start.

    Raises
    ------
    InputError
        At path ``now``, for the ``replan`` document.
    """
    if now < problem.start:
        raise InputError(
            [
                FieldIssue(
                    "now",
                    f"{now} is before the problem start {problem.start}",
                )
            ],
            "replan",
        )


def tasks_by_id(problem: Problem) -> dict[str, Task]:
    """Every task of ``problem`` by its id, in problem order."""
    return {task.id: task for task in problem.tasks}


def _known_activities(
    problem: Problem, activities: Iterable[Activity]
) -> list[tuple[Activity, Task]]:
    tasks = tasks_by_id(problem)
    pairs = []
    for activity in activities:
        task = tasks.get(activity.task)
        if task is None:
            raise ValueError(
                f"plan activity {activity.task!r} is not a task of the problem"
            )
        pairs.append((activity, task))
    return pairs


def resource_profiles(problem: Problem, plan: Plan) -> dict[str, list[float]]:
    """Usage of each multiple resource and level of each consumable.

    Parameters
    ----------
    problem
        The problem the plan solves.
    plan
        The plan; only its activities are read.

    Returns
    -------
    dict[str, list[float]]
        One list of ``problem.horizon`` values per multiple and consumable
        resource, in declaration order. Index ``i`` is time unit
        ``problem.start + i``. A multiple resource gets the summed amount
        of the activities running in that unit; a consumable gets its level
        at the end of that unit: initial level minus amount * units run up
        to and including it (negative amounts generate), and never above
        the consumable's capacity when it has one (the level at the end of
        ``t`` is ``min(max, level at t-1 - net use in t)``). Parts of
        activities outside the horizon are ignored.

    Raises
    ------
    ValueError
        If an activity names a task that is not in the problem.
    """
    rate = _rates(problem, plan)
    profiles: dict[str, list[float]] = {}
    for name in problem.resources.multiple:
        profiles[name] = rate[name]
    for name, levels in _consumable_walk(problem, rate).items():
        profiles[name] = levels[0]
    return profiles


def lost_charge(problem: Problem, plan: Plan) -> dict[str, list[float]]:
    """What each consumable with a capacity loses per unit of the plan.

    Generation that a full store cannot take is lost: at index ``i``, the
    amount cut off at the end of unit ``problem.start + i`` (see
    :func:`resource_profiles`). Consumables without a capacity lose
    nothing and are not listed.

    Raises
    ------
    ValueError
        If an activity names a task that is not in the problem.
    """
    rate = _rates(problem, plan)
    ceilings = problem.resources.ceilings
    return {
        name: lost
        for name, (_, lost) in _consumable_walk(problem, rate).items()
        if name in ceilings
    }


def _rates(problem: Problem, plan: Plan) -> dict[str, list[float]]:
    """Summed amount of the running activities per unit and resource."""
    resources = problem.resources
    rate = {name: [0.0] * problem.horizon for name in resources.multiple}
    # The external rate of a consumable is negative use.
    rate.update(
        {
            name: [
                0.0 - r
                for r in resources.external_profile(
                    name, problem.start, problem.horizon
                )
            ]
            for name in resources.consumable
        }
    )
    for activity, task in _known_activities(problem, plan.activities):
        first = max(activity.start, problem.start) - problem.start
        last = min(activity.end, problem.end) - problem.start
        for name, amount in task.uses.items():
            values = rate.get(name)
            if values is None:  # binary resources have no profile
                continue
            for idx in range(first, last):
                values[idx] += amount
    return rate


def _consumable_walk(
    problem: Problem, rate: Mapping[str, list[float]]
) -> dict[str, tuple[list[float], list[float]]]:
    """Level at the end of each unit, and the amount lost at the ceiling."""
    ceilings = problem.resources.ceilings
    walks = {}
    for name, initial in problem.resources.initial_levels.items():
        walks[name] = walk(float(initial), rate[name], ceilings.get(name))
    return walks
