"""What the executor says: execution reports checked, held, applied.

A report answers a dispatch of this spacecraft (:meth:`Reports.on_report`
names what is wrong otherwise). One a little ahead of the clock (the
executor saw a tick this node has not processed: two publishers, no order
between them) is held, at most :data:`~.config.HELD_REPORTS`, and applied
at the first step whose time reaches it. ``cancelled`` answers a cancel
(:mod:`.dispatch`); a report on an earlier commander's run of a task
this node commanded blind is taken as the fact it is. Kept apart from
:class:`~fsw_scheduler.engine.core.Engine` so that the rules of what a
report may say sit in one place.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import msgspec

from ..errors import FieldIssue
from ..model.change import ExecutionReport
from . import overrun
from .config import HELD_REPORTS
from .dispatch import dispatch_id, parse_id
from .events import Command, Log
from .snapshot import QueuedChange

#: The trigger of a replan caused by an early completion.
EARLY_COMPLETION = "early_completion"

if TYPE_CHECKING:
    from ..wire.messages import ActivityReport
    from .queue import SolveQueue
    from .state import EngineState
    from .verdicts import Verdicts


class Reports:
    """Check, hold and apply execution reports (see the module docstring).

    Parameters
    ----------
    state
        The engine's state.
    queue
        The solve queue: a failure, a fact or a late answer queues a
        replan.
    verdicts
        Statuses and rejections.
    """

    def __init__(
        self, state: EngineState, queue: SolveQueue, verdicts: Verdicts
    ) -> None:
        self._state = state
        self._queue = queue
        self._verdicts = verdicts

    def release_held(self, out: list[Command]) -> None:
        """Apply each held report the clock has reached, in arrival order.

        At the start of a step, before its event: a deterministic point,
        so that a replay (the held reports are journaled inputs) applies
        them on the same step.
        """
        state = self._state
        if not state.held:
            return
        now = state.clock()
        due = [r for r in state.held if r.at <= now]
        if not due:
            return
        state.held = [r for r in state.held if r.at > now]
        for report in due:
            self.on_report(report, out)

    def _hold(self, report: ActivityReport, out: list[Command]) -> bool:
        """Hold ``report`` if its ``at`` is ahead of the clock but within
        ``report_ahead`` (and fewer than :data:`HELD_REPORTS` wait)."""
        state = self._state
        ahead = report.at - state.clock()
        if (
            ahead <= 0
            or ahead > self._state.config.report_ahead
            or len(state.held) >= HELD_REPORTS
        ):
            return False
        state.held.append(report)
        out.append(
            Log(
                "info",
                f"{report.task} {report.state} at {report.at}: held until "
                f"the clock reaches it (now {state.clock()})",
            )
        )
        return True

    def on_report(self, report: ActivityReport, out: list[Command]) -> None:
        if report.at > self._state.clock() and self._hold(report, out):
            return
        if (
            report.state == "cancelled"
            and report.task not in self._state.dispatches.cancelling
        ):
            # The answer to a cancel already settled (a new commander
            # asked again): nothing waits for it.
            out.append(
                Log("info", f"{report.task}: cancelled again, already settled")
            )
            return
        schedule = self._state.schedule
        dispatches = self._state.dispatches
        if (
            schedule is not None
            and report.task not in {t.id for t in schedule.problem.tasks}
            and report.task in {t.id for t in schedule.catalog}
            and report.task not in dispatches.cancelling
        ):
            # A late report on a task that already left the problem (for
            # instance finished by the plan's prediction): note it only.
            dispatches.note(report.task, report.state)
            return
        if (
            schedule is None
            or report.task not in {t.id for t in schedule.problem.tasks}
        ) and report.task not in dispatches.cancelling:
            self._verdicts.reject_input(
                f"telemetry/activities/{report.task}",
                "activity_report",
                [FieldIssue("task", f"no live task {report.task!r}")],
                out,
            )
            return
        if self._earlier_command(report, out):
            return
        wrong = self._report_issue(report)
        if wrong is not None:
            self._verdicts.reject_input(
                f"telemetry/activities/{report.task}",
                "activity_report",
                [wrong],
                out,
            )
            if wrong.path == "term":
                # The executor acts on a higher term's dispatches: it
                # fences this node's. Never report ok meanwhile.
                detail = (
                    f"an executor follows term {report.term}, above this "
                    f"node's term {self._state.term}: it ignores this "
                    "node's dispatches"
                )
                self._state.set_health("degraded", detail)
                out.append(Log("error", detail))
                out.append(self._verdicts.publish("alarm", detail=detail))
            return
        assert schedule is not None
        self._state.count(reports=self._state.counters.reports + 1)
        at = min(report.at, self._state.clock())
        if self._state.config.cancel_timeout is not None:
            # A report from before the problem's start (a slow executor)
            # still counts: the rules read reports from the start on, and
            # a completion they missed would be planned, and not flown,
            # again and again.
            at = max(at, schedule.problem.start)
        detail = f"{report.task} {report.state} at {report.at}"
        if report.state == "cancelled":
            self._on_cancelled(report.task)
            out.append(self._verdicts.publish("activity", detail=detail))
            return
        cancelled = report.task in dispatches.cancelling
        # Read before the report settles the dispatch (which forgets it).
        sent = dispatches.sent.get(report.task)
        dispatches.report(report.task, report.state)
        out.append(self._verdicts.publish("activity", detail=detail))
        if cancelled and report.state == "running":
            return  # it runs until the cancel reaches it: nothing new
        if cancelled:
            # The ``missed`` record of the cancel is overtaken by the fact.
            schedule = msgspec.structs.replace(
                schedule,
                reports=tuple(
                    r
                    for r in schedule.reports
                    if r.task != report.task or r.state != "missed"
                ),
            )
        self._state.schedule = schedule.with_report(
            ExecutionReport(report.task, report.state, at)
        )
        if cancelled and report.state != "failed":
            # It ended before the cancel reached it: what it did is a
            # fact; the plan that moved it is replanned from it.
            self._queue.add(QueuedChange("levels", at=at, trigger="cancelled"))
        if report.state == "failed":
            self._queue.add(QueuedChange("failure", task=report.task, at=at))
        elif (
            report.state == "completed" and sent is not None and not cancelled
        ):
            self._early_completion(report, sent[1], out)
            self._late_completion(report.task, at, sent[1], out)

    def _early_completion(
        self, report: ActivityReport, end: int, out: list[Command]
    ) -> None:
        """Replan when ``report`` frees at least ``early_completion_gain``
        units of its dispatch ``[.., end)``: what follows it or waits for
        its resources may start earlier (Mars 2020's flexible execution).
        A smaller gain replans nothing: the plan in force stays, and its
        successors keep their starts."""
        gain = self._state.config.early_completion_gain
        freed = end - report.at
        if gain <= 0 or freed < gain:
            return
        out.append(
            Log(
                "info",
                f"{report.task} completed at {report.at}, {freed} units "
                f"before the end of its dispatch ({end}): replanning",
            )
        )
        self._queue.add_once(
            QueuedChange(
                "levels", at=self._state.clock(), trigger=EARLY_COMPLETION
            )
        )

    def _late_completion(
        self, task: str, at: int, end: int, out: list[Command]
    ) -> None:
        """Replan when ``task``, completed at ``at`` after the end of its
        dispatch (``end``), broke or stretched the plan in force
        (:func:`~.overrun.depends_on`): what depends on it moves."""
        state = self._state
        if not overrun.pushing(state) or at <= end:
            return
        schedule = state.schedule
        assert schedule is not None
        why = overrun.depends_on(
            schedule, state.dispatches.lifecycle, task, at
        )
        if why is None:
            return
        out.append(
            Log(
                "info",
                f"{task} completed at {at}, {at - end} "
                f"unit{'s' if at - end > 1 else ''} after the end of its "
                f"dispatch ({end}); {why}: replanning",
            )
        )
        self._queue.add_once(
            QueuedChange(
                "levels", at=state.clock(), trigger=overrun.LATE_COMPLETION
            )
        )

    def _earlier_command(
        self, report: ActivityReport, out: list[Command]
    ) -> bool:
        """Take ``report`` as a fact if it answers another commander's
        dispatch of its task: a lower term, a ``dispatch_id`` this node did
        not send, while this node has no word on a command of its own.

        A commander that took over from an older state may command, blind,
        an activity its predecessor commanded last; the executor does not
        run it again but reports the earlier run (README, "Receiving
        dispatches"). That run is what happened: this node's own command
        of the task is void, and the plan is made again from the fact.
        """
        if (
            self._state.config.cancel_timeout is None
            or report.term >= self._state.term
        ):
            return False
        task = report.task
        parsed = parse_id(report.dispatch_id)
        if parsed is None or parsed[0] != task:
            return False
        _, span, number = parsed
        dispatches = self._state.dispatches
        ours = dispatches.id_of(task) == report.dispatch_id
        if ours or dispatches.lifecycle.get(task, "planned") not in (
            "planned",
            "dispatched",
            "missed",
        ):
            return False
        schedule = self._state.schedule
        if schedule is None or report.state == "cancelled":
            return False
        dispatches.dispatched.pop(task, None)
        dispatches.sent[task] = span
        dispatches.numbers[task] = number
        dispatches.report(task, report.state)
        at = min(max(report.at, schedule.problem.start), self._state.clock())
        self._state.schedule = schedule.with_report(
            ExecutionReport(task, report.state, at)
        )
        self._state.count(reports=self._state.counters.reports + 1)
        detail = (
            f"{task} {report.state} at {report.at} under "
            f"{report.dispatch_id} (term {report.term}): commanded before "
            "this node's term; taken as a fact"
        )
        out.append(Log("warning", detail))
        out.append(self._verdicts.publish("activity", detail=detail))
        if report.state == "failed":
            self._queue.add(QueuedChange("failure", task=task, at=at))
        else:
            self._queue.add(QueuedChange("levels", at=at, trigger="merged"))
        return True

    def _on_cancelled(self, task: str) -> None:
        """A cancel answered: the activity stopped (or never started).

        It may now be commanded again where the plan puts it, if that
        place is still to come; otherwise it is replanned (``missed``).
        """
        state = self._state
        dispatches = state.dispatches
        schedule = state.schedule
        assert schedule is not None
        dispatches.cancelling.pop(task, None)
        dispatches.dispatched.pop(task, None)
        dispatches.sent.pop(task, None)
        placed = schedule.plan.activity(task)
        if placed is None or task in schedule.continuing:
            dispatches.note(
                task, "obsolete" if task in schedule.obsolete else "preempted"
            )
            return
        if placed.start >= state.clock():
            dispatches.note(task, "planned")
            return
        dispatches.note(task, "missed")
        state.schedule = schedule.with_report(
            ExecutionReport(task, "missed", state.clock())
        )
        self._queue.add(
            QueuedChange("levels", at=state.clock(), trigger="missed")
        )

    def _report_issue(self, report: ActivityReport) -> FieldIssue | None:
        """Why ``report`` answers no dispatch of this spacecraft (None: it
        does): its task was never dispatched, it names another dispatch,
        a later term or a time to come."""
        task = report.task
        if self._state.dispatches.lifecycle.get(task, "planned") == "planned":
            return FieldIssue(
                "task", f"{task!r} was never dispatched: nothing to report on"
            )
        if report.at > self._state.clock():
            return FieldIssue(
                "at",
                f"{report.at} is after now ({self._state.clock()}) by more "
                f"than report-ahead ({self._state.config.report_ahead})"
                if len(self._state.held) < HELD_REPORTS
                else f"{report.at} is after now ({self._state.clock()}) and "
                f"{HELD_REPORTS} reports are held already",
            )

        if report.term > self._state.term:
            return FieldIssue(
                "term",
                f"{report.term} is above this node's term {self._state.term}",
            )
        if not report.dispatch_id:
            if self._state.config.reports_need_dispatch:
                return FieldIssue(
                    "dispatch_id", "missing: name the dispatch this answers"
                )
            return None
        # The dispatch as it was sent: a replan re-bases a running
        # activity to start now, but its dispatch keeps its id.
        sent = self._state.dispatches.sent.get(task)
        schedule = self._state.schedule
        current = schedule.plan.activity(task) if schedule else None
        if sent is not None:
            expected = self._state.dispatches.id_of(task)
        else:
            expected = (
                dispatch_id(current, self._state.dispatches.number(task))
                if current is not None
                else None
            )
        if expected is not None and report.dispatch_id != expected:
            return FieldIssue(
                "dispatch_id",
                f"{report.dispatch_id!r} is not the dispatch of {task!r} "
                f"({expected!r})",
            )
        return None
