"""The engine's state, its statuses and the adoption of a plan.

:class:`EngineState` holds every piece of the scheduler's state and the
helpers that turn it into statuses, counters and verdicts; adopting a plan
and dispatching what is due are here too, since the solve queue
(:mod:`fsw_scheduler.engine.solves`) and the event handlers
(:mod:`fsw_scheduler.engine.core`) both end in them. The lifecycle of each
activity is kept by :class:`~fsw_scheduler.engine.dispatch.Dispatches`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Literal

import msgspec

from ..errors import FieldIssue, InputError
from ..model.change import ExecutionReport, Removal
from ..model.plan import Plan, SolveStatus
from ..wire import topics
from ..wire.messages import (
    Counters,
    PlanMessage,
    SolveSummary,
    Status,
)
from .dispatch import Dispatches, dispatch_message
from .events import (
    Command,
    Log,
    Publish,
    StartSolve,
)
from .ledger import GoalLedger
from .snapshot import PendingSolve, QueuedChange

if TYPE_CHECKING:
    from ..model.goal import Goal
    from ..model.problem import Problem
    from ..replan.schedule import Replan, Schedule
    from .config import EngineConfig


#: Finished tasks (and their executions, and obsolete ids) a schedule
#: keeps beyond what its live tasks need: late reports on them are noted,
#: and the snapshot shared with a standby stays bounded.
PAST_KEPT = 256


class EngineState:
    """The state of an :class:`~fsw_scheduler.engine.Engine` and its views.

    Parameters
    ----------
    config
        Engine settings.
    initial
        The initial problem.
    """

    def __init__(self, config: EngineConfig, initial: Problem) -> None:
        self.config = config
        self._unsolved_initial: Problem | None = initial
        self.schedule: Schedule | None = None
        self.plan_id: int | None = None
        self.now: int | None = None
        self._solve_id = 0
        self._pending: PendingSolve | None = None
        self._queue: list[QueuedChange] = []
        # The command term (events.TermBegan): stamped on every plan,
        # dispatch and status, so that receivers fence a stale commander.
        self.term = 0
        # The rule pass of the last goal checked on arrival, kept so that
        # starting its solve at once does not run the same pass again. A
        # memo of (schedule, now, goal) -> replan, derived, not state: a
        # snapshot leaves it out and a restored engine recomputes it.
        self._goal_checked: tuple[Schedule, int, Goal, Replan] | None = None
        self._ledger = GoalLedger(limit=config.max_goal_ids)
        self._dispatches = Dispatches()
        self._counters = Counters()
        self._last_solve: SolveSummary | None = None
        self._inputs = 0
        self._health: Literal["ok", "degraded", "error"] = "ok"
        self._health_detail = ""
        self._plan_message: PlanMessage | None = None
        self.initial = initial

    @property
    def busy(self) -> bool:
        """True while a solve is in flight."""
        return self._pending is not None

    @property
    def inputs_seen(self) -> int:
        """Number of events processed so far."""
        return self._inputs

    @property
    def plan_message(self) -> PlanMessage | None:
        """The current plan as published (None before the first plan)."""
        return self._plan_message

    def status(self, event: str = "heartbeat", **extra: object) -> Status:
        """The current status with the whole lifecycle map (queries).

        Publishing goes through :meth:`_status`, which also says what
        changed since the previous published status.
        """
        return Status(
            state=self._health,
            plan_id=self.plan_id,
            now=self.now,
            event=event,
            detail=str(extra.pop("detail", self._health_detail)),
            busy=self.busy,
            activities=dict(sorted(self._dispatches.lifecycle.items())),
            counters=self._counters,
            last_solve=self._last_solve,
            node_id=self.config.node_id,
            term=self.term,
            **extra,  # type: ignore[arg-type]
        )

    def pending_solve(self) -> StartSolve | None:
        """The solve in flight, as the command that asked for it.

        A node that resumes (or takes over) while a solve was running asks
        for it again: the same input gives the same plan.
        """
        pending = self._pending
        if pending is None:
            return None
        return StartSolve(
            pending.solve_id,
            pending.trigger,
            pending.problem,
            pending.warm,
            explain=pending.explain,
        )

    def _status(self, event: str, full: bool = False, **extra: Any) -> Status:
        """A status to publish: ``changed`` since the last one published.

        Verdicts and events carry only the lifecycle entries that changed
        since the previous published status; heartbeats (``full``) carry
        the whole map too. Applying every ``changed`` in order to the last
        full map gives the current map.
        """
        changed = self._dispatches.changed()
        status = self.status(event, **extra)
        return msgspec.structs.replace(
            status,
            activities=status.activities if full else {},
            changed=changed,
        )

    @property
    def pending_goals(self) -> tuple[str, ...]:
        """Goal ids of the solve in flight (empty when none)."""
        return self._pending.goals if self._pending is not None else ()

    @property
    def goals_waiting(self) -> int:
        """Goals accepted for processing and waiting for a solve."""
        return sum(1 for c in self._queue if c.kind == "goal")

    def count_shell(self, **totals: int) -> None:
        """Record the shell's running totals (see ``Counters``)."""
        current = self._counters
        if any(getattr(current, k) != v for k, v in totals.items()):
            self._count(**totals)

    def _live_checked(self, replan: Replan) -> Replan:
        """``replan``, unless it would hold more than ``max_live_tasks``."""
        limit = self.config.max_live_tasks
        live = replan.problem.num_tasks + len(replan.deferred)
        if limit is not None and live > limit:
            raise InputError(
                [
                    FieldIssue(
                        "tasks",
                        f"the plan would hold {live} live tasks; the limit "
                        f"is {limit} (live-tasks)",
                    )
                ],
                "goal",
            )
        return replan

    def _adopt(
        self,
        plan: Plan,
        trigger: str,
        goals: tuple[str, ...],
        removed: tuple[Removal, ...],
        out: list[Command],
    ) -> None:
        schedule = self.schedule
        assert schedule is not None
        # A bounded past: a long mission's state does not grow.
        schedule = self.schedule = schedule.trimmed(PAST_KEPT)
        self.plan_id = (self.plan_id or 0) + 1
        self._dispatches.adopt(
            plan, schedule.continuing, removed, self.config.max_history
        )
        self._plan_message = PlanMessage(
            plan_id=self.plan_id,
            issued_at=self._clock(),
            horizon_start=schedule.problem.start,
            horizon_end=schedule.problem.end,
            status=plan.status,
            objective=plan.objective,
            activities=plan.activities,
            unscheduled=plan.unscheduled,
            why=plan.why,
            continuing=schedule.continuing,
            deferred=tuple(t.id for t in schedule.deferred),
            removed=removed,
            trigger=trigger,
            goals=goals,
            stats=plan.stats,
            term=self.term,
        )
        if plan.status is SolveStatus.DEGRADED:
            self._set_health("degraded", degraded_detail(self.plan_id, plan))
        else:
            self._set_health("ok", "")
        out.append(Publish(topics.PLAN, self._plan_message))
        out.append(
            Log(
                "info",
                f"plan {self.plan_id} ({trigger}, {plan.status.value}): "
                f"{len(plan.activities)} activities, "
                f"{len(plan.unscheduled)} unscheduled",
            )
        )
        for goal_id in goals:
            self._ledger.accept(goal_id)
            self._count(goals_accepted=self._counters.goals_accepted + 1)
            out.append(
                Publish(
                    topics.STATUS,
                    self._status("goal_accepted", goal_id=goal_id),
                )
            )
        out.append(Publish(topics.STATUS, self._status("plan")))

    def _dispatch_due(
        self, out: list[Command], before: int | None = None
    ) -> None:
        """Dispatch what is due; what a clock jump from ``before`` passed
        the start of is missed instead (never commanded out of its time)."""
        schedule = self.schedule
        if schedule is None or self.now is None or self.plan_id is None:
            return
        due, missed = self._dispatches.due(
            schedule.plan, schedule.continuing, self.now, before
        )
        for activity in missed:
            schedule = schedule.with_report(
                ExecutionReport(activity.task, "missed", self.now)
            )
            out.append(
                Publish(
                    topics.STATUS,
                    self._status(
                        "activity_missed",
                        detail=f"{activity.task} [{activity.start}, "
                        f"{activity.end}): the clock jumped over its start "
                        f"(now {self.now}): not commanded, replanned",
                    ),
                )
            )
        if missed:
            self._queue.append(
                QueuedChange("levels", at=self.now, trigger="missed")
            )
        for activity in due:
            late = activity.start < self.now
            self._count(
                dispatches=self._counters.dispatches + 1,
                late_dispatches=self._counters.late_dispatches + late,
            )
            out.append(
                dispatch_message(
                    self.plan_id,
                    schedule.problem,
                    activity,
                    self.now,
                    self.term,
                )
            )
        if due:
            # Commanded means started: a replan at this same unit (here, or
            # on a node that takes over before the first report) must not
            # move it and command it a second time.
            schedule = msgspec.structs.replace(
                schedule,
                continuing=tuple(
                    dict.fromkeys(
                        (*schedule.continuing, *(a.task for a in due))
                    )
                ),
            )
        self.schedule = schedule

    def _check_report_timeouts(self, out: list[Command]) -> None:
        timeout = self.config.report_timeout
        if timeout is None or self.now is None:
            return
        for task, since in self._dispatches.timed_out(self.now, timeout):
            out.append(
                Log(
                    "warning",
                    f"{task}: no report {timeout} units "
                    "after dispatch; counted as failed",
                )
            )
            if self.schedule is not None:
                # Recorded in the schedule too, so that whichever
                # failure is replanned first accounts for all of them.
                self.schedule = self.schedule.with_report(
                    ExecutionReport(task, "failed", since)
                )
            self._queue.append(QueuedChange("failure", task=task, at=since))

    def _alarm_overdue(self, out: list[Command], before: int | None) -> None:
        """Say once, when its planned end comes, that a dispatch got no
        report: an executor that is not there is never silence.

        Said on the step whose time reaches the end, and kept nowhere, so
        that a replay says it on the same step. ``report_timeout`` (off by
        default) then decides whether it counts as failed.
        """
        now = self.now
        if now is None or (before is not None and now <= before):
            return
        for task, (_, end) in sorted(self._dispatches.sent.items()):
            if self._dispatches.lifecycle.get(task) != "dispatched":
                continue
            if (before is None or before < end) and end <= now:
                detail = (
                    f"{task}: dispatched to run until {end}, no report yet "
                    f"(now {now})"
                )
                out.append(Log("warning", detail))
                out.append(
                    Publish(
                        topics.STATUS,
                        self._status("report_overdue", detail=detail),
                    )
                )

    def _reject_goal(
        self,
        goal_id: str | None,
        errors: list[FieldIssue] | tuple[FieldIssue, ...],
        out: list[Command],
        *,
        forget: bool = True,
    ) -> None:
        if forget and goal_id is not None:
            self._ledger.forget(goal_id)  # the id is free again
        self._count(goals_rejected=self._counters.goals_rejected + 1)
        self._report_rejection(
            f"goal {goal_id} rejected",
            errors,
            out,
            event="goal_rejected",
            goal_id=goal_id,
        )

    def _reject_input(
        self,
        key: str,
        kind: str,
        errors: list[FieldIssue] | tuple[FieldIssue, ...],
        out: list[Command],
    ) -> None:
        self._count(inputs_rejected=self._counters.inputs_rejected + 1)
        what = f"{kind} on {key} ignored"
        self._report_rejection(
            what, errors, out, event="input_rejected", detail=what
        )

    def _report_rejection(
        self,
        what: str,
        errors: list[FieldIssue] | tuple[FieldIssue, ...],
        out: list[Command],
        event: str,
        **fields: Any,
    ) -> None:
        """Log a rejection and publish it on the status key."""
        text = "; ".join(str(e) for e in errors)
        out.append(Log("warning", f"{what}: {text}"))
        out.append(
            Publish(
                topics.STATUS,
                self._status(event, errors=tuple(errors), **fields),
            )
        )

    def _set_health(
        self, state: Literal["ok", "degraded", "error"], detail: str
    ) -> None:
        self._health, self._health_detail = state, detail

    def _count(self, **changes: int) -> None:
        self._counters = msgspec.structs.replace(self._counters, **changes)

    def _clock(self) -> int:
        return self.now if self.now is not None else 0


def degraded_detail(plan_id: int | None, plan: Plan) -> str:
    """The alarm text of a degraded plan: each shed task and why."""
    return f"plan {plan_id} is degraded: " + "; ".join(
        f"{b.task} shed ({b.detail})" for b in plan.why if b.cause == "shed"
    )
