"""Alternatives: groups of options, indexed, and what a plan makes of them.

A group (:class:`~fsw_scheduler.model.problem.Alternative`) holds options;
an option's tasks are scheduled all together or not at all, and at most
one option of a group is. This module is the one place that reads a set
of scheduled tasks against the groups: which option a plan chose
(:func:`chosen`), and the unscheduled cost of the objective
(:func:`unscheduled_cost`: a group left out costs its own schedule cost
once, its members' costs are not counted). Pure: no solver, no bus, no
clock.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import msgspec

if TYPE_CHECKING:
    from collections.abc import Collection, Iterable

    from .problem import Alternative, Problem, Task

__all__ = [
    "Groups",
    "chosen",
    "index",
    "keep_one_option",
    "kept_alternatives",
    "left_out",
    "mandatory_group_missing",
    "of",
    "settle",
    "unscheduled_cost",
]


class Groups:
    """The groups of a problem, indexed by member task.

    Parameters
    ----------
    alternatives
        The problem's groups (problem-level and goals' together).

    Attributes
    ----------
    groups
        The groups, in order.
    member
        Member task id to (group index, option index); a task in several
        options (an invalid problem) keeps the first.
    """

    def __init__(self, alternatives: tuple[Alternative, ...]) -> None:
        self.groups = alternatives
        self.member: dict[str, tuple[int, int]] = {}
        for g_idx, group in enumerate(alternatives):
            for o_idx, option in enumerate(group.options):
                for name in option:
                    self.member.setdefault(name, (g_idx, o_idx))

    def __bool__(self) -> bool:
        return bool(self.groups)

    def option_of(self, task_id: str) -> tuple[Alternative, int] | None:
        """The group and option index of a member task, None otherwise."""
        where = self.member.get(task_id)
        if where is None:
            return None
        return self.groups[where[0]], where[1]

    def partners(self, task_id: str) -> tuple[str, ...]:
        """The other tasks of ``task_id``'s option (empty for a non-member)."""
        found = self.option_of(task_id)
        if found is None:
            return ()
        group, o_idx = found
        return tuple(n for n in group.options[o_idx] if n != task_id)

    def required(self, task: Task) -> bool:
        """True if every plan must schedule ``task``.

        A pinned task, or a mandatory one (schedule cost 0) that is no
        member of a group: a member of a mandatory group is not required
        on its own, one option of its group is.
        """
        if task.fixed_start is not None:
            return True
        return task.schedule_cost == 0 and task.id not in self.member

    def rivals(self, task_id: str) -> tuple[str, ...]:
        """The tasks of the other options of ``task_id``'s group."""
        found = self.option_of(task_id)
        if found is None:
            return ()
        group, o_idx = found
        return tuple(
            name
            for k, option in enumerate(group.options)
            if k != o_idx
            for name in option
        )


_EMPTY = Groups(())
# Index per alternatives tuple: a problem is immutable and its groups are
# read for every task; the tuple is kept alive by the entry, so its id is
# not reused while cached.
_CACHE: dict[int, tuple[tuple[Alternative, ...], Groups]] = {}
_CACHE_SIZE = 64


def index(alternatives: tuple[Alternative, ...]) -> Groups:
    """The :class:`Groups` of ``alternatives``, built once per tuple."""
    if not alternatives:
        return _EMPTY
    hit = _CACHE.get(id(alternatives))
    if hit is not None and hit[0] is alternatives:
        return hit[1]
    if len(_CACHE) >= _CACHE_SIZE:
        _CACHE.clear()
    built = Groups(alternatives)
    _CACHE[id(alternatives)] = (alternatives, built)
    return built


def of(problem: Problem) -> Groups:
    """The :class:`Groups` of ``problem``."""
    return index(problem.alternatives)


def chosen(
    problem: Problem, scheduled: Collection[str]
) -> dict[str, int] | msgspec.UnsetType:
    """Group id to the index of the option that ``scheduled`` holds.

    The first option with a scheduled task (in a valid plan the only one,
    with all its tasks); a group with no scheduled task is absent.
    ``UNSET`` for a problem without groups (the plan's ``chosen`` is then
    not written).
    """
    if not problem.alternatives:
        return msgspec.UNSET
    picks: dict[str, int] = {}
    for group in problem.alternatives:
        for o_idx, option in enumerate(group.options):
            if any(name in scheduled for name in option):
                picks[group.id] = o_idx
                break
    return picks


def unscheduled_cost(problem: Problem, scheduled: Collection[str]) -> int:
    """The unscheduled cost of the objective for the tasks ``scheduled``.

    Every task left out that is no group member costs its schedule cost;
    every group with no scheduled task costs the group's, once. A group
    none of whose tasks is in ``problem`` (a part of a larger problem)
    costs nothing here.
    """
    member = of(problem).member
    present = {task.id for task in problem.tasks}
    cost = sum(
        task.schedule_cost
        for task in problem.tasks
        if task.id not in scheduled and task.id not in member
    )
    for group in problem.alternatives:
        names = [n for option in group.options for n in option]
        if not any(n in present for n in names):
            continue
        if not any(n in scheduled for n in names):
            cost += group.schedule_cost
    return cost


def kept_alternatives(
    problem: Problem, kept: Iterable[str]
) -> tuple[Alternative, ...]:
    """The groups of ``problem`` with a task in ``kept`` (for a sub-problem).

    A sub-problem that keeps some tasks keeps the groups they belong to;
    an option with a task not kept cannot be scheduled there, so it is
    kept only when all its tasks are (the group keeps its other options).
    A group with no option left is dropped with its tasks' reason being
    the caller's.
    """
    keep = set(kept)
    out = []
    for group in problem.alternatives:
        options = tuple(
            option
            for option in group.options
            if all(n in keep for n in option)
        )
        if options and any(
            n in keep for option in group.options for n in option
        ):
            out.append(
                type(group)(
                    id=group.id,
                    schedule_cost=group.schedule_cost,
                    options=options,
                )
            )
    return tuple(out)


def left_out(problem: Problem, scheduled: Collection[str]) -> tuple[str, ...]:
    """What a plan lists as ``unscheduled`` (the plan format).

    Every task not in ``scheduled`` that is no group member, in problem
    order, then the id of every group none of whose tasks is scheduled
    (its members are not listed one by one).
    """
    member = of(problem).member
    present = {task.id for task in problem.tasks}
    names = [
        task.id
        for task in problem.tasks
        if task.id not in scheduled and task.id not in member
    ]
    for group in problem.alternatives:
        tasks = [n for option in group.options for n in option]
        if any(n in present for n in tasks) and not any(
            n in scheduled for n in tasks
        ):
            names.append(group.id)
    return tuple(names)


def keep_one_option(problem: Problem, starts: dict[str, int]) -> set[str]:
    """Take out of ``starts`` what breaks the alternatives; return it.

    For list scheduling, which places members one by one: of each group,
    the tasks of an option only partly placed, and every option placed
    in full but the one that delays least (the first on a tie).
    """
    dropped: set[str] = set()
    tasks = {task.id: task for task in problem.tasks}
    for group in problem.alternatives:
        full = [
            option
            for option in group.options
            if all(name in starts for name in option)
        ]
        keep = min(
            full,
            key=lambda option: sum(
                tasks[n].delay_cost * (starts[n] - problem.start)
                for n in option
            ),
            default=(),
        )
        for option in group.options:
            if option is keep:
                continue
            for name in option:
                if name in starts:
                    del starts[name]
                    dropped.add(name)
    return dropped


def mandatory_group_missing(problem: Problem, starts: Collection[str]) -> bool:
    """True if a mandatory group of ``problem`` has no option in full."""
    present = {task.id for task in problem.tasks}
    return any(
        group.schedule_cost == 0
        and any(n in present for o in group.options for n in o)
        and not any(all(n in starts for n in o) for o in group.options)
        for group in problem.alternatives
    )


def settle(
    alternatives: tuple[Alternative, ...],
    live: Collection[str],
    started: Collection[str],
) -> tuple[tuple[Alternative, ...], dict[str, str]]:
    """The groups of a replan, and the live tasks they take out.

    Parameters
    ----------
    alternatives
        The groups of the running problem.
    live
        The tasks still to plan.
    started
        Tasks that have run or are running (dispatched, running or
        completed): a started member pins its option.

    Returns
    -------
    tuple
        The groups to plan: a group with a started member keeps only its
        option (what is left of it, all or none, at the group's cost); a
        group loses every option one of whose tasks is gone (neither live
        nor started), and is dropped with none left. Then the live tasks
        to take out, with the reason: the other options of a pinned group,
        and what is left of an option that lost a task.
    """
    groups_out: list[Alternative] = []
    drop: dict[str, str] = {}
    for group in alternatives:
        pinned = next(
            (
                k
                for k, option in enumerate(group.options)
                if any(name in started for name in option)
            ),
            None,
        )
        options: list[tuple[str, ...]] = []
        for k, option in enumerate(group.options):
            rest = tuple(name for name in option if name in live)
            if pinned is not None and k != pinned:
                for name in rest:
                    drop[name] = (
                        f"group {group.id}: option {pinned} has started"
                    )
                continue
            gone = [n for n in option if n not in live and n not in started]
            if gone:
                for name in rest:
                    drop[name] = (
                        f"group {group.id}: its option {k} lost {gone[0]}"
                    )
                continue
            if rest:
                options.append(rest)
        if options:
            groups_out.append(
                type(group)(
                    id=group.id,
                    schedule_cost=group.schedule_cost,
                    options=tuple(options),
                )
            )
    return tuple(groups_out), drop
