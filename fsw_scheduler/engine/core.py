"""The scheduler's functional core: events in, commands out.

:class:`Engine` holds every piece of the scheduler's state and changes it
only in :meth:`Engine.step`, which takes one event and the current time
unit and returns the commands for the shell to carry out: publish a
message, start a solve, log a line. It never solves, publishes, decodes or
reads a clock, so the same sequence of events always gives the same
commands; the bus node (:mod:`fsw_scheduler.bus.node`) and deterministic
replay (:mod:`fsw_scheduler.journal.replay`) both drive it.

The lifecycle of an activity is ``planned -> dispatched -> running ->
completed | failed``, or ``preempted`` / ``obsolete`` when a replan takes
it away. Replans are triggered by a goal, a failure report, a dispatch
with no report within ``report_timeout`` units (a failure), or a measured
consumable level departing from the plan's prediction. One solve runs at a
time: goals arriving meanwhile get ``goal_queued`` and are merged into the
next solve (at most ``max_goals_per_solve`` at once; beyond
``max_goals_waiting`` a goal is rejected ``busy``), other triggers are
queued. A solve that yields no plan leaves the current plan in place and
the status says why. Published statuses carry the lifecycle entries that
``changed`` since the previous one; heartbeats and queries the whole map.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import msgspec

from ..errors import FieldIssue, InputError
from ..model.change import ExecutionReport
from ..replan.schedule import Schedule, empty_plan
from ..replan.triggers import (
    apply_goal,
    drift,
)
from ..wire import topics
from .dispatch import Dispatches, dispatch_id, dispatch_message
from .events import (
    ClockStalled,
    Command,
    Event,
    Explained,
    GoalArrived,
    InputRejected,
    LevelArrived,
    Log,
    Publish,
    ReportArrived,
    SolveDone,
    SolveFailed,
    TermBegan,
    Tick,
)
from .ledger import GoalLedger, goal_digest
from .snapshot import EngineSnapshot, GoalRecord, QueuedChange
from .solves import SolveQueue

if TYPE_CHECKING:
    from ..model.goal import Goal
    from ..wire.messages import (
        ActivityReport,
        ResourceLevel,
    )
    from .config import EngineConfig


class Engine(SolveQueue):
    """The scheduler's state machine.

    Parameters
    ----------
    config
        Engine settings.
    initial
        The initial problem: its resources and horizon length, and any
        initial tasks. Solved at the first tick (re-based to start at that
        tick if the clock is already past its start).
    """

    # -- read-only views (for queryables) ---------------------------------

    # -- snapshots (resume, hot standby) ------------------------------------

    def snapshot(self) -> EngineSnapshot:
        """The whole state, as data (see
        :mod:`fsw_scheduler.engine.snapshot`)."""
        return EngineSnapshot(
            initial=self.initial,
            unsolved_initial=self._unsolved_initial,
            schedule=self.schedule,
            plan_id=self.plan_id,
            now=self.now,
            solve_id=self._solve_id,
            pending=self._pending,
            queue=tuple(self._queue),
            dispatched=dict(self._dispatches.dispatched),
            lifecycle=dict(self._dispatches.lifecycle),
            reported=dict(self._dispatches.reported),
            sent=dict(self._dispatches.sent),
            counters=self._counters,
            last_solve=self._last_solve,
            inputs=self._inputs,
            health=self._health,
            health_detail=self._health_detail,
            plan_message=self._plan_message,
            term=self.term,
            ledger=dict(self._ledger.records),
        )

    @classmethod
    def restore(cls, config: EngineConfig, snapshot: EngineSnapshot) -> Engine:
        """An engine in the state ``snapshot`` was taken in.

        Parameters
        ----------
        config
            Engine settings (not part of the state: a restarted node may
            be given new ones).
        snapshot
            From :meth:`snapshot`.
        """
        engine = cls(config, snapshot.initial)
        engine._unsolved_initial = snapshot.unsolved_initial
        engine.schedule = snapshot.schedule
        engine.plan_id = snapshot.plan_id
        engine.now = snapshot.now
        engine._solve_id = snapshot.solve_id
        engine._pending = snapshot.pending
        engine._queue = list(snapshot.queue)
        engine._dispatches = Dispatches(
            lifecycle=snapshot.lifecycle,
            dispatched=snapshot.dispatched,
            sent=snapshot.sent,
            reported=snapshot.reported,
        )
        engine._counters = snapshot.counters
        engine._last_solve = snapshot.last_solve
        engine._inputs = snapshot.inputs
        engine._health = snapshot.health
        engine._health_detail = snapshot.health_detail
        engine._plan_message = snapshot.plan_message
        engine.term = snapshot.term
        engine._ledger = GoalLedger(snapshot.ledger, config.max_goal_ids)
        return engine

    def resume_commands(self, event: str = "resumed") -> list[Command]:
        """What a rebuilt engine says first: the status, then its outputs.

        A node saves its state before its outputs reach the bus, so when
        it died in between, the plan and dispatches of its last step were
        never seen. They are published again: the current plan (same
        ``plan_id``) and every dispatch still waiting for its first
        report, with its ``dispatch_id``, so that a receiver that has it
        already drops it.
        """
        out: list[Command] = [self.resumed(event)]
        schedule = self.schedule
        if self._plan_message is not None:
            out.append(Publish(topics.PLAN, self._plan_message))
        if schedule is None or self.plan_id is None:
            return out
        for activity, since in self._dispatches.standing(schedule.plan):
            out.append(
                dispatch_message(
                    self.plan_id, schedule.problem, activity, since, self.term
                )
            )
        return out

    def resumed(self, event: str = "resumed", **extra: object) -> Command:
        """The status saying this engine was rebuilt and goes on."""
        detail = (
            f"state rebuilt at t={self.now}: plan {self.plan_id}, "
            f"{len(self._dispatches.lifecycle)} activities known"
            + (", a solve in flight asked again" if self.busy else "")
        )
        return Publish(
            topics.STATUS,
            self._status(
                event,
                full=True,
                detail=detail,
                from_plan_id=self.plan_id,
                at=self.now,
                **extra,
            ),
        )

    # -- the step ------------------------------------------------------------

    def step(self, event: Event, now: int) -> list[Command]:
        """Process one event at time unit ``now``.

        Parameters
        ----------
        event
            What happened.
        now
            The current time unit (never earlier than in a previous step;
            an earlier value is treated as the latest one).

        Returns
        -------
        list of Command
            What the shell must do, in order.
        """
        self._inputs += 1
        before = self.now
        if self.now is None or now > self.now:
            self.now = now
        out: list[Command] = []
        if isinstance(event, Tick):
            self._on_tick(out)
        elif isinstance(event, GoalArrived):
            self._on_goal(event.goal, out)
        elif isinstance(event, ReportArrived):
            self._on_report(event.report, out)
        elif isinstance(event, LevelArrived):
            self._on_level(event.level, out)
        elif isinstance(event, InputRejected):
            self._on_rejected(event, out)
        elif isinstance(event, ClockStalled):
            self._on_stalled(event, out)
        elif isinstance(event, Explained):
            self._on_explained(event, out)
        elif isinstance(event, TermBegan):
            self._on_term(event, out)
        elif isinstance(event, SolveDone):
            self._on_solve_done(event, out)
        elif isinstance(event, SolveFailed):
            self._on_solve_failed(event, out)
        # Dispatch first: a replan started in this step then counts what
        # was just commanded as started, never moves it, never sends it
        # twice.
        self._dispatch_due(out, before)
        self._alarm_overdue(out, before)
        if self._pending is None:
            self._start_queued(out)
        return out

    # -- event handlers ------------------------------------------------------

    def _on_term(self, event: TermBegan, out: list[Command]) -> None:
        if event.term == self.term:
            return  # already in this term (a journal replayed from its head)
        if event.term < self.term:
            # The shell picks a higher term; a lower one would unfence a
            # stale commander, so it is never taken.
            out.append(
                Log(
                    "error",
                    f"term {event.term} is below term {self.term}: ignored",
                )
            )
            return
        self.term = event.term
        out.append(
            Log(
                "info",
                f"term {event.term} begins ({event.reason or 'command'}"
                f"{', node ' + event.node_id if event.node_id else ''})",
            )
        )

    def _on_explained(self, event: Explained, out: list[Command]) -> None:
        message = self._plan_message
        if message is None or message.plan_id != event.plan_id:
            return  # a newer plan is out; its own explanation follows
        self._plan_message = msgspec.structs.replace(message, why=event.why)
        out.append(
            Publish(
                topics.STATUS,
                self._status(
                    "explained",
                    why=event.why,
                    detail=f"plan {event.plan_id}: why "
                    f"{len(event.why)} tasks are out",
                ),
            )
        )

    def _on_stalled(self, event: ClockStalled, out: list[Command]) -> None:
        detail = (
            f"{_STALLED}: no clock message for {event.seconds:g} s "
            f"since unit {event.last}"
        )
        self._set_health("degraded", detail)
        out.append(Log("warning", detail))
        out.append(Publish(topics.STATUS, self._status("clock_stalled")))

    def _on_tick(self, out: list[Command]) -> None:
        if self._health_detail.startswith(_STALLED):
            self._set_health("ok", "")
            out.append(Publish(topics.STATUS, self._status("clock_resumed")))
        if self._unsolved_initial is not None and self._pending is None:
            self._start_initial(out)
        self._check_report_timeouts(out)
        if self._deferred_due() and not any(
            c.trigger == "horizon" for c in self._queue
        ):
            self._queue.append(
                QueuedChange("levels", at=self._clock(), trigger="horizon")
            )
        beat = self.config.heartbeat
        if beat and self.now is not None and self.now % beat == 0:
            out.append(
                Publish(topics.STATUS, self._status("heartbeat", full=True))
            )

    def _deferred_due(self) -> bool:
        """True when the rolling horizon now reaches a deferred task."""
        schedule = self.schedule
        if schedule is None or not schedule.deferred or self.now is None:
            return False
        frame = schedule.problem.replace(
            start=self.now + self.config.replan_lead
        )
        for task in schedule.deferred:
            earliest, latest = frame.start_bounds(task)
            if earliest <= latest:
                return True
        return False

    def _start_initial(self, out: list[Command]) -> None:
        problem = self._unsolved_initial
        assert problem is not None and self.now is not None
        self._unsolved_initial = None
        if self.now > problem.start:
            problem = problem.replace(start=self.now)
        if not problem.tasks:
            self.schedule = Schedule.begin(problem, empty_plan())
            self._adopt(empty_plan(), "initial", (), (), out)
            return
        self._start_solve("initial", problem, None, None, (), out)

    def _on_goal(self, goal: Goal, out: list[Command]) -> None:
        digest = goal_digest(goal)
        record = self._ledger.seen(goal.goal_id)
        if record is not None:
            self._answer_repeat(goal.goal_id, digest, record, out)
            return
        if goal.not_after is not None and self._clock() > goal.not_after:
            self._reject_goal(
                goal.goal_id,
                [
                    FieldIssue(
                        "not_after",
                        f"the goal expired at t={goal.not_after}; now is "
                        f"t={self._clock()}",
                    )
                ],
                out,
            )
            return
        if self.schedule is None and self._pending is None:
            self._reject_goal(
                goal.goal_id,
                [FieldIssue("", "no plan yet: the scheduler has not started")],
                out,
            )
            return
        config = self.config
        limit = config.max_tasks_per_goal
        if limit is not None and len(goal.tasks) > limit:
            self._reject_goal(
                goal.goal_id,
                [
                    FieldIssue(
                        "tasks",
                        f"{len(goal.tasks)} tasks; the limit is {limit} "
                        "per goal (tasks-per-goal)",
                    )
                ],
                out,
            )
            return
        waiting = self.goals_waiting
        if (
            config.max_goals_waiting is not None
            and waiting >= config.max_goals_waiting
        ):
            self._reject_goal(
                goal.goal_id,
                [FieldIssue("", f"busy: {waiting} goals waiting")],
                out,
            )
            return
        # Validate against the live state now so a bad goal is rejected at
        # once, even when it has to wait for a solve in flight.
        if self.schedule is not None:
            now = self._clock()
            try:
                replan = self._live_checked(
                    apply_goal(self.schedule, goal, now)
                )
            except InputError as error:
                self._reject_goal(goal.goal_id, error.issues, out)
                return
            self._goal_checked = (self.schedule, now, goal, replan)
        self._queue.append(QueuedChange("goal", goal=goal))
        self._ledger.queue(goal.goal_id, digest, self._clock(), self.term)
        if self._pending is not None:
            out.append(
                Log("info", f"goal {goal.goal_id} queued behind a solve")
            )
            out.append(
                Publish(
                    topics.STATUS,
                    self._status(
                        "goal_queued",
                        goal_id=goal.goal_id,
                        detail=f"waiting behind solve "
                        f"{self._pending.solve_id} "
                        f"({self._pending.trigger}); "
                        f"{waiting + 1} goals waiting",
                    ),
                )
            )

    def _answer_repeat(
        self, goal_id: str, digest: str, record: GoalRecord, out: list[Command]
    ) -> None:
        """A goal id already in the ledger: its verdict again, or no."""
        if record.digest != digest:
            self._reject_goal(
                goal_id,
                [
                    FieldIssue(
                        "goal_id",
                        f"goal id {goal_id!r} is taken by another goal "
                        f"({record.verdict} at t={record.at}); send new "
                        "content under a new id",
                    )
                ],
                out,
                forget=False,
            )
            return
        event = (
            "goal_accepted" if record.verdict == "accepted" else "goal_queued"
        )
        out.append(
            Publish(
                topics.STATUS,
                self._status(
                    event,
                    goal_id=goal_id,
                    detail=f"goal {goal_id} again, the same as at "
                    f"t={record.at}: its verdict stands, nothing changes",
                ),
            )
        )

    def _on_report(self, report: ActivityReport, out: list[Command]) -> None:
        schedule = self.schedule
        if (
            schedule is not None
            and report.task not in {t.id for t in schedule.problem.tasks}
            and report.task in {t.id for t in schedule.catalog}
        ):
            # A late report on a task that already left the problem (for
            # instance finished by the plan's prediction): note it only.
            self._dispatches.note(report.task, report.state)
            return
        if schedule is None or report.task not in {
            t.id for t in schedule.problem.tasks
        }:
            self._reject_input(
                f"telemetry/activities/{report.task}",
                "activity_report",
                [FieldIssue("task", f"no live task {report.task!r}")],
                out,
            )
            return
        wrong = self._report_issue(report)
        if wrong is not None:
            self._reject_input(
                f"telemetry/activities/{report.task}",
                "activity_report",
                [wrong],
                out,
            )
            return
        self._count(reports=self._counters.reports + 1)
        self._dispatches.report(report.task, report.state)
        at = min(report.at, self._clock())
        self.schedule = schedule.with_report(
            ExecutionReport(report.task, report.state, at)
        )
        out.append(
            Publish(
                topics.STATUS,
                self._status(
                    "activity",
                    detail=f"{report.task} {report.state} at {report.at}",
                ),
            )
        )
        if report.state == "failed":
            self._queue.append(
                QueuedChange("failure", task=report.task, at=at)
            )

    def _report_issue(self, report: ActivityReport) -> FieldIssue | None:
        """Why ``report`` answers no dispatch of this spacecraft (None: it
        does): its task was never dispatched, it names another dispatch,
        a later term or a time to come."""
        task = report.task
        if self._dispatches.lifecycle.get(task, "planned") == "planned":
            return FieldIssue(
                "task", f"{task!r} was never dispatched: nothing to report on"
            )
        if report.at > self._clock():
            return FieldIssue(
                "at", f"{report.at} is after now ({self._clock()})"
            )
        if report.term > self.term:
            return FieldIssue(
                "term", f"{report.term} is above this node's term {self.term}"
            )
        if not report.dispatch_id:
            if self.config.reports_need_dispatch:
                return FieldIssue(
                    "dispatch_id", "missing: name the dispatch this answers"
                )
            return None
        # The dispatch as it was sent: a replan re-bases a running
        # activity to start now, but its dispatch keeps its id.
        sent = self._dispatches.sent.get(task)
        schedule = self.schedule
        current = schedule.plan.activity(task) if schedule else None
        if sent is not None:
            expected: str | None = f"{task}:{sent[0]}-{sent[1]}"
        else:
            expected = dispatch_id(current) if current is not None else None
        if expected is not None and report.dispatch_id != expected:
            return FieldIssue(
                "dispatch_id",
                f"{report.dispatch_id!r} is not the dispatch of {task!r} "
                f"({expected!r})",
            )
        return None

    def _on_level(self, level: ResourceLevel, out: list[Command]) -> None:
        self._count(levels=self._counters.levels + 1)
        schedule = self.schedule
        if schedule is None:
            return
        consumables = schedule.problem.resources.consumable
        if level.resource not in consumables:
            self._reject_input(
                f"telemetry/resources/{level.resource}",
                "resource_level",
                [
                    FieldIssue(
                        "resource",
                        f"{level.resource!r} is not a consumable resource",
                    )
                ],
                out,
            )
            return
        if not 0 <= level.at <= self._clock():
            self._reject_input(
                f"telemetry/resources/{level.resource}",
                "resource_level",
                [
                    FieldIssue(
                        "at",
                        f"{level.at} is outside [0, now = {self._clock()}]: "
                        "a level is measured, never foreseen",
                    )
                ],
                out,
            )
            return
        at = max(level.at, schedule.problem.start)
        departed = drift(
            schedule.problem,
            schedule.plan,
            at,
            {level.resource: level.level},
            self.config.tolerance,
        )
        if not departed:
            return
        d = departed[0]
        out.append(
            Publish(
                topics.STATUS,
                self._status(
                    "drift",
                    detail=f"{d.resource} measured {d.measured:g} at {at}, "
                    f"plan predicted {d.predicted:g}",
                ),
            )
        )
        self._queue.append(
            QueuedChange("levels", at=at, levels={level.resource: level.level})
        )

    def _on_rejected(self, event: InputRejected, out: list[Command]) -> None:
        if event.kind == "goal":
            self._reject_goal(event.goal_id, event.errors, out)
        else:
            self._reject_input(event.key, event.kind, event.errors, out)

    # -- solving -------------------------------------------------------------

    # -- adopting and dispatching --------------------------------------------

    # -- status helpers ------------------------------------------------------


_STALLED = "bus clock stalled"
