"""Online rescheduling: from a running plan and a change to a new problem.

This module implements the paper's "Online rescheduling" section. A
:class:`Schedule` is what the engine keeps between replans: the current
problem and plan, the catalog of every task and precedence ever accepted,
what has been executed, and which tasks are continuing an execution. A
trigger (:func:`apply_goal`, :func:`apply_failure`, :func:`apply_levels`)
turns it into a :class:`Replan`: a new problem over ``[now, now + H)``, the
removals with the rule that caused each, the continuing tasks and a warm
start. After solving, :meth:`Replan.adopt` gives the next :class:`Schedule`.

Each rule is one function named ``rule_*`` whose docstring cites the paper.
They run in this order (a later rule sees the result of earlier ones):

1. :func:`rule_finished_leave`: finished tasks leave (``finished``).
2. :func:`rule_failed_activity`: a reported failure, by preemption policy
   (``failed_delete``).
3. :func:`rule_running_preemption`: running tasks, by preemption policy
   (``preemption_delete``); non-preemptible ones are pinned and continuing.
4. :func:`rule_obsolete`: a goal's ``obsoletes`` (``obsolete``).
5. :func:`rule_removal_cascade` after every removal (``tight_cascade``).
6. goal merge (collisions and unknown references reject the goal).
7. :func:`rule_tight_chain`: a preempted or failed task that is rescheduled
   brings back its executed tight partners (re-added from the catalog).
8. :func:`rule_settled_precedences`: precedences touching a finished task
   are dropped; a successor still waiting keeps its bound on the start.
9. :func:`rule_window_passed` (``window_passed``) and
   :func:`rule_defer_beyond_horizon` (kept aside, not removed).

The module is pure: no solver import at module level, no bus, no wall
clock, no threads; time is always an argument.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Literal, NamedTuple

import msgspec

from ..errors import FieldIssue, InputError
from ..model import problem as model
from ..model.goal import Goal, decode_goal
from ..model.plan import Activity, Objective, Plan, SolveStatus
from ..model.problem import (
    Precedence,
    Problem,
    Task,
    decode_strict,
    validate_problem,
)

__all__ = [
    "ActivityFailed",
    "Drift",
    "Execution",
    "ExecutionReport",
    "ExecutionState",
    "LevelsMeasured",
    "Move",
    "PlanDiff",
    "Removal",
    "Replan",
    "Schedule",
    "TaskState",
    "Tolerance",
    "apply_change",
    "apply_failure",
    "apply_goal",
    "apply_levels",
    "decode_change",
    "diff_plans",
    "drift",
    "empty_plan",
    "execution_state",
    "format_diff",
    "predicted_levels",
    "replan_files",
]

ReportState = Literal["running", "completed", "failed"]
Phase = Literal["pending", "running", "finished", "failed"]
Outcome = Literal["completed", "failed", "interrupted"]

#: Removal rule names, in the order the rules run.
RULES = (
    "finished",
    "failed_delete",
    "preemption_delete",
    "obsolete",
    "tight_cascade",
    "window_passed",
)

# --------------------------------------------------------------------------
# Execution state


class ExecutionReport(msgspec.Struct, frozen=True):
    """An execution report from the spacecraft (``telemetry/activities``).

    Attributes
    ----------
    task
        The task reported on.
    state
        ``running``, ``completed`` or ``failed``.
    at
        Time unit of the report.
    """

    task: str
    state: ReportState
    at: int


class TaskState(msgspec.Struct, frozen=True, omit_defaults=True):
    """Where one task of the current plan stands at ``now``.

    Attributes
    ----------
    task
        Task id.
    phase
        ``pending`` (not started), ``running``, ``finished`` or ``failed``.
    since
        First time unit it ran (of the current problem's version of the
        task), None when pending.
    until
        First time unit it no longer ran (finished or failed), else None.
    done
        Units of the current version run before ``now``.
    """

    task: str
    phase: Phase
    since: int | None = None
    until: int | None = None
    done: int = 0


class ExecutionState(msgspec.Struct, frozen=True):
    """The state of every task at the start of time unit ``now``.

    Attributes
    ----------
    now
        The time unit.
    tasks
        One :class:`TaskState` per task of the problem, in problem order.
    levels
        Consumable levels at the start of unit ``now``: measured where
        given, otherwise predicted from the executions.
    """

    now: int
    tasks: tuple[TaskState, ...]
    levels: dict[str, float]

    def of(self, task_id: str) -> TaskState:
        """The state of ``task_id`` (KeyError if it is not in the problem)."""
        for state in self.tasks:
            if state.task == task_id:
                return state
        raise KeyError(task_id)


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
    _check_now(problem, now)
    runs = {
        a.task: max(0, min(a.end, now) - a.start)
        for a in plan.activities
        if a.start < now
    }
    spans = {
        a.task: (a.start, min(a.end, now))
        for a in plan.activities
        if a.start < now
    }
    return _capped(problem, _levels(problem, runs), spans, now)


def execution_state(
    problem: Problem,
    plan: Plan,
    now: int,
    *,
    reports: Iterable[ExecutionReport] = (),
    measured: Mapping[str, float] | None = None,
    continuing: Iterable[str] = (),
) -> ExecutionState:
    """Derive the execution state at ``now``.

    The plan is assumed to run as planned: an activity with ``end <= now``
    is finished, one with ``start < now < end`` is running. An activity
    starting at ``now`` has not started, unless it is *continuing* (pinned
    by a previous replan: it has been running all along). The latest
    report of a task with ``problem.start <= at <= now`` overrides this:

    * ``running`` at T: running since its planned start if that is not
      after T, else since T; if the plan says it should be over, it has
      overrun and one unit is left.
    * ``completed`` at T: finished at T.
    * ``failed`` at T: failed at T, with the units run until then.

    Parameters
    ----------
    problem, plan
        The current problem and plan.
    now
        Time unit, ``>= problem.start``.
    reports
        Execution reports, in arrival order.
    measured
        Consumable levels measured at the start of ``now``; they override
        the prediction resource by resource.
    continuing
        Tasks already running when ``problem`` was built.

    Returns
    -------
    ExecutionState
    """
    _check_now(problem, now)
    continuing = set(continuing)
    latest: dict[str, ExecutionReport] = {}
    for report in sorted(reports, key=lambda r: r.at):
        if problem.start <= report.at <= now:
            latest[report.task] = report
    states = []
    for task in problem.tasks:
        act = plan.activity(task.id)
        state = _planned_state(task, act, now, task.id in continuing)
        reported = latest.get(task.id)
        if reported is not None:
            state = _reported_state(task, act, now, reported, problem.start)
        states.append(state)
    runs = {
        s.task: (s.until if s.until is not None else now) - s.since
        for s in states
        if s.since is not None
    }
    levels = _capped(problem, _levels(problem, runs), _spans(states, now), now)
    if measured:
        levels.update(_cut_to_capacity(problem, measured))
    return ExecutionState(now=now, tasks=tuple(states), levels=levels)


def _planned_state(
    task: Task, act: Activity | None, now: int, continuing: bool
) -> TaskState:
    if act is None:
        return TaskState(task.id, "pending")
    if act.end <= now:
        return TaskState(task.id, "finished", act.start, act.end, task.length)
    if act.start < now or (continuing and act.start <= now):
        return TaskState(task.id, "running", act.start, done=now - act.start)
    return TaskState(task.id, "pending")


def _reported_state(
    task: Task,
    act: Activity | None,
    now: int,
    report: ExecutionReport,
    origin: int,
) -> TaskState:
    at = report.at
    planned = act.start if act is not None and act.start <= at else None
    if report.state == "completed":
        since = (
            planned if planned is not None else max(origin, at - task.length)
        )
        return TaskState(task.id, "finished", since, at, task.length)
    since = planned if planned is not None else at
    if report.state == "failed":
        done = min(max(0, at - since), task.length - 1)
        return TaskState(task.id, "failed", since, at, done)
    done = min(now - since, task.length - 1)
    return TaskState(task.id, "running", since, done=done)


def _levels(problem: Problem, runs: Mapping[str, int]) -> dict[str, float]:
    levels = problem.resources.initial_levels
    for task in problem.tasks:
        units = runs.get(task.id, 0)
        for name, amount in task.uses.items():
            if name in levels and units:
                levels[name] -= amount * units
    return levels


def _spans(
    states: Iterable[TaskState], now: int
) -> dict[str, tuple[int, int]]:
    """Task to the units ``[since, until)`` it ran (until ``now`` if it
    still runs), as :func:`execution_state` counts them."""
    return {
        s.task: (s.since, s.until if s.until is not None else now)
        for s in states
        if s.since is not None
    }


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
    walked unit by unit from the problem's start.
    """
    for name, top in problem.resources.ceilings.items():
        levels[name] = _walk_level(
            problem,
            spans,
            name,
            problem.resources.initial(name),
            (problem.start, now),
            top,
        )
    return levels


def _walk_level(
    problem: Problem,
    spans: Mapping[str, tuple[int, int]],
    name: str,
    level: float,
    window: tuple[int, int],
    top: float,
) -> float:
    """Level of ``name`` at the start of ``window[1]`` from ``level`` at
    the start of ``window[0]``: ``min(top, level - net use)`` per unit,
    the units each task ran given by ``spans`` (``[since, until)``).
    """
    first, last = window
    rates = [0.0] * max(0, last - first)
    for task in problem.tasks:
        amount = task.uses.get(name, 0)
        span = spans.get(task.id)
        if not amount or span is None:
            continue
        for t in range(max(span[0], first), min(span[1], last)):
            rates[t - first] += amount
    level = min(top, level)
    for used in rates:
        level = min(top, level - used)
    return level


def _cut_to_capacity(
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


def _check_now(problem: Problem, now: int) -> None:
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


# --------------------------------------------------------------------------
# State kept between replans


class Execution(msgspec.Struct, frozen=True):
    """One past execution of a task, kept in :attr:`Schedule.history`.

    ``start`` is the start of the last segment the scheduler saw (a task
    pinned over several replans reports its last segment).
    """

    task: str
    start: int
    end: int
    outcome: Outcome


class Schedule(msgspec.Struct, frozen=True):
    """What the engine keeps between replans.

    Attributes
    ----------
    problem
        The current problem (``[start, start + horizon)``).
    plan
        The plan being executed for ``problem``.
    catalog
        Every task ever accepted, in its original definition (full length,
        not pinned), latest definition per id; obsolete tasks leave it.
    catalog_precedences
        Every precedence ever accepted between catalog tasks.
    history
        Past executions.
    continuing
        Tasks of ``problem`` pinned because they were already running;
        the engine must not dispatch them again.
    obsolete
        Ids made obsolete by goals; they never come back by a rule.
    deferred
        Accepted tasks whose window lies beyond the current horizon; they
        enter a later problem when it reaches them.
    parked
        Precedences touching a deferred task.
    reports
        Execution reports not yet consumed by a replan.
    """

    problem: Problem
    plan: Plan
    catalog: tuple[Task, ...] = ()
    catalog_precedences: tuple[Precedence, ...] = ()
    history: tuple[Execution, ...] = ()
    continuing: tuple[str, ...] = ()
    obsolete: tuple[str, ...] = ()
    deferred: tuple[Task, ...] = ()
    parked: tuple[Precedence, ...] = ()
    reports: tuple[ExecutionReport, ...] = ()

    @classmethod
    def begin(cls, problem: Problem, plan: Plan) -> Schedule:
        """Start a session from a solved problem.

        Parameters
        ----------
        problem
            The first problem; its tasks and precedences form the catalog.
        plan
            Its plan.
        """
        return cls(
            problem=problem,
            plan=plan,
            catalog=problem.tasks,
            catalog_precedences=problem.precedences,
        )

    @property
    def horizon(self) -> int:
        """Horizon length H kept by every replan."""
        return self.problem.horizon

    def with_report(self, report: ExecutionReport) -> Schedule:
        """Record an execution report for the next replan."""
        return msgspec.structs.replace(self, reports=(*self.reports, report))

    def state(
        self, now: int, measured: Mapping[str, float] | None = None
    ) -> ExecutionState:
        """The execution state at ``now`` (see :func:`execution_state`)."""
        return execution_state(
            self.problem,
            self.plan,
            now,
            reports=self.reports,
            measured=measured,
            continuing=self.continuing,
        )


class Removal(msgspec.Struct, frozen=True):
    """A task that left the pending list, and why.

    Attributes
    ----------
    task
        Task id.
    rule
        One of :data:`RULES` (or ``unscheduled`` in a :class:`PlanDiff`).
    detail
        Plain-words explanation.
    """

    task: str
    rule: str
    detail: str = ""


class Replan(msgspec.Struct, frozen=True):
    """The result of a trigger: a problem to solve and what changed.

    Attributes
    ----------
    problem
        The new problem over ``[now, now + H)``. It may have no task (all
        done); then :func:`empty_plan` is its plan and no solve is needed.
    removed
        Tasks that left, with their rule, in the order the rules ran.
    continuing
        Running tasks pinned at ``now`` with their remaining length; the
        engine must not dispatch them again.
    warm
        The old plan mapped onto the new problem, as a MIP start.
    readded
        Executed tasks brought back by :func:`rule_tight_chain`.
    deferred
        Tasks kept aside because their window is beyond the horizon.
    following
        The schedule to adopt once ``problem`` is solved.
    """

    problem: Problem
    removed: tuple[Removal, ...]
    continuing: tuple[str, ...]
    warm: Plan | None
    readded: tuple[str, ...]
    deferred: tuple[str, ...]
    following: Schedule

    def adopt(self, plan: Plan) -> Schedule:
        """The schedule to keep once ``plan`` solves :attr:`problem`."""
        return msgspec.structs.replace(self.following, plan=plan)


def empty_plan() -> Plan:
    """The plan of a problem with no task."""
    return Plan(status=SolveStatus.OPTIMAL, objective=Objective(0, 0, 0))


# --------------------------------------------------------------------------
# The working set a replan edits, rule after rule.


@dataclass
class _Work:
    now: int
    horizon: int
    base: Problem
    tasks: dict[str, Task]
    precedences: list[Precedence]
    catalog: dict[str, Task]
    catalog_precedences: list[Precedence]
    history: list[Execution]
    obsolete: list[str]
    removed: list[Removal] = field(default_factory=list)
    pinned: list[str] = field(default_factory=list)
    rescheduled: list[str] = field(default_factory=list)
    readded: list[str] = field(default_factory=list)
    deferred: list[str] = field(default_factory=list)
    runs: dict[str, tuple[int, int]] = field(default_factory=dict)
    keep_running: bool = False

    def remove(self, task_id: str, rule: str, detail: str) -> None:
        """Take ``task_id`` out of the live set and record why."""
        self.tasks.pop(task_id, None)
        if task_id in self.rescheduled:
            self.rescheduled.remove(task_id)
        self.removed.append(Removal(task_id, rule, detail))

    def frame(self) -> Problem:
        """An empty problem over the new window, for start bounds."""
        return Problem(
            horizon=self.horizon,
            tasks=(),
            start=self.now,
            feasible_interval_applies_to=(
                self.base.feasible_interval_applies_to
            ),
            resources=self.base.resources,
        )


def _start_work(schedule: Schedule, now: int) -> _Work:
    tasks = {t.id: t for t in (*schedule.problem.tasks, *schedule.deferred)}
    runs = {
        e.task: (e.start, e.end)
        for e in schedule.history
        if e.outcome == "completed"
    }
    return _Work(
        now=now,
        horizon=schedule.horizon,
        base=schedule.problem,
        tasks=tasks,
        precedences=[*schedule.problem.precedences, *schedule.parked],
        catalog={t.id: t for t in schedule.catalog},
        catalog_precedences=list(schedule.catalog_precedences),
        history=list(schedule.history),
        obsolete=list(schedule.obsolete),
        runs=runs,
    )


# --------------------------------------------------------------------------
# The rules


def rule_finished_leave(work: _Work, state: ExecutionState) -> list[str]:
    """Finished tasks leave the problem (rule ``finished``).

    Paper, "Online rescheduling": the new activities "must be co-scheduled
    together with those already present in the schedule and not already
    executed". Their consumption is already in the new initial levels
    (``state.levels``); they stay in the catalog so that
    :func:`rule_tight_chain` can bring them back.

    Returns
    -------
    list of str
        The finished task ids.
    """
    finished = []
    for ts in state.tasks:
        if ts.phase != "finished":
            continue
        assert ts.since is not None and ts.until is not None
        work.history.append(
            Execution(ts.task, ts.since, ts.until, "completed")
        )
        work.runs[ts.task] = (ts.since, ts.until)
        work.remove(ts.task, "finished", f"ran over [{ts.since}, {ts.until})")
        finished.append(ts.task)
    return finished


def rule_failed_activity(
    work: _Work, state: ExecutionState, task_id: str
) -> list[str]:
    """A failed activity is handled by its preemption policy.

    Paper, "Online rescheduling": unexpected events such as faults "call
    for a rescheduling procedure", and a running task is treated by its
    preemption behaviour. A failure interrupts the task, so:

    * ``from_start``: retried in full.
    * ``none``: retried in full too. The policy says the task cannot be
      interrupted, so its partial run is worthless and it cannot resume
      in the middle; a fresh run is the only way to reach its effect.
    * ``from_interrupt``: only the remaining part is rescheduled.
    * ``delete``: dropped (rule ``failed_delete``); its tight chain goes
      with it through :func:`rule_removal_cascade`.

    Returns
    -------
    list of str
        Seeds for the removal cascade (the task when deleted).
    """
    ts = state.of(task_id)
    task = work.tasks[task_id]
    since = ts.since if ts.since is not None else work.now
    until = ts.until if ts.until is not None else work.now
    work.history.append(Execution(task_id, since, until, "failed"))
    if task.preemption == "delete":
        work.remove(
            task_id, "failed_delete", f"failed at {until}, preemption delete"
        )
        return [task_id]
    if task.preemption == "from_interrupt":
        work.tasks[task_id] = _unpinned(task, task.length - ts.done)
    else:
        work.tasks[task_id] = work.catalog.get(task_id, _unpinned(task))
    work.rescheduled.append(task_id)
    return []


def rule_running_preemption(work: _Work, state: ExecutionState) -> list[str]:
    """Running tasks are treated by their preemption policy.

    Paper, "Online rescheduling", the four behaviours for running tasks:

    * ``none``: "cannot be interrupted and will be concluded in the new
      schedule": pinned at ``now`` (``fixed_start``) with its remaining
      length and flagged continuing. Its feasible interval is dropped: it
      was honoured when the task started.
    * ``from_start``: "completely rescheduled": back to its full length.
    * ``from_interrupt``: "only the remaining part must be rescheduled".
    * ``delete``: "deleted from the schedule" (rule ``preemption_delete``).

    A replan that only corrects the world (measured levels, a stale plan)
    sets ``keep_running``: nothing new competes for the running tasks, so
    they all continue as if non-preemptible rather than being interrupted,
    with their tight chains, on every telemetry update.

    Returns
    -------
    list of str
        Seeds for the removal cascade (deleted tasks).
    """
    seeds = []
    for ts in state.tasks:
        if ts.phase != "running" or ts.task not in work.tasks:
            continue
        task = work.tasks[ts.task]
        remaining = task.length - ts.done
        if task.preemption == "none" or work.keep_running:
            work.tasks[ts.task] = msgspec.structs.replace(
                task,
                length=remaining,
                fixed_start=work.now,
                feasible_interval=None,
                feasible_interval_applies_to=None,
            )
            work.pinned.append(ts.task)
            continue
        assert ts.since is not None
        work.history.append(
            Execution(ts.task, ts.since, work.now, "interrupted")
        )
        if task.preemption == "delete":
            work.remove(
                ts.task,
                "preemption_delete",
                f"running at {work.now}, preemption delete",
            )
            seeds.append(ts.task)
        elif task.preemption == "from_interrupt":
            work.tasks[ts.task] = _unpinned(task, remaining)
            work.rescheduled.append(ts.task)
        else:
            work.tasks[ts.task] = work.catalog.get(ts.task, _unpinned(task))
            work.rescheduled.append(ts.task)
    return seeds


def rule_obsolete(work: _Work, goal: Goal) -> list[str]:
    """A goal's ``obsoletes`` remove tasks from the pending list.

    Paper, "Online rescheduling", last case: a new goal can make tasks
    already in the schedule obsolete; "obsolete activities are removed
    from the pending list and are not included in subsequent schedules".
    The ids also leave the catalog, so no rule brings them back. A running
    task with preemption ``none`` cannot be interrupted: it finishes as
    pinned, then leaves. Naming a task never accepted rejects the goal.

    Returns
    -------
    list of str
        Seeds for the removal cascade.

    Raises
    ------
    InputError
        When an obsoleted id is unknown (path ``tasks[i].obsoletes[j]``).
    """
    issues = []
    seeds = []
    for idx, task in enumerate(goal.tasks):
        for jdx, name in enumerate(task.obsoletes):
            known = (
                name in work.tasks
                or name in work.catalog
                or any(r.task == name for r in work.removed)
            )
            if not known:
                issues.append(
                    FieldIssue(
                        f"tasks[{idx}].obsoletes[{jdx}]",
                        f"unknown task {name!r}",
                    )
                )
                continue
            if name not in work.obsolete:
                work.obsolete.append(name)
            if name in work.tasks and name not in work.pinned:
                work.remove(
                    name,
                    "obsolete",
                    f"made obsolete by {task.id} of goal {goal.goal_id}",
                )
                seeds.append(name)
    if issues:
        raise InputError(issues, "goal")
    for name in goal.obsoleted:
        if name not in work.pinned:
            _forget(work, name)
    return seeds


def rule_removal_cascade(work: _Work, seeds: Sequence[str]) -> None:
    """Removal follows tight constraints; lax constraints are dropped.

    Paper, "Online rescheduling": "When a task is removed from the
    scheduling problem, all other tasks that follow the deleted task inside
    a tight constraint are also removed from the pending activities.
    Instead, tasks that follow a lax constraint are maintained, but the
    constraint is removed." A task that *precedes* a removed one through a
    tight ``both`` constraint goes too: ``both`` means both or neither, and
    a tight predecessor only exists as its precondition (this removes the
    old SetPositionZ with AcquisitionHF in the paper's Table 2). Through a
    tight ``at_least_first`` constraint the predecessor stays. Every
    constraint touching a removed task is dropped. Pinned (continuing)
    tasks cannot be interrupted and stop the cascade. Rule
    ``tight_cascade``; it runs transitively.
    """
    work.precedences = cascade(
        work.precedences,
        seeds,
        live=lambda name: name in work.tasks and name not in work.pinned,
        remove=lambda name, detail: work.remove(
            name, "tight_cascade", detail
        ),
    )


def cascade(
    precedences: Sequence[Precedence],
    seeds: Sequence[str],
    live: Callable[[str], bool],
    remove: Callable[[str, str], None],
    cause: str = "removed",
) -> list[Precedence]:
    """The removal cascade of :func:`rule_removal_cascade`, on any task set.

    Parameters
    ----------
    precedences
        The precedences among the tasks.
    seeds
        Tasks just removed.
    live
        Whether a task is still there and may be removed.
    remove
        Removes a task taken by the cascade, given the plain-words reason.
    cause
        How the reason names a seed's removal (``removed``, ``shed task``).

    Returns
    -------
    list of Precedence
        The precedences that touch no removed task.
    """
    kept = list(precedences)
    queue = list(seeds)
    while queue:
        gone = queue.pop(0)
        keep = []
        for prec in kept:
            if gone not in (prec.before, prec.after):
                keep.append(prec)
                continue
            other = prec.after if prec.before == gone else prec.before
            follows = prec.after == other
            takes = prec.kind == "tight" and (follows or prec.scope == "both")
            if takes and live(other):
                how = "follows" if follows else "tightly precedes"
                remove(
                    other,
                    f"{how} {cause} {gone} through a tight {prec.scope} "
                    "precedence",
                )
                queue.append(other)
        kept = keep
    return kept


def rule_tight_chain(work: _Work) -> None:
    """A preempted task that is rescheduled brings its tight chain along.

    Paper, "Online rescheduling": "When an activity that belongs to a
    precedence sequence is preempted and rescheduled, then also all the
    other tasks in the chain, that is all the tasks involved in tight
    precedence constraints with the interrupted task, have to be
    rescheduled, even those that have already been executed." The chain
    is the set of tasks joined by tight precedences of the catalog,
    transitively, in either direction. Members still live are already in
    the problem; executed members are re-added from the catalog (full
    definition) with the catalog precedences that join them to live tasks.
    Obsolete tasks never come back.
    """
    tight = [p for p in work.catalog_precedences if p.kind == "tight"]
    seen = set(work.rescheduled)
    queue = list(work.rescheduled)
    added: list[str] = []
    while queue:
        name = queue.pop(0)
        for prec in tight:
            if name not in (prec.before, prec.after):
                continue
            other = prec.after if prec.before == name else prec.before
            if other in seen or other in work.obsolete:
                continue
            seen.add(other)
            queue.append(other)
            if (
                other not in work.tasks
                and other in work.runs
                and (other in work.catalog)
            ):
                work.tasks[other] = work.catalog[other]
                added.append(other)
    if not added:
        return
    work.readded += added
    # Re-added tasks are live again: they must not be dropped as finished.
    for name in added:
        work.runs.pop(name, None)
    present = set(work.precedences)
    for prec in work.catalog_precedences:
        ends = (prec.before, prec.after)
        if (
            prec not in present
            and all(end in work.tasks for end in ends)
            and any(end in added for end in ends)
        ):
            work.precedences.append(prec)
            present.add(prec)


def rule_settled_precedences(work: _Work) -> tuple[list[str], list[str]]:
    """Precedences touching a finished task are dropped.

    Paper, "Online rescheduling": only tasks "not already executed" are
    co-scheduled, so a constraint with an executed task has no second end
    left in the problem. ``scope`` is settled by the execution (the
    predecessor ran). The start bound it put on a successor still waiting
    is kept, as the successor's window (``start`` reading): ``start ==
    end_before + offset`` for tight, ``>=`` for lax, where ``end_before``
    is when the predecessor really finished. A successor left with no
    start is removed (rule ``window_passed``). A tight successor whose
    required start has already passed can no longer follow its
    precondition: it is handed to :func:`rule_tight_chain`, which runs the
    precondition again. A precedence whose ``after`` is pinned (already
    started) is settled and dropped.

    Returns
    -------
    tuple of two lists of str
        Successors that need their tight chain run again, and seeds for
        the removal cascade.
    """
    keep = []
    redo = []
    seeds: dict[str, str] = {}
    for prec in work.precedences:
        before_live = prec.before in work.tasks
        after_live = prec.after in work.tasks
        if before_live and after_live and prec.after not in work.pinned:
            keep.append(prec)
            continue
        run = work.runs.get(prec.before)
        if run is None or not after_live or prec.after in work.pinned:
            continue
        bound = run[1] + prec.offset
        if prec.kind == "tight" and bound < work.now:
            redo.append(prec.after)
            continue
        high = None if prec.kind == "lax" else bound
        task = _bounded(work, work.tasks[prec.after], bound, high)
        if task is None:
            seeds.setdefault(
                prec.after,
                f"no start left after {prec.before} (ended {run[1]})",
            )
        else:
            work.tasks[prec.after] = task
    work.precedences = keep
    # Removed only now, so that the cascade still sees their constraints.
    for name, detail in seeds.items():
        work.remove(name, "window_passed", detail)
    return [n for n in redo if n in work.tasks], list(seeds)


def rule_window_passed(work: _Work) -> list[str]:
    """Tasks whose feasible interval has passed are removed.

    Paper, "Scheduling problem definition": the start is bounded to the
    feasible interval; once ``now`` is past its last allowed start (or a
    pin is in the past), the task can no longer be scheduled in any later
    horizon. Rule ``window_passed``.

    Returns
    -------
    list of str
        Seeds for the removal cascade.
    """
    seeds = []
    frame = work.frame()
    for task in list(work.tasks.values()):
        if task.id in work.pinned:
            continue
        latest = _latest_start(frame, task)
        if latest < work.now:
            work.remove(
                task.id,
                "window_passed",
                f"last allowed start {latest} is before {work.now}",
            )
            seeds.append(task.id)
    return seeds


def rule_defer_beyond_horizon(work: _Work) -> None:
    """Tasks that fit only after the horizon are kept aside.

    Not in the paper, whose horizon is fixed; with a rolling horizon, a
    task whose window opens after ``now + H`` is accepted but cannot be in
    this problem. It waits in :attr:`Schedule.deferred` and enters the
    first later replan whose horizon reaches it. Tight successors, tight
    ``both`` predecessors and any successor (which must start after it)
    wait with it; other constraints touching it are parked.
    """
    frame = work.frame()
    queue = []
    for task in work.tasks.values():
        earliest, latest = frame.start_bounds(task)
        if task.id not in work.pinned and earliest > latest:
            queue.append(task.id)
    waiting = set(queue)
    while queue:
        name = queue.pop(0)
        for prec in work.precedences:
            if name not in (prec.before, prec.after):
                continue
            other = prec.after if prec.before == name else prec.before
            follows = prec.after == other
            drags = follows or (prec.kind == "tight" and prec.scope == "both")
            if drags and other not in waiting and other not in work.pinned:
                waiting.add(other)
                queue.append(other)
    work.deferred = [name for name in work.tasks if name in waiting]


# --------------------------------------------------------------------------
# Rule helpers


def _unpinned(task: Task, length: int | None = None) -> Task:
    return msgspec.structs.replace(
        task,
        length=task.length if length is None else length,
        fixed_start=None,
    )


def _forget(work: _Work, name: str) -> None:
    work.catalog.pop(name, None)
    work.catalog_precedences = [
        p for p in work.catalog_precedences if name not in (p.before, p.after)
    ]


def _latest_start(frame: Problem, task: Task) -> int:
    """Last start allowed by window and pin, ignoring the horizon end."""
    open_ended = frame.replace(horizon=10**9)
    return open_ended.start_bounds(task)[1]


def _bounded(
    work: _Work, task: Task, low: int, high: int | None
) -> Task | None:
    """``task`` with its start also kept in ``[low, high]``, None if empty."""
    open_ended = work.frame().replace(horizon=10**9)
    earliest, latest = open_ended.start_bounds(task)
    earliest = max(earliest, low)
    if high is not None:
        latest = min(latest, high)
    if earliest > latest or latest < work.now:
        return None
    if earliest <= work.now and latest >= 10**9 - task.length:
        return task  # the bound is already met by any start in the horizon
    return msgspec.structs.replace(
        task,
        feasible_interval=(earliest, latest),
        feasible_interval_applies_to="start",
    )


# --------------------------------------------------------------------------
# Goal merge


def _merge_goal(work: _Work, goal: Goal) -> None:
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
            issues += model._check_use(work.base.resources, name, amount, path)
        if task.length > work.horizon:
            issues.append(
                FieldIssue(
                    f"{path}.length",
                    f"length {task.length} exceeds the horizon {work.horizon}",
                )
            )
        elif _latest_start(frame, task) < work.now:
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
    if issues:
        raise InputError(issues, "goal")
    for gtask in goal.tasks:
        task = gtask.to_task()
        _forget(work, task.id)  # an id reused for a new task
        work.tasks[task.id] = task
        work.catalog[task.id] = task
        if task.id in work.obsolete:
            work.obsolete.remove(task.id)
        work.runs.pop(task.id, None)
    work.precedences += goal.precedences
    work.catalog_precedences += goal.precedences


# --------------------------------------------------------------------------
# Triggers


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
        The goal (see :func:`fsw_scheduler.goal.decode_goal`).
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
    measured = _cut_to_capacity(problem, measured)
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
            else _walk_level(
                problem,
                _spans(later.tasks, now),
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
    work = _start_work(schedule, now)
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
    rule_defer_beyond_horizon(work)
    return _finish(schedule, work, state, goal)


def _finish(
    schedule: Schedule,
    work: _Work,
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
    problem = schedule.problem.replace(
        start=work.now,
        tasks=tasks,
        precedences=precedences,
        resources=resources,
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
    """The old plan's starts that still fit, as a MIP start."""
    starts = old.starts()
    activities = []
    unscheduled = []
    for task in problem.tasks:
        earliest, latest = problem.start_bounds(task)
        start = task.fixed_start
        if start is None:
            start = starts.get(task.id)
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


# --------------------------------------------------------------------------
# Change documents (CLI) and plan differences


class ActivityFailed(
    msgspec.Struct, frozen=True, tag="activity_failed", tag_field="event"
):
    """Event document: ``{"event": "activity_failed", "task", "at"}``."""

    task: str
    at: int


class LevelsMeasured(
    msgspec.Struct, frozen=True, tag="levels", tag_field="event"
):
    """Event document: ``{"event": "levels", "levels": {...}, "at"}``."""

    levels: dict[str, float]
    at: int


Event = ActivityFailed | LevelsMeasured
Change = Goal | ActivityFailed | LevelsMeasured


def decode_change(data: bytes | str) -> Change:
    """Decode a goal or an event document, telling them apart.

    A document with an ``event`` key is an event (``activity_failed`` or
    ``levels``); any other is a goal.

    Raises
    ------
    InputError
        Paths name the field (``at``, ``tasks[0].length``).
    """
    head = decode_strict(data, dict, "change")
    if "event" in head:
        return decode_strict(data, Event, "event")  # type: ignore[arg-type]
    return decode_goal(data)


def apply_change(schedule: Schedule, change: Change, now: int) -> Replan:
    """Dispatch a decoded change to its trigger."""
    if isinstance(change, Goal):
        return apply_goal(schedule, change, now)
    if isinstance(change, ActivityFailed):
        return apply_failure(schedule, change.task, change.at, now=now)
    return apply_levels(schedule, change.levels, now, at=change.at)


class Move(msgspec.Struct, frozen=True):
    """A task kept in both plans at another time."""

    task: str
    old_start: int
    new_start: int
    old_end: int
    new_end: int


class PlanDiff(msgspec.Struct, frozen=True):
    """What a replan changed between two plans.

    Attributes
    ----------
    kept
        Scheduled at the same interval in both.
    continued
        Continuing (pinned) tasks: the rest of an activity already running.
    moved
        Scheduled in both at different intervals.
    added
        Scheduled only in the new plan.
    removed
        Every removal of the replan, plus old activities the solver left out
        (rule ``unscheduled``).
    """

    kept: tuple[str, ...]
    continued: tuple[str, ...]
    moved: tuple[Move, ...]
    added: tuple[str, ...]
    removed: tuple[Removal, ...]


def diff_plans(
    old: Plan,
    new: Plan,
    removed: Iterable[Removal] = (),
    *,
    continuing: Iterable[str] = (),
) -> PlanDiff:
    """Compare two plans of a session.

    Parameters
    ----------
    old, new
        The plans before and after a replan.
    removed
        The replan's removals (:attr:`Replan.removed`).
    continuing
        The replan's continuing tasks.

    Returns
    -------
    PlanDiff
    """
    removed = list(removed)
    gone = {r.task for r in removed}
    continuing = set(continuing)
    before = {a.task: a for a in old.activities}
    kept, continued, moved, added = [], [], [], []
    for act in new.activities:
        prev = before.get(act.task)
        if act.task in continuing:
            continued.append(act.task)
        elif prev is None or act.task in gone:
            # A removed id scheduled again is a new task (a goal reusing
            # the id, or an executed task re-added by its tight chain).
            added.append(act.task)
        elif (prev.start, prev.end) == (act.start, act.end):
            kept.append(act.task)
        else:
            moved.append(
                Move(act.task, prev.start, act.start, prev.end, act.end)
            )
    now_in = {a.task for a in new.activities}
    for act in old.activities:
        if act.task not in now_in and act.task not in gone:
            removed.append(
                Removal(act.task, "unscheduled", "left out by the solver")
            )
    return PlanDiff(
        kept=tuple(kept),
        continued=tuple(continued),
        moved=tuple(moved),
        added=tuple(added),
        removed=tuple(removed),
    )


def format_diff(diff: PlanDiff, new: Plan | None = None) -> str:
    """The diff as lines for humans, one task a line.

    Parameters
    ----------
    diff
        From :func:`diff_plans`.
    new
        The new plan, to show the intervals of kept, continued and added
        tasks (omitted when not given).
    """
    spans = {
        a.task: f" [{a.start}, {a.end})"
        for a in (new.activities if new is not None else ())
    }
    lines = [f"kept       {t}{spans.get(t, '')}" for t in diff.kept]
    lines += [f"continued  {t}{spans.get(t, '')}" for t in diff.continued]
    lines += [
        f"moved      {m.task} [{m.old_start}, {m.old_end}) -> "
        f"[{m.new_start}, {m.new_end})"
        for m in diff.moved
    ]
    lines += [f"added      {t}{spans.get(t, '')}" for t in diff.added]
    lines += [
        f"removed    {r.task} ({r.rule}{': ' + r.detail if r.detail else ''})"
        for r in diff.removed
    ]
    return "\n".join(lines)


SolveFn = Callable[..., Plan]


def replan_files(
    problem: Problem,
    plan: Plan,
    change: Change,
    now: int,
    *,
    solver: str = "cbc",
    time_limit: float | None = None,
    solve_fn: SolveFn | None = None,
) -> tuple[Problem, Plan, PlanDiff]:
    """One replan from files, for ``fsw-scheduler replan``.

    Parameters
    ----------
    problem, plan
        The running problem and its plan (the start of a session).
    change
        From :func:`decode_change`.
    now
        Time unit of the replan.
    solver, time_limit
        Passed to the solver.
    solve_fn
        The solve function (default :func:`fsw_scheduler.solve.solve`,
        imported only when called so this module stays solver-free).

    Returns
    -------
    tuple
        The new problem, its plan and the difference with ``plan``.

    Raises
    ------
    InputError
        The change is rejected; nothing was solved.
    """
    if solve_fn is None:
        from ..solving.solve import solve as default_solve

        solve_fn = default_solve
    replan = apply_change(Schedule.begin(problem, plan), change, now)
    if replan.problem.tasks:
        new_plan = solve_fn(
            replan.problem, solver, time_limit=time_limit, warm=replan.warm
        )
    else:
        new_plan = empty_plan()
    diff = diff_plans(
        plan, new_plan, replan.removed, continuing=replan.continuing
    )
    return replan.problem, new_plan, diff
