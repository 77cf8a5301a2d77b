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
from ..wire.messages import Dispatch, PlanMessage
from . import overrun
from .dispatch import dispatch_message, span_id
from .events import Command, Log, Publish
from .snapshot import QueuedChange

if TYPE_CHECKING:
    from ..model.change import Removal
    from ..model.plan import Moved
    from ..replan.schedule import Schedule
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
        readded: tuple[str, ...] = (),
        *,
        moved: tuple[Moved, ...] | msgspec.UnsetType = msgspec.UNSET,
    ) -> None:
        """Make ``plan`` (already in ``state.schedule``) the plan flown.

        Gives it the next ``plan_id``, publishes it (with what it
        ``moved``, where plans report it), and accepts the goals it
        carries. ``readded``: completed tasks the rules brought back to
        run again (a tight chain).
        """
        state = self._state
        schedule = state.schedule
        assert schedule is not None
        # A bounded past: a long mission's state does not grow.
        schedule = state.schedule = schedule.trimmed(PAST_KEPT)
        state.plan_id = (state.plan_id or 0) + 1
        cancels = state.dispatches.adopt(
            plan,
            schedule.continuing,
            removed,
            state.config.max_history,
            None if state.config.cancel_timeout is None else state.clock(),
            readded,
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
            chosen=plan.chosen,
            moved=moved,
        )
        if plan.status is SolveStatus.DEGRADED:
            state.set_health("degraded", degraded_detail(state.plan_id, plan))
        elif not state.clock_stalled:
            # A stalled clock stays said until it ticks again (and then
            # ``clock_resumed``): a plan is no news about the clock.
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
        self._cancel(cancels, out)
        lifecycle = state.dispatches.lifecycle
        if state.config.cancel_timeout is not None and any(
            lifecycle.get(a.task) in ("completed", "unknown")
            and a.task not in schedule.continuing
            and a.task not in readded
            for a in plan.activities
        ):
            # The plan was computed before what ran was known: it holds
            # an activity that will not be flown; plan from the facts.
            self._queue.add(
                QueuedChange("levels", at=state.clock(), trigger="stale")
            )

    def _cancel(
        self, cancels: list[tuple[str, tuple[int, int]]], out: list[Command]
    ) -> None:
        """Send the cancel of each dispatch the new plan took away.

        Until its answer the activity has not run for the plan: a
        ``missed`` record at now makes a replan meanwhile plan it again,
        instead of taking it as running or finished where it was.
        """
        state = self._state
        schedule = state.schedule
        if not cancels or schedule is None or state.plan_id is None:
            return
        for task, span in cancels:
            schedule = schedule.with_report(
                ExecutionReport(task, "missed", state.clock())
            )
            out.append(
                Log(
                    "info",
                    f"{task}: cancel of {state.dispatches.id_of(task)} sent; "
                    "not commanded again before the executor answers",
                )
            )
            out.append(self.cancel_message(task, span, state.clock()))
        state.schedule = schedule

    def cancel_message(
        self, task: str, span: tuple[int, int], at: int
    ) -> Publish:
        """The cancel, sent at ``at``, of the dispatch of ``task`` for
        ``span`` (the same ``dispatch_id``, ``action: cancel``)."""
        state = self._state
        schedule = state.schedule
        assert schedule is not None and state.plan_id is not None
        known = {t.id: t for t in (*schedule.catalog, *schedule.problem.tasks)}
        uses = known[task].uses if task in known else {}
        return Publish(
            f"{topics.DISPATCH}/{task}",
            Dispatch(
                task=task,
                plan_id=state.plan_id,
                start=span[0],
                end=span[1],
                uses=dict(sorted(uses.items())),
                dispatched_at=at,
                dispatch_id=span_id(task, span, state.dispatches.number(task)),
                term=state.term,
                action="cancel",
            ),
        )

    def check_cancels(self, out: list[Command]) -> None:
        """Turn ``unknown`` each activity whose cancel got no answer in
        ``cancel_timeout`` units: taken as having run where it was
        commanded, never commanded again, and replanned around."""
        state = self._state
        timeout = state.config.cancel_timeout
        if timeout is None or state.now is None:
            return
        late = state.dispatches.cancel_overdue(state.now, timeout)
        for task in late:
            detail = (
                f"{task}: no answer to its cancel in {timeout} units; its "
                "outcome is unknown: taken as run, never commanded again"
            )
            out.append(Log("warning", detail))
            out.append(
                self._verdicts.publish("activity_unknown", detail=detail)
            )
            if state.schedule is not None:
                state.schedule = state.schedule.with_report(
                    ExecutionReport(task, "completed", state.now)
                )
        if late:
            self._queue.add(
                QueuedChange("levels", at=state.now, trigger="cancelled")
            )

    def dispatch_due(
        self, out: list[Command], before: int | None = None
    ) -> None:
        """Dispatch what is due; what a clock jump from ``before`` passed
        the start of is missed instead (never commanded out of its time)."""
        state = self._state
        schedule = state.schedule
        if schedule is None or state.now is None or state.plan_id is None:
            return
        held = overrun.held(state, self._queue)
        due, missed = state.dispatches.due(
            schedule.plan, schedule.continuing, state.now, before, held
        )
        if held:
            # It recorded what was held: carry on from its schedule.
            schedule = self._hold(held, before, out)
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
                    number=state.dispatches.number(activity.task),
                )
            )
        if due:
            # Commanded means started: a replan at this same unit (here, or
            # on a node that takes over before the first report) must not
            # move it and command it a second time. A ``missed`` record of
            # a cancel answered is history now.
            commanded = {a.task for a in due}
            schedule = msgspec.structs.replace(
                schedule,
                continuing=tuple(
                    dict.fromkeys(
                        (*schedule.continuing, *(a.task for a in due))
                    )
                ),
                reports=tuple(
                    r
                    for r in schedule.reports
                    if r.task not in commanded or r.state != "missed"
                ),
            )
        state.schedule = schedule

    def _hold(
        self, held: dict[str, str], before: int | None, out: list[Command]
    ) -> Schedule:
        """Say, at its start, why each held activity waits; replan once
        (trigger ``overrun``) when a held activity's start has passed.

        A held activity has not started: a ``missed`` record tells a
        replan meanwhile so (the rules take a planned activity whose
        start came as running); it goes when the activity is commanded.
        """
        state = self._state
        schedule, now = state.schedule, state.now
        assert schedule is not None and now is not None
        passed = []
        noted = {r.task for r in schedule.reports if r.state == "missed"}
        for task, why in held.items():
            placed = schedule.plan.activity(task)
            assert placed is not None
            if task not in noted:
                schedule = schedule.with_report(
                    ExecutionReport(task, "missed", now)
                )
            detail = f"{task} [{placed.start}, {placed.end}) held: {why}"
            if before is None or before < placed.start:
                # A completion racing the clock releases it in this
                # unit, as it does at most activity ends: a debug line.
                out.append(Log("debug", detail))
            if placed.start < now:
                passed.append(task)
                if before is None or before <= placed.start:
                    out.append(
                        self._verdicts.publish("activity_held", detail=detail)
                    )
        state.schedule = schedule
        if passed and not overrun.replan_under_way(self._queue):
            out.append(
                Log(
                    "warning",
                    f"{', '.join(passed)}: held past the start; replanning "
                    "what waits on a late activity",
                )
            )
            self._queue.add(
                QueuedChange("levels", at=now, trigger=overrun.OVERRUN)
            )
        return schedule

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
