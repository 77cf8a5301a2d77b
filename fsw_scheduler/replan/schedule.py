"""What the engine keeps between replans, and the execution state at ``now``.

A :class:`Schedule` holds the current problem and plan, the catalog of
every task and precedence ever accepted, what has been executed, and which
tasks are continuing an execution. :func:`execution_state` derives where
each task stands at ``now`` from the plan and the reports. After a solve,
:meth:`Replan.adopt` gives the next :class:`Schedule`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

import msgspec

from ..model.change import ExecutionReport, Outcome, Removal
from ..model.levels import check_now, cut_to_capacity, levels_at
from ..model.plan import Activity, Objective, Plan, SolveStatus
from ..model.problem import (
    Precedence,
    Problem,
    Task,
)

if TYPE_CHECKING:
    from collections.abc import Iterable, Mapping

__all__ = [
    "Execution",
    "ExecutionState",
    "Replan",
    "Schedule",
    "TaskState",
    "empty_plan",
    "execution_state",
    "run_spans",
]


Phase = Literal["pending", "running", "finished", "failed"]


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
    check_now(problem, now)
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
    levels = levels_at(problem, run_spans(states, now), now)
    if measured:
        levels.update(cut_to_capacity(problem, measured))
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
    if report.state == "missed":
        return TaskState(task.id, "pending")  # never ran: plan it again
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


def run_spans(
    states: Iterable[TaskState], now: int
) -> dict[str, tuple[int, int]]:
    """Task to the units ``[since, until)`` it ran (until ``now`` if it
    still runs), as :func:`execution_state` counts them.

    Parameters
    ----------
    states
        The tasks' states at ``now`` (:attr:`ExecutionState.tasks`).
    now
        The time unit of the states.

    Returns
    -------
    dict
        Task id to its span, for every task that has started.
    """
    return {
        s.task: (s.since, s.until if s.until is not None else now)
        for s in states
        if s.since is not None
    }


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

    def trimmed(self, keep: int) -> Schedule:
        """This schedule with a bounded past: what the rules can still use.

        Live tasks (in the problem or deferred), their executions and the
        finished tasks catalog precedences tie to a live one stay; of
        the other finished tasks, executions and obsolete ids only the
        last ``keep`` do. A long mission's state (its snapshot, shared
        with a standby and opening every journal part) stays bounded.
        """
        live = {t.id for t in self.problem.tasks} | {
            t.id for t in self.deferred
        }
        # Finished tasks reachable from a live one through precedences: a
        # tight chain may bring them back.
        needed = set(live)
        grew = True
        while grew:
            grew = False
            for p in self.catalog_precedences:
                if (p.before in needed) != (p.after in needed):
                    needed |= {p.before, p.after}
                    grew = True
        if (
            len(self.catalog) <= len(needed) + keep
            and len(self.history) <= keep + len(needed)
            and len(self.obsolete) <= keep
        ):
            return self
        others = [t for t in self.catalog if t.id not in needed]
        kept_others = {t.id for t in others[max(0, len(others) - keep) :]}
        catalog = tuple(
            t for t in self.catalog if t.id in needed or t.id in kept_others
        )
        ids = {t.id for t in catalog}
        past = [e for e in self.history if e.task not in needed]
        recent = set(map(id, past[max(0, len(past) - keep) :]))
        history = tuple(
            e for e in self.history if e.task in needed or id(e) in recent
        )
        return msgspec.structs.replace(
            self,
            catalog=catalog,
            catalog_precedences=tuple(
                p
                for p in self.catalog_precedences
                if p.before in ids and p.after in ids
            ),
            history=history,
            obsolete=self.obsolete[max(0, len(self.obsolete) - keep) :],
        )


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
