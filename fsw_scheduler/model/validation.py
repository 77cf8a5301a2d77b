"""Validation of the problem format: every rule, with its field path.

:func:`validate_problem` runs every rule on a decoded problem, so that a
user sees every mistake at once. The per-task rules are a public seam:
:func:`check_task`, :func:`check_use`, :func:`duplicate_ids` and
:func:`time_issues` are also run on the tasks of a goal, alone
(:func:`fsw_scheduler.model.goal.validate_goal`) and when it is merged into
the running problem (:func:`fsw_scheduler.replan.triggers.apply_goal`), so
that the three report the same mistake with the same words and path.

The problem types are read here, never built: they are imported for type
checking only, since :mod:`.problem` runs these rules in its decoder (the
dependency goes that way). Pure: no solver, no bus, no clock.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..errors import FieldIssue
from .limits import (
    HORIZON_WHY,
    MAX_COST,
    MAX_DELAY_COST,
    MAX_HORIZON,
    MAX_TIME,
    MIN_COST,
    MIN_DELAY_COST,
    id_issue,
    key_path,
    shown,
)
from .mission_rules import mission_issues

if TYPE_CHECKING:
    from collections.abc import Iterable, Iterator

    from .problem import Consumable, Problem, Resources, Task

__all__ = [
    "check_task",
    "check_use",
    "duplicate_ids",
    "time_issues",
    "validate_problem",
]


def validate_problem(
    problem: Problem, *, allow_empty: bool = False
) -> list[FieldIssue]:
    """Return every validation issue of ``problem`` (empty when valid)."""
    issues = [
        *_check_horizon(problem),
        *_check_resources(problem.resources),
    ]
    issues += _check_tasks(problem, allow_empty)
    # Tight precedences that contradict along two paths are valid: they
    # only mean those tasks cannot all be scheduled together (see
    # fsw_scheduler.analysis.proofs for when that makes the problem
    # infeasible).
    issues += _check_precedences(problem)
    issues += mission_issues(problem)
    return issues


def _check_horizon(problem: Problem) -> Iterator[FieldIssue]:
    if problem.horizon <= 0:
        yield FieldIssue("horizon", f"must be > 0, got {problem.horizon}")
    if problem.horizon > MAX_HORIZON:
        yield FieldIssue(
            "horizon",
            f"{problem.horizon} units is longer than the longest horizon, "
            f"{MAX_HORIZON}: {HORIZON_WHY}",
        )
    if problem.start < 0:
        yield FieldIssue("start", f"must be >= 0, got {problem.start}")
    if problem.start + max(problem.horizon, 0) > MAX_TIME:
        yield FieldIssue(
            "horizon",
            f"start + horizon must be at most {MAX_TIME}, got "
            f"{problem.start + problem.horizon}",
        )


def _check_resources(resources: Resources) -> Iterator[FieldIssue]:
    seen: dict[str, str] = {}
    # Binary resources written as a list are named by position, written
    # as an object by name.
    listed = not isinstance(resources.binary, dict)
    named = [
        *(
            ("binary", i if listed else n, n)
            for i, n in enumerate(resources.binary)
        ),
        *(("multiple", n, n) for n in resources.multiple),
        *(("consumable", n, n) for n in resources.consumable),
    ]
    for kind, key, name in named:
        path = (
            f"resources.{kind}[{key}]"
            if kind == "binary" and listed
            else f"resources.{kind}.{key}"
        )
        reason = id_issue(name)
        if reason is not None:
            if kind != "binary" or not listed:
                path = key_path(f"resources.{kind}", name)
            yield FieldIssue(path, f"resource name {reason}")
        if name in seen:
            yield FieldIssue(
                path, f"resource {name!r} is already declared as {seen[name]}"
            )
        seen[name] = kind
    for name, capacity in resources.multiple.items():
        if isinstance(capacity, int | float) and capacity < 0:
            yield FieldIssue(
                key_path("resources.multiple", name),
                f"capacity must be >= 0, got {capacity}",
            )
    for name, spec in resources.consumable.items():
        yield from _check_consumable(name, spec)


def _check_consumable(
    name: str, spec: float | Consumable
) -> Iterator[FieldIssue]:
    path = key_path("resources.consumable", name)
    if isinstance(spec, (int, float)):  # a plain initial level
        if spec < 0:
            yield FieldIssue(path, f"initial level must be >= 0, got {spec}")
        return
    if spec.initial < 0:
        yield FieldIssue(
            f"{path}.initial",
            f"initial level must be >= 0, got {spec.initial}",
        )
    if spec.max is None:
        return
    if spec.max < 0:
        yield FieldIssue(
            f"{path}.max", f"capacity must be >= 0, got {spec.max}"
        )
    elif spec.initial > spec.max:
        yield FieldIssue(
            f"{path}.initial",
            f"initial level {spec.initial:g} is above the capacity "
            f"max {spec.max:g}",
        )


def _check_tasks(problem: Problem, allow_empty: bool) -> list[FieldIssue]:
    issues: list[FieldIssue] = []
    if not problem.tasks and not allow_empty:
        issues.append(FieldIssue("tasks", "at least one task is required"))
    issues += duplicate_ids(problem.tasks)
    for idx, task in enumerate(problem.tasks):
        issues += check_task(problem, task, f"tasks[{idx}]")
    return issues


def duplicate_ids(tasks: Iterable[Task]) -> list[FieldIssue]:
    """One issue per task whose id an earlier task already has."""
    issues = []
    seen: dict[str, int] = {}
    for idx, task in enumerate(tasks):
        if task.id in seen:
            issues.append(
                FieldIssue(
                    f"tasks[{idx}].id",
                    f"duplicate task id {shown(task.id)} "
                    f"(first at tasks[{seen[task.id]}])",
                )
            )
        seen.setdefault(task.id, idx)
    return issues


def check_task(problem: Problem, task: Task, path: str) -> list[FieldIssue]:
    """Every issue of one task, read against ``problem``.

    Parameters
    ----------
    problem
        The problem the task belongs to (or will join): its resources, its
        horizon and its window reading. The task itself need not be one of
        its tasks.
    task
        The task to check.
    path
        The task's field path in its document (``tasks[3]``); every issue
        path starts with it.

    Returns
    -------
    list of FieldIssue
        Empty when the task is valid. The id, the time values, the length
        and the costs are checked against the formats' limits; each used
        resource by :func:`check_use`; the window and a fixed start
        against the horizon (only for a positive length). A caller without
        the real problem (a goal alone) passes a permissive stand-in and
        drops the issues it cannot judge, by path.
    """
    issues: list[FieldIssue] = []
    reason = id_issue(task.id)
    if reason is not None:
        issues.append(FieldIssue(f"{path}.id", f"task id {reason}"))
    issues += time_issues(task, path)
    if task.length <= 0:
        issues.append(
            FieldIssue(f"{path}.length", f"must be > 0, got {task.length}")
        )
    if not MIN_DELAY_COST <= task.delay_cost <= MAX_DELAY_COST:
        issues.append(
            FieldIssue(
                f"{path}.delay_cost",
                f"must be in {MIN_DELAY_COST}..{MAX_DELAY_COST}, "
                f"got {task.delay_cost}",
            )
        )
    if not MIN_COST <= task.schedule_cost <= MAX_COST:
        issues.append(
            FieldIssue(
                f"{path}.schedule_cost",
                f"must be in {MIN_COST}..{MAX_COST} (0 = mandatory), "
                f"got {task.schedule_cost}",
            )
        )
    for name, amount in sorted(task.uses.items()):
        issues += check_use(problem.resources, name, amount, path)
    if task.length > 0:
        issues += _check_window(problem, task, path)
    return issues


def check_use(
    resources: Resources, name: str, amount: float, path: str
) -> list[FieldIssue]:
    """The issue of one resource use of a task, if any.

    Parameters
    ----------
    resources
        The declared resources the task may use.
    name
        The resource named in the task's ``uses``.
    amount
        The amount per time unit it names.
    path
        The task's field path (``tasks[3]``); the issue is at
        ``<path>.uses.<name>``.

    Returns
    -------
    list of FieldIssue
        At most one: an unknown resource (with the known ones), a binary
        amount other than 1, or a negative amount of a multiple resource
        (a negative consumable amount is generation, and valid).
    """
    kind = resources.kind_of(name)
    where = key_path(f"{path}.uses", name)
    if kind is None:
        known = ", ".join(resources.names) or "none declared"
        return [FieldIssue(where, f"unknown resource (known: {known})")]
    if kind == "binary" and amount != 1:
        return [
            FieldIssue(
                where, f"binary resource amount must be 1, got {amount}"
            )
        ]
    if kind == "multiple" and amount < 0:
        return [
            FieldIssue(
                where, f"multiple resource amount must be >= 0, got {amount}"
            )
        ]
    return []


def time_issues(task: Task, path: str) -> list[FieldIssue]:
    """Time values of ``task`` outside ``[0, MAX_TIME]``."""
    values = {
        "length": task.length,
        "fixed_start": task.fixed_start,
        **dict(
            zip(
                ("feasible_interval[0]", "feasible_interval[1]"),
                task.feasible_interval or (),
                strict=False,
            )
        ),
    }
    # Times are units of the mission clock, as the types declare them.
    return [
        FieldIssue(f"{path}.{name}", f"{value} is outside [0, {MAX_TIME}]")
        for name, value in values.items()
        if value is not None
        # A length below 1 has its own rule (check_task).
        and not (0 if name != "length" else -MAX_TIME) <= value <= MAX_TIME
    ]


def _check_window(
    problem: Problem, task: Task, path: str
) -> Iterable[FieldIssue]:
    if task.length > problem.horizon:
        return [
            FieldIssue(
                f"{path}.length",
                f"length {task.length} exceeds the horizon {problem.horizon}",
            )
        ]
    if task.fixed_start is not None:
        low, high = problem.start, problem.end - task.length
        if not low <= task.fixed_start <= high:
            return [
                FieldIssue(
                    f"{path}.fixed_start",
                    f"must be in [{low}, {high}] to fit the horizon",
                )
            ]
    if task.feasible_interval is None:
        return []
    where = f"{path}.feasible_interval"
    low, high = task.feasible_interval
    if low > high:
        return [FieldIssue(where, f"start {low} is after end {high}")]
    reading = problem.window_reading(task)
    if reading == "task" and high - low < task.length:
        return [
            FieldIssue(
                where,
                f"[{low}, {high}] is {high - low} units long and cannot "
                f"hold the task's length {task.length}",
            )
        ]
    earliest, latest = problem.start_bounds(task)
    if earliest > latest:
        return [
            FieldIssue(
                where,
                f"[{low}, {high}] leaves no start time inside the horizon "
                f"[{problem.start}, {problem.end}) for length {task.length}",
            )
        ]
    return []


def _check_precedences(problem: Problem) -> Iterator[FieldIssue]:
    ids = {task.id for task in problem.tasks}
    for idx, prec in enumerate(problem.precedences):
        path = f"precedences[{idx}]"
        for end in ("before", "after"):
            name = getattr(prec, end)
            if name not in ids:
                yield FieldIssue(
                    f"{path}.{end}", f"unknown task {shown(name)}"
                )
        if prec.before == prec.after:
            yield FieldIssue(
                f"{path}.after", f"task {prec.after!r} cannot precede itself"
            )
