"""Flying a plan: adopting it, and commanding each activity when it is due.

:class:`Execution` is where a solved plan becomes the plan flown (a new
``plan_id``, the plan message, the goals it carries accepted) and where
time turns planned activities into dispatches: what is due is commanded,
what a clock jump passed is missed (never commanded out of its time), a
dispatch that gets no report is said once at its planned end and, with
``report_timeout``, counted as failed. The lifecycle of each activity is
kept by :class:`~fsw_scheduler.engine.dispatch.Dispatches`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import msgspec

from ..model.change import ExecutionReport
from ..model.plan import Plan, SolveStatus
from ..replan.commit import PIN_CAUSE
from ..wire import topics
from ..wire.messages import PlanMessage
from .dispatch import dispatch_message
from .events import Command, Log, Publish
from .snapshot import QueuedChange

if TYPE_CHECKING:
    from ..model.change import Removal
    from ..model.plan import Moved
    from .queue import SolveQueue
    from .state import EngineState
    from .verdicts import Verdicts


#: Finished tasks (and their executions, and obsolete ids) a schedule
#: keeps beyond what its live tasks need: late reports on them are noted,
#: and the snapshot shared with a standby stays bounded.
PAST_KEPT = 256


class Execution:
    """Adopt plans and command what is due (see the module docstring).

    Parameters
    ----------
    state
        The engine's state.
    queue
        The solve queue: a missed activity or a timed-out dispatch queues
        a replan.
    verdicts
        Statuses.
    """

    def __init__(
        self, state: EngineState, queue: SolveQueue, verdicts: Verdicts
    ) -> None:
        self._state = state
        self._queue = queue
        self._verdicts = verdicts

    def adopt(
        self,
        plan: Plan,
        trigger: str,
        goals: tuple[str, ...],
        removed: tuple[Removal, ...],
        out: list[Command],
        *,
        moved: tuple[Moved, ...] | msgspec.UnsetType = msgspec.UNSET,
    ) -> None:
        """Make ``plan`` (already in ``state.schedule``) the plan flown.

        Gives it the next ``plan_id``, publishes it (with what it
        ``moved``, where plans report it), and accepts the goals it
        carries.
        """
        state = self._state
        schedule = state.schedule
        assert schedule is not None
        # A bounded past: a long mission's state does not grow.
        schedule = state.schedule = schedule.trimmed(PAST_KEPT)
        state.plan_id = (state.plan_id or 0) + 1
        state.dispatches.adopt(
            plan, schedule.continuing, removed, state.config.max_history
        )
        state.plan_message = PlanMessage(
            plan_id=state.plan_id,
            issued_at=state.clock(),
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
            term=state.term,
            moved=moved,
        )
        if plan.status is SolveStatus.DEGRADED:
            state.set_health("degraded", degraded_detail(state.plan_id, plan))
        else:
            state.set_health("ok", "")
        out.append(Publish(topics.PLAN, state.plan_message))
        out.append(
            Log(
                "info",
                f"plan {state.plan_id} ({trigger}, {plan.status.value}): "
                f"{len(plan.activities)} activities, "
                f"{len(plan.unscheduled)} unscheduled",
            )
        )
        for goal_id in goals:
            state.ledger.accept(goal_id)
            state.count(goals_accepted=state.counters.goals_accepted + 1)
            out.append(
                self._verdicts.publish("goal_accepted", goal_id=goal_id)
            )
        out.append(self._verdicts.publish("plan"))

    def dispatch_due(
        self, out: list[Command], before: int | None = None
    ) -> None:
        """Dispatch what is due; what a clock jump from ``before`` passed
        the start of is missed instead (never commanded out of its time)."""
        state = self._state
        schedule = state.schedule
        if schedule is None or state.now is None or state.plan_id is None:
            return
        due, missed = state.dispatches.due(
            schedule.plan, schedule.continuing, state.now, before
        )
        for activity in missed:
            schedule = schedule.with_report(
                ExecutionReport(activity.task, "missed", state.now)
            )
            out.append(
                self._verdicts.publish(
                    "activity_missed",
                    detail=f"{activity.task} [{activity.start}, "
                    f"{activity.end}): the clock jumped over its start "
                    f"(now {state.now}): not commanded, replanned",
                )
            )
        if missed:
            self._queue.add(
                QueuedChange("levels", at=state.now, trigger="missed")
            )
        for activity in due:
            late = activity.start < state.now
            state.count(
                dispatches=state.counters.dispatches + 1,
                late_dispatches=state.counters.late_dispatches + late,
            )
            out.append(
                dispatch_message(
                    state.plan_id,
                    schedule.problem,
                    activity,
                    state.now,
                    state.term,
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
        state.schedule = schedule

    def check_report_timeouts(self, out: list[Command]) -> None:
        """Count as failed each dispatch with no report in
        ``report_timeout`` units, and queue its failure replan."""
        state = self._state
        timeout = state.config.report_timeout
        if timeout is None or state.now is None:
            return
        for task, since in state.dispatches.timed_out(state.now, timeout):
            out.append(
                Log(
                    "warning",
                    f"{task}: no report {timeout} units "
                    "after dispatch; counted as failed",
                )
            )
            if state.schedule is not None:
                # Recorded in the schedule too, so that whichever
                # failure is replanned first accounts for all of them.
                state.schedule = state.schedule.with_report(
                    ExecutionReport(task, "failed", since)
                )
            self._queue.add(QueuedChange("failure", task=task, at=since))

    def alarm_overdue(self, out: list[Command], before: int | None) -> None:
        """Say once, when its planned end comes, that a dispatch got no
        report: an executor that is not there is never silence.

        Said on the step whose time reaches the end, and kept nowhere, so
        that a replay says it on the same step. ``report_timeout`` (off by
        default) then decides whether it counts as failed.
        """
        state = self._state
        now = state.now
        if now is None or (before is not None and now <= before):
            return
        dispatches = state.dispatches
        for task, (_, end) in sorted(dispatches.sent.items()):
            if dispatches.lifecycle.get(task) != "dispatched":
                continue
            if (before is None or before < end) and end <= now:
                detail = (
                    f"{task}: dispatched to run until {end}, no report yet "
                    f"(now {now})"
                )
                out.append(Log("warning", detail))
                out.append(
                    self._verdicts.publish("report_overdue", detail=detail)
                )


def degraded_detail(plan_id: int | None, plan: Plan) -> str:
    """The alarm text of a degraded plan: each shed task and each pin of
    the commit window it broke, and why."""
    return f"plan {plan_id} is degraded: " + "; ".join(
        [f"{b.task} shed ({b.detail})" for b in plan.why if b.cause == "shed"]
        + [
            f"{b.task} pin broken ({b.detail})"
            for b in plan.why
            if b.cause == PIN_CAUSE
        ]
    )
