"""Rules of the mission model: alternatives and changing resources.

The fields of the mission model (``alternatives``, binary ``available``
windows, multiple capacity ``steps``, consumable ``external`` rates) are
checked here, apart from the rules every problem had
(:mod:`.validation` calls :func:`mission_issues`), so that each rule has
one place and one wording, shared by problems and goals. Also here:
:func:`fill_member_costs`, which gives a group member written without a
``schedule_cost`` its group's, before the shape is checked. Pure: no
solver, no bus, no clock.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ..errors import FieldIssue
from .limits import key_path, shown
from .strict import suggestion

if TYPE_CHECKING:
    from collections.abc import Iterator, Sequence

    from .problem import Alternative, Problem, Resources, Task

__all__ = [
    "alternatives_issues",
    "fill_member_costs",
    "forecast_issues",
    "mission_issues",
    "resource_profile_issues",
]


def fill_member_costs(raw: Any) -> None:
    """Give each member task without ``schedule_cost`` its group's.

    ``raw`` is a parsed problem or goal document (left alone when it is
    not shaped like one: the shape check reports that). A member may
    leave its cost out since the group's is the one used; a task that is
    no member keeps its "missing required field".
    """
    if not isinstance(raw, dict):
        return
    groups, tasks = raw.get("alternatives"), raw.get("tasks")
    if not isinstance(groups, list) or not isinstance(tasks, list):
        return
    cost_of: dict[str, object] = {}
    for group in groups:
        if not isinstance(group, dict) or "schedule_cost" not in group:
            continue
        options = group.get("options")
        for option in options if isinstance(options, list) else ():
            for name in option if isinstance(option, list) else ():
                if isinstance(name, str):
                    cost_of.setdefault(name, group["schedule_cost"])
    for task in tasks:
        if (
            isinstance(task, dict)
            and "schedule_cost" not in task
            and isinstance(task.get("id"), str)
            and task["id"] in cost_of
        ):
            task["schedule_cost"] = cost_of[task["id"]]


def mission_issues(problem: Problem) -> list[FieldIssue]:
    """Every issue of the mission-model fields of ``problem``."""
    return [
        *resource_profile_issues(problem.resources, problem.start),
        *alternatives_issues(problem.alternatives, problem.tasks, ()),
    ]


def resource_profile_issues(
    resources: Resources, start: int | None
) -> list[FieldIssue]:
    """Windows, capacity steps and external rates that break a rule.

    Parameters
    ----------
    resources
        The declared resources.
    start
        The problem's start: the first capacity step must be at or
        before it (None: not checked, for a forecast's steps).
    """
    issues: list[FieldIssue] = []
    if isinstance(resources.binary, dict):
        for name, spec in resources.binary.items():
            if spec.available is not None:
                path = key_path("resources.binary", name) + ".available"
                issues += window_issues(spec.available, path)
    for name, value in resources.multiple.items():
        if isinstance(value, int | float):
            continue
        path = key_path("resources.multiple", name) + ".steps"
        issues += step_issues(value.steps, path, start)
    for name, store in resources.consumable.items():
        external = getattr(store, "external", ())
        if external:
            path = key_path("resources.consumable", name) + ".external"
            issues += step_issues(external, path, None)
    return issues


def window_issues(
    windows: Sequence[tuple[int, int]], path: str
) -> list[FieldIssue]:
    """Windows ``[a, b)`` that are empty, unsorted or overlapping."""
    issues = []
    for k, (low, high) in enumerate(windows):
        if low >= high:
            issues.append(
                FieldIssue(
                    f"{path}[{k}]",
                    f"window [{low}, {high}) is empty: its start must be "
                    "before its end",
                )
            )
        elif k and low < windows[k - 1][1]:
            before = windows[k - 1]
            issues.append(
                FieldIssue(
                    f"{path}[{k}]",
                    f"window [{low}, {high}) starts before the end of "
                    f"[{before[0]}, {before[1]}): windows must be sorted "
                    "and disjoint",
                )
            )
    return issues


def step_issues(
    steps: Sequence[tuple[int, float]],
    path: str,
    start: int | None,
    what: str = "the problem start",
) -> list[FieldIssue]:
    """Steps whose times do not strictly increase, or that start late."""
    issues = []
    for k in range(1, len(steps)):
        if steps[k][0] <= steps[k - 1][0]:
            issues.append(
                FieldIssue(
                    f"{path}[{k}][0]",
                    f"step time {steps[k][0]} must be after the previous "
                    f"step's {steps[k - 1][0]} (times strictly increase)",
                )
            )
    if start is not None and steps and steps[0][0] > start:
        issues.append(
            FieldIssue(
                f"{path}[0][0]",
                f"the first step is at {steps[0][0]}, after {what} "
                f"{start}: say the value from there on",
            )
        )
    return issues


def alternatives_issues(
    groups: Sequence[Alternative],
    tasks: Sequence[Task],
    taken: Sequence[str],
) -> list[FieldIssue]:
    """Groups that break a rule of the alternatives.

    Parameters
    ----------
    groups
        The groups of the document (paths ``alternatives[g]``).
    tasks
        The tasks their options may name (paths ``tasks[i]``).
    taken
        Names groups may not take besides the tasks' (groups already
        accepted, for a goal merged into a problem).
    """
    issues: list[FieldIssue] = []
    task_idx = {task.id: idx for idx, task in enumerate(tasks)}
    ids = sorted(task_idx)
    seen_groups: dict[str, int] = {}
    placed: dict[str, str] = {}
    for g_idx, group in enumerate(groups):
        path = f"alternatives[{g_idx}]"
        issues += _group_name_issues(group, path, task_idx, seen_groups, taken)
        seen_groups.setdefault(group.id, g_idx)
        for o_idx, option in enumerate(group.options):
            for k, name in enumerate(option):
                where = f"{path}.options[{o_idx}][{k}]"
                if name not in task_idx:
                    issues.append(
                        FieldIssue(
                            where,
                            f"unknown task {shown(name)}"
                            f"{suggestion(name, ids)}",
                        )
                    )
                    continue
                if name in placed:
                    issues.append(
                        FieldIssue(
                            where,
                            f"task {shown(name)} is already a member at "
                            f"{placed[name]}: a task belongs to at most one "
                            "option of one group",
                        )
                    )
                    continue
                placed[name] = where
                issues += _member_cost_issue(
                    group, tasks[task_idx[name]], task_idx[name]
                )
    return issues


def _group_name_issues(
    group: Alternative,
    path: str,
    task_idx: dict[str, int],
    seen: dict[str, int],
    taken: Sequence[str],
) -> Iterator[FieldIssue]:
    if group.id in seen:
        yield FieldIssue(
            f"{path}.id",
            f"duplicate group id {shown(group.id)} (first at "
            f"alternatives[{seen[group.id]}])",
        )
    if group.id in task_idx:
        yield FieldIssue(
            f"{path}.id",
            f"group id {shown(group.id)} is the id of tasks"
            f"[{task_idx[group.id]}]: groups and tasks share no name",
        )
    elif group.id in taken:
        yield FieldIssue(
            f"{path}.id",
            f"{shown(group.id)} is already the name of a task or group "
            "of the running problem",
        )


def _member_cost_issue(
    group: Alternative, task: Task, idx: int
) -> list[FieldIssue]:
    if task.schedule_cost == group.schedule_cost:
        return []
    return [
        FieldIssue(
            f"tasks[{idx}].schedule_cost",
            f"task {shown(task.id)} is a member of group {shown(group.id)}, "
            f"whose schedule_cost {group.schedule_cost} is the one used: "
            "leave the member's out or make it equal",
        )
    ]


def forecast_issues(
    resources: Resources,
    name: str,
    at: int,
    fields: dict[str, Sequence[tuple[int, float]] | None],
) -> list[FieldIssue]:
    """Every reason a forecast of ``name`` cannot be taken.

    Parameters
    ----------
    resources
        The running problem's resources.
    name
        The resource named by the forecast (and its key).
    at
        From when the forecast holds.
    fields
        The forecast's ``available``, ``steps`` and ``external`` (None for
        the ones it does not carry): exactly the one of the resource's
        kind must be there.

    Returns
    -------
    list of FieldIssue
        Paths relative to the forecast message.
    """
    kind = _forecast_kind(resources, name)
    if kind is None:
        known = ", ".join(resources.names) or "none declared"
        return [FieldIssue("resource", f"unknown resource (known: {known})")]
    issues = [
        FieldIssue(
            other,
            f"{name!r} is a {resources.kind_of(name)} resource: its "
            f"forecast carries {kind!r}",
        )
        for other, value in fields.items()
        if value is not None and other != kind
    ]
    values = fields.get(kind)
    if values is None:
        issues.append(
            FieldIssue(kind, f"missing: the forecast of {name!r} carries it")
        )
        return issues
    if kind == "available":
        issues += window_issues(values, "available")  # type: ignore[arg-type]
        return issues
    issues += step_issues(values, kind, at, "at")
    if kind == "steps":
        issues += [
            FieldIssue(
                f"steps[{k}][1]",
                f"capacity must be a whole number >= 0, got {value:g}",
            )
            for k, (_, value) in enumerate(values)
            if value < 0 or value != int(value)
        ]
    return issues


def _forecast_kind(resources: Resources, name: str) -> str | None:
    """The field a forecast of ``name`` carries (None: unknown name)."""
    kind = resources.kind_of(name)
    return None if kind is None else _FORECAST_FIELDS[kind]


_FORECAST_FIELDS = {
    "binary": "available",
    "multiple": "steps",
    "consumable": "external",
}
