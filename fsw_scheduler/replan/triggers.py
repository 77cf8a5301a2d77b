"""The paper's replan triggers: a goal, a failure, measured levels.

A trigger (:func:`apply_goal`, :func:`apply_failure`, :func:`apply_levels`,
or :func:`apply_change` for a decoded change document) turns a
:class:`~fsw_scheduler.replan.schedule.Schedule` into a
:class:`~fsw_scheduler.replan.schedule.Replan`: a new problem over
``[now, now + H)``, the removals with the rule that caused each, the
continuing tasks and a warm start. The rules themselves are in
:mod:`fsw_scheduler.replan.rules`; this module runs them in order, merges
a goal (collisions and unknown references reject it) and validates the
merged problem once. :func:`drift` says when measured levels are far
enough from the prediction to replan.

Pure: no solver, no bus, no wall clock; time is always an argument.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

import msgspec

from ..errors import FieldIssue, InputError
from ..model import groups
from ..model.change import ActivityFailed, Change, ExecutionReport
from ..model.goal import Goal
from ..model.levels import cut_to_capacity, predicted_levels, walk_level
from ..model.mission_rules import alternatives_issues
from ..model.plan import Activity, Plan, SolveStatus
from ..model.validation import check_use, validate_problem
from .rules import (
    Work,
    forget,
    latest_start,
    rule_alternatives,
    rule_defer_beyond_horizon,
    rule_failed_activity,
    rule_finished_leave,
    rule_obsolete,
    rule_removal_cascade,
    rule_running_preemption,
    rule_settled_precedences,
    rule_tight_chain,
    rule_window_passed,
    start_work,
)
from .schedule import (
    ExecutionState,
    Replan,
    Schedule,
    empty_plan,
    run_spans,
)

if TYPE_CHECKING:
    from collections.abc import Mapping

    from ..model.problem import Precedence, Problem

__all__ = [
    "Drift",
    "Tolerance",
    "apply_change",
    "apply_failure",
    "apply_goal",
    "apply_levels",
    "drift",
]


def _merge_goal(work: Work, goal: Goal) -> None:
    """Add the goal's tasks and precedences, or reject the goal.

    Raises
    ------
    InputError
        A task id collides with a live task the goal does not make
        obsolete (or with a running task that cannot be interrupted); a
        precedence names a task that is neither live, in the goal nor
        executed; a task's window has already passed.
    """
    issues = []
    removed_by = {r.task: r.rule for r in work.removed}
    frame = work.frame()
    for idx, gtask in enumerate(goal.tasks):
        path = f"tasks[{idx}]"
        if gtask.id in work.pinned:
            issues.append(
                FieldIssue(
                    f"{path}.id",
                    f"task {gtask.id!r} is running and cannot be "
                    "interrupted (preemption none); it cannot be replaced",
                )
            )
        elif gtask.id in work.tasks:
            issues.append(
                FieldIssue(
                    f"{path}.id",
                    f"task {gtask.id!r} is already live and this goal does "
                    "not make it obsolete",
                )
            )
        task = gtask.to_task()
        for name, amount in sorted(task.uses.items()):
            issues += check_use(work.base.resources, name, amount, path)
        if task.length > work.horizon:
            issues.append(
                FieldIssue(
                    f"{path}.length",
                    f"length {task.length} exceeds the horizon {work.horizon}",
                )
            )
        elif latest_start(frame, task) < work.now:
            where = (
                "fixed_start"
                if task.fixed_start is not None
                else ("feasible_interval")
            )
            issues.append(
                FieldIssue(
                    f"{path}.{where}",
                    f"no start left at or after now = {work.now}",
                )
            )
    goal_ids = {t.id for t in goal.tasks}
    for idx, prec in enumerate(goal.precedences):
        for end in ("before", "after"):
            name = getattr(prec, end)
            if name in goal_ids or name in work.tasks or name in work.runs:
                continue
            reason = (
                f"task {name!r} is removed by this change ({removed_by[name]})"
                if name in removed_by
                else f"unknown task {name!r}"
            )
            issues.append(FieldIssue(f"precedences[{idx}].{end}", reason))
    taken = {g.id for g in work.groups} | set(work.tasks) - goal_ids
    issues += [
        issue
        for issue in alternatives_issues(goal.alternatives, goal.tasks, ())
        if issue.path.startswith("alternatives")
    ]
    for idx, group in enumerate(goal.alternatives):
        if group.id in taken:
            issues.append(
                FieldIssue(
                    f"alternatives[{idx}].id",
                    f"{group.id!r} is already the name of a task or group "
                    "of the running problem",
                )
            )
    if issues:
        raise InputError(issues, "goal")
    for gtask in goal.tasks:
        task = gtask.to_task()
        forget(work, task.id)  # an id reused for a new task
        work.tasks[task.id] = task
        work.catalog[task.id] = task
        if task.id in work.obsolete:
            work.obsolete.remove(task.id)
        work.runs.pop(task.id, None)
    work.precedences += goal.precedences
    work.catalog_precedences += goal.precedences
    work.groups += goal.alternatives


def apply_goal(
    schedule: Schedule,
    goal: Goal,
    now: int,
    *,
    measured: Mapping[str, float] | None = None,
) -> Replan:
    """Apply a new goal at ``now``.

    Parameters
    ----------
    schedule
        The state kept by the engine.
    goal
        The goal (see :func:`fsw_scheduler.model.goal.decode_goal`).
    now
        Time unit of the replan, ``>= schedule.problem.start``.
    measured
        Optional measured consumable levels at the start of ``now``.

    Returns
    -------
    Replan

    Raises
    ------
    InputError
        The goal is rejected as a whole; paths name the goal's fields
        (``tasks[0].id``). ``schedule`` is not changed (it is immutable).
    """
    return _replan(schedule, now, goal=goal, measured=measured)


def apply_failure(
    schedule: Schedule,
    task: str,
    at: int,
    *,
    now: int | None = None,
    measured: Mapping[str, float] | None = None,
) -> Replan:
    """Replan after ``task`` failed at ``at`` (see rule_failed_activity).

    Parameters
    ----------
    schedule
        The state kept by the engine.
    task
        The failed task; it must be in the current problem.
    at
        Time unit of the failure; a time before the current problem's
        start (a late report) counts as that start.
    now
        Time unit of the replan (default ``at``); ``>= at``.
    measured
        Optional measured consumable levels at the start of ``now``.

    Returns
    -------
    Replan

    Raises
    ------
    InputError
        Unknown task (path ``task``) or times out of order (``at``).
    """
    now = at if now is None else now
    # A report that arrives after a replan refers to the previous window;
    # the current version of the task then failed as it began.
    at = max(at, schedule.problem.start)
    issues = []
    if all(t.id != task for t in schedule.problem.tasks):
        issues.append(FieldIssue("task", f"unknown task {task!r}"))
    if at > now:
        issues.append(FieldIssue("at", f"{at} is after now = {now}"))
    if issues:
        raise InputError(issues, "event")
    schedule = schedule.with_report(ExecutionReport(task, "failed", at))
    return _replan(schedule, now, measured=measured)


def apply_levels(
    schedule: Schedule,
    measured: Mapping[str, float],
    now: int,
    *,
    at: int | None = None,
    keep_running: bool = False,
) -> Replan:
    """Replan from measured consumable levels.

    Parameters
    ----------
    schedule
        The state kept by the engine.
    measured
        Resource name to level measured at the start of unit ``at``.
    now
        Time unit of the replan.
    at
        When the levels were measured (default ``now``). Earlier readings
        are carried to ``now`` with the plan's predicted use in between,
        unit by unit for a consumable with a capacity. A level above its
        consumable's capacity is read as full; the new problem keeps the
        capacity.
    keep_running
        Let every running task continue (pinned) whatever its preemption
        policy; see :func:`rule_running_preemption`.

    Returns
    -------
    Replan

    Raises
    ------
    InputError
        Unknown or non-consumable resource, negative or non-finite level
        (path ``levels.<name>``), or ``at`` after ``now``.
    """
    levels = _levels_at(schedule, measured, now, now if at is None else at)
    return _replan(schedule, now, measured=levels, keep_running=keep_running)


class Tolerance(msgspec.Struct, frozen=True):
    """How far a measured level may be from the prediction.

    A level departs when ``|measured - predicted| > absolute + relative *
    |predicted|`` (the rule of :func:`math.isclose`, but additive so that
    either part can be set alone).
    """

    absolute: float = 1e-6
    relative: float = 0.0

    def departs(self, predicted: float, measured: float) -> bool:
        """True if ``measured`` is out of tolerance around ``predicted``."""
        slack = self.absolute + self.relative * abs(predicted)
        return abs(measured - predicted) > slack


class Drift(NamedTuple):
    """A consumable whose measured level departs from the prediction."""

    resource: str
    predicted: float
    measured: float


def drift(
    problem: Problem,
    plan: Plan,
    now: int,
    measured: Mapping[str, float],
    tolerance: Tolerance | None = None,
) -> list[Drift]:
    """Measured consumable levels that depart from the plan's prediction.

    Parameters
    ----------
    problem, plan
        The current problem and plan.
    now
        Time unit of the measurement (start of the unit).
    measured
        Resource name to measured level; names that are not consumables of
        ``problem`` are ignored.
    tolerance
        Allowed departure (default :class:`Tolerance`).

    Returns
    -------
    list of Drift
        One entry per departing resource, in name order; empty when the
        plan is still on track and no replan is needed.
    """
    tolerance = tolerance or Tolerance()
    predicted = predicted_levels(problem, plan, now)
    measured = cut_to_capacity(problem, measured)
    return [
        Drift(name, predicted[name], float(measured[name]))
        for name in sorted(measured)
        if name in predicted
        and tolerance.departs(predicted[name], float(measured[name]))
    ]


def _levels_at(
    schedule: Schedule, measured: Mapping[str, float], now: int, at: int
) -> dict[str, float]:
    problem = schedule.problem
    issues = []
    for name, level in sorted(measured.items()):
        if name not in problem.resources.consumable:
            issues.append(
                FieldIssue(f"levels.{name}", "not a consumable resource")
            )
        elif not math.isfinite(level) or level < 0:
            issues.append(
                FieldIssue(f"levels.{name}", f"must be >= 0, got {level}")
            )
    if not problem.start <= at <= now:
        issues.append(
            FieldIssue("at", f"{at} is not in [{problem.start}, {now}]")
        )
    if issues:
        raise InputError(issues, "event")
    then = schedule.state(at).levels
    later = schedule.state(now)
    ceilings = problem.resources.ceilings
    return {
        name: max(
            0.0,
            level + later.levels[name] - then[name]
            if name not in ceilings
            else walk_level(
                problem,
                run_spans(later.tasks, now),
                name,
                level,
                (at, now),
                ceilings[name],
            ),
        )
        for name, level in measured.items()
    }


def _replan(
    schedule: Schedule,
    now: int,
    *,
    goal: Goal | None = None,
    measured: Mapping[str, float] | None = None,
    keep_running: bool = False,
) -> Replan:
    state = schedule.state(now, measured)
    work = start_work(schedule, now)
    work.keep_running = keep_running
    rule_finished_leave(work, state)
    seeds = []
    # Every failure reported so far, not only the one that triggered.
    for ts in state.tasks:
        if ts.phase == "failed" and ts.task in work.tasks:
            seeds += rule_failed_activity(work, state, ts.task)
    seeds += rule_running_preemption(work, state)
    if goal is not None:
        seeds += rule_obsolete(work, goal)
    rule_removal_cascade(work, seeds)
    if goal is not None:
        _merge_goal(work, goal)
    rule_tight_chain(work)
    redo, seeds = rule_settled_precedences(work)
    if redo:
        work.rescheduled = redo
        rule_tight_chain(work)
        redo, more = rule_settled_precedences(work)
        seeds += more
        # The precondition could not be brought back (obsolete, unknown).
        for name in redo:
            work.remove(
                name, "window_passed", "its tight precondition has passed"
            )
            seeds.append(name)
    rule_removal_cascade(work, seeds)
    rule_removal_cascade(work, rule_window_passed(work))
    # A failed member does not pin its option: another may be chosen.
    started = {*work.runs} | {
        ts.task for ts in state.tasks if ts.phase in ("running", "finished")
    }
    for _ in range(2):  # a cascade can take a member of another option
        rule_removal_cascade(work, rule_alternatives(work, started))
    rule_defer_beyond_horizon(work)
    return _finish(schedule, work, state, goal)


def _finish(
    schedule: Schedule,
    work: Work,
    state: ExecutionState,
    goal: Goal | None,
) -> Replan:
    deferred = set(work.deferred)
    tasks = tuple(t for t in work.tasks.values() if t.id not in deferred)
    live = {t.id for t in tasks}
    precedences = tuple(
        p for p in work.precedences if p.before in live and p.after in live
    )
    parked = tuple(
        p
        for p in work.precedences
        if {p.before, p.after} <= work.tasks.keys()
        and (p.before in deferred or p.after in deferred)
    )
    # Float noise, or an overrun reported by telemetry, can predict a level
    # just below zero; a problem cannot start there, so it starts empty.
    # Each capacity is kept, and a level above it is cut to it.
    levels = {name: max(0.0, level) for name, level in state.levels.items()}
    resources = schedule.problem.resources.with_levels(levels)
    settled = schedule.problem.replace(alternatives=tuple(work.groups))
    problem = schedule.problem.replace(
        start=work.now,
        tasks=tasks,
        precedences=precedences,
        resources=resources,
        # Options with a task deferred beyond the horizon wait for it.
        alternatives=groups.kept_alternatives(settled, live),
    )
    _validate_merged(problem, goal)
    pinned = tuple(name for name in work.pinned if name in live)
    following = Schedule(
        problem=problem,
        plan=empty_plan(),
        catalog=tuple(work.catalog.values()),
        catalog_precedences=tuple(work.catalog_precedences),
        history=tuple(work.history),
        continuing=pinned,
        obsolete=tuple(work.obsolete),
        deferred=tuple(work.tasks[name] for name in work.deferred),
        parked=parked,
        reports=tuple(r for r in schedule.reports if r.at > work.now),
    )
    return Replan(
        problem=problem,
        removed=tuple(work.removed),
        continuing=pinned,
        warm=_warm_plan(problem, schedule.plan),
        readded=tuple(n for n in work.readded if n in live),
        deferred=tuple(work.deferred),
        following=following,
    )


def _validate_merged(problem: Problem, goal: Goal | None) -> None:
    issues = [
        issue
        for issue in validate_problem(problem)
        if not (issue.path == "tasks" and not problem.tasks)
    ]
    if not issues:
        return
    if goal is None:
        raise InputError(issues, "replanned problem")
    task_idx = {t.id: i for i, t in enumerate(goal.tasks)}
    prec_idx = {p: i for i, p in enumerate(goal.precedences)}
    mapped = []
    for issue in issues:
        mapped.append(_goal_path(problem, issue, task_idx, prec_idx))
    raise InputError(mapped, "goal")


def _goal_path(
    problem: Problem,
    issue: FieldIssue,
    task_idx: Mapping[str, int],
    prec_idx: Mapping[Precedence, int],
) -> FieldIssue:
    """Name the goal's field for an issue of the merged problem."""
    for kind in ("tasks", "precedences"):
        prefix = f"{kind}["
        if not issue.path.startswith(prefix):
            continue
        idx_text, _, rest = issue.path[len(prefix) :].partition("]")
        idx = int(idx_text)
        if kind == "tasks":
            own = task_idx.get(problem.tasks[idx].id)
        else:
            own = prec_idx.get(problem.precedences[idx])
        if own is not None:
            return FieldIssue(f"{kind}[{own}]{rest}", issue.reason)
    return FieldIssue(
        "", f"merged problem, {issue.path or 'document'}: {issue.reason}"
    )


def _warm_plan(problem: Problem, old: Plan) -> Plan:
    """The old plan's starts that still fit, as a MIP start.

    A task the old plan runs across the replan's start, whose remaining
    part is now the task (``from_interrupt``: as long as the old plan had
    left of it), starts there: the old plan carries it on. Left out, a
    ``both`` partner after it made the plan in force invalid on the new
    day (replan suite, seed 210's r60-h1440-0), and the repair could not
    start from it.
    """
    starts = old.starts()
    left = {
        a.task: a.end - problem.start
        for a in old.activities
        if a.start < problem.start < a.end
    }
    activities = []
    unscheduled = []
    for task in problem.tasks:
        earliest, latest = problem.start_bounds(task)
        start = task.fixed_start
        if start is None:
            start = starts.get(task.id)
        if (
            start is not None
            and start < problem.start
            and left.get(task.id) == task.length
        ):
            start = problem.start
        if start is not None and earliest <= start <= latest:
            activities.append(Activity(task.id, start, start + task.length))
        else:
            unscheduled.append(task.id)
    return Plan(
        status=SolveStatus.FEASIBLE,
        objective=None,
        activities=tuple(activities),
        unscheduled=tuple(unscheduled),
    )


def apply_change(schedule: Schedule, change: Change, now: int) -> Replan:
    """Dispatch a decoded change to its trigger."""
    if isinstance(change, Goal):
        return apply_goal(schedule, change, now)
    if isinstance(change, ActivityFailed):
        return apply_failure(schedule, change.task, change.at, now=now)
    return apply_levels(schedule, change.levels, now, at=change.at)
