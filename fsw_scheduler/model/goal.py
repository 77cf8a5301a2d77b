"""Goals: new tasks arriving while a plan runs (the goal format).

A goal carries tasks (the fields of a problem task plus ``obsoletes``, the
ids of live tasks the new task replaces) and precedences. :func:`decode_goal`
checks what can be checked without the running problem: the document shape,
each task on its own and each precedence on its own. What depends on the
running problem (resource names, windows inside the new horizon, id
collisions, unknown references, tight cycles) is checked when the goal is
merged, by :func:`fsw_scheduler.replan.triggers.apply_goal`, with the same
field paths. This module is pure: no solver, no bus, no clock.
"""

from __future__ import annotations

from typing import Annotated

import msgspec

from ..errors import FieldIssue, InputError
from .codec import read_strict
from .limits import MAX_TIME, id_issue, key_path
from .mission_rules import alternatives_issues, fill_member_costs
from .problem import (
    Alternative,
    Consumable,
    Id,
    Instant,
    Precedence,
    Problem,
    Resources,
    Task,
)
from .strict import under
from .validation import check_task, duplicate_ids

__all__ = ["Goal", "GoalTask", "decode_goal", "validate_goal"]


class GoalTask(Task, frozen=True, omit_defaults=True):
    """A task brought by a goal: a problem task plus what it replaces.

    Attributes
    ----------
    obsoletes
        Ids of tasks already accepted that this task makes obsolete; they
        leave the pending list (paper, "Online rescheduling", last case).
    """

    obsoletes: tuple[Id, ...] = ()

    def to_task(self) -> Task:
        """The plain problem task, without ``obsoletes``."""
        fields = msgspec.structs.asdict(self)
        del fields["obsoletes"]
        return Task(**fields)


class Goal(msgspec.Struct, frozen=True, omit_defaults=True):
    """A goal: tasks and precedences to co-schedule with the live plan.

    Attributes
    ----------
    goal_id
        Name of the goal, used in reports; a key-safe id
        (:func:`fsw_scheduler.model.id_issue`).
    tasks
        New tasks; their ids must not collide with live tasks unless a task
        of this goal makes the live one obsolete.
    precedences
        Precedences between goal tasks, or between a goal task and a live
        task.
    issued_at
        Time unit at which the goal was issued, if known.
    not_after
        Time unit after which the goal is stale: arriving later, it is
        rejected (None: it never expires).
    alternatives
        Groups of alternatives among the goal's own tasks; they join the
        running problem's groups.
    """

    goal_id: Id
    tasks: Annotated[
        tuple[GoalTask, ...],
        msgspec.Meta(min_length=1, description="a goal brings a task"),
    ]
    precedences: tuple[Precedence, ...] = ()
    issued_at: Instant | None = None
    not_after: Instant | None = None
    alternatives: tuple[Alternative, ...] = ()

    @property
    def obsoleted(self) -> tuple[str, ...]:
        """Every id made obsolete by a task of the goal, in order, once."""
        return tuple(
            dict.fromkeys(name for t in self.tasks for name in t.obsoletes)
        )


# Issues of check_task that depend on the running problem (resource
# names, the horizon, the window reading) are left to the merge.
_MERGE_ONLY = (".uses.", ".feasible_interval", ".fixed_start")


def validate_goal(
    goal: Goal, resources: Resources | None = None
) -> list[FieldIssue]:
    """Return every issue found in ``goal`` alone (empty when valid).

    Parameters
    ----------
    goal
        A decoded goal.
    resources
        The resources of the problem the goal is for, when known (a node's
        own, or those its ``scheduler/config`` publishes): each use is
        then checked against them too (an unknown resource, a binary use
        other than 1), as the merge would.

    Returns
    -------
    list of FieldIssue
        Paths are relative to the goal document (``tasks[0].length``).
    """
    issues: list[FieldIssue] = []
    reason = id_issue(goal.goal_id)
    if reason is not None:
        issues.append(FieldIssue("goal_id", f"goal id {reason}"))
    for name in ("issued_at", "not_after"):
        value = getattr(goal, name)
        if value is not None and not 0 <= value <= MAX_TIME:
            issues.append(
                FieldIssue(name, f"{value} is outside [0, {MAX_TIME}]")
            )
    # A permissive stand-in problem: every used resource declared, a horizon
    # long enough for any length, so only per-task rules speak.
    used: dict[str, float | Consumable] = {
        name: 0.0 for t in goal.tasks for name in t.uses
    }
    lengths = [t.length for t in goal.tasks if t.length > 0]
    stand_in = Problem(
        horizon=max(lengths, default=1),
        tasks=(),
        resources=resources or Resources(consumable=used),
    )
    merge_only = _MERGE_ONLY[1:] if resources is not None else _MERGE_ONLY
    issues += duplicate_ids(goal.tasks)
    for idx, task in enumerate(goal.tasks):
        path = f"tasks[{idx}]"
        # A name that is not an id is said so below, once.
        unsafe = {
            key_path(f"{path}.uses", name)
            for name in task.uses
            if id_issue(name) is not None
        }
        issues += [
            issue
            for issue in check_task(stand_in, task.to_task(), path)
            if not any(part in issue.path for part in merge_only)
            and issue.path not in unsafe
        ]
        for name in task.uses:
            reason = id_issue(name)
            if reason is not None:
                issues.append(
                    FieldIssue(
                        key_path(f"{path}.uses", name),
                        f"resource name {reason}",
                    )
                )
        for pos, name in enumerate(task.obsoletes):
            reason = id_issue(name)
            if reason is not None:
                issues.append(
                    FieldIssue(f"{path}.obsoletes[{pos}]", f"task id {reason}")
                )
        if task.feasible_interval is not None:
            low, high = task.feasible_interval
            if low > high:
                issues.append(
                    FieldIssue(
                        f"{path}.feasible_interval",
                        f"start {low} is after end {high}",
                    )
                )
    issues += alternatives_issues(goal.alternatives, goal.tasks, ())
    for idx, prec in enumerate(goal.precedences):
        for end in ("before", "after"):
            reason = id_issue(getattr(prec, end))
            if reason is not None:
                issues.append(
                    FieldIssue(
                        f"precedences[{idx}].{end}", f"task id {reason}"
                    )
                )
        if prec.before == prec.after:
            issues.append(
                FieldIssue(
                    f"precedences[{idx}].after",
                    f"task {prec.after!r} cannot precede itself",
                )
            )
    return issues


def decode_goal(data: bytes | str, resources: Resources | None = None) -> Goal:
    """Decode and check a goal document (the goal format).

    Parameters
    ----------
    data
        The goal JSON.
    resources
        The resources of the running problem, when known: the uses are
        checked against them in the same pass (see :func:`validate_goal`).

    Returns
    -------
    Goal
        A goal that passed :func:`validate_goal`.

    Raises
    ------
    InputError
        With one :class:`FieldIssue` per problem, paths naming the field
        (``tasks[0].length``).
    """
    goal, issues, bad = read_strict(
        data, Goal, "goal", prepare=fill_member_costs
    )
    if goal is not None:
        issues += [
            issue
            for issue in validate_goal(goal, resources)
            if not under(issue.path, bad)
        ]
    if issues or goal is None:
        raise InputError(issues, "goal")
    return goal
