"""The scheduler's functional core: events in, commands out.

:class:`Engine` holds every piece of the scheduler's state and changes it
only in :meth:`Engine.step`, which takes one event and the current time
unit and returns the commands for the shell to carry out: publish a
message, start a solve, log a line. It never solves, publishes, decodes or
reads a clock, so the same sequence of events always gives the same
commands; the bus node (:mod:`fsw_scheduler.bus.node`) and deterministic
replay (:mod:`fsw_scheduler.replay`) both drive it.

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

import hashlib
from typing import Any, Literal

import msgspec

from ..errors import FieldIssue, InputError
from ..model.change import ExecutionReport, Removal
from ..model.goal import Goal
from ..model.plan import Activity, Blocker, Plan, SolverStats, SolveStatus
from ..model.problem import Problem
from ..replan.schedule import Replan, Schedule, empty_plan
from ..replan.shed import (
    shed_blockers,
    shed_tasks,
    shedding_problem,
    without_tasks,
)
from ..replan.triggers import (
    Tolerance,
    apply_failure,
    apply_goal,
    apply_levels,
    drift,
)
from ..wire import topics
from ..wire.messages import (
    ActivityReport,
    Counters,
    Dispatch,
    PlanMessage,
    ResourceLevel,
    SolveRecord,
    SolveSummary,
    Status,
)
from .snapshot import EngineSnapshot, Lifecycle, PendingSolve, QueuedChange

# -- events ------------------------------------------------------------------


class Tick(msgspec.Struct, frozen=True, tag=True):
    """Time advanced to ``now`` (bus clock or the node's own clock)."""

    now: int


class GoalArrived(msgspec.Struct, frozen=True, tag=True):
    """A decoded goal from ``scheduler/goals``."""

    goal: Goal


class ReportArrived(msgspec.Struct, frozen=True, tag=True):
    """An execution report from ``telemetry/activities/<task>``."""

    report: ActivityReport


class LevelArrived(msgspec.Struct, frozen=True, tag=True):
    """A consumable level from ``telemetry/resources/<name>``."""

    level: ResourceLevel


class InputRejected(msgspec.Struct, frozen=True, tag=True):
    """An input the shell could not decode; reported, never fatal."""

    key: str
    kind: str
    errors: tuple[FieldIssue, ...]
    goal_id: str | None = None


class ClockStalled(msgspec.Struct, frozen=True, tag=True):
    """No bus clock message for ``seconds`` (wall clock) since ``last``."""

    seconds: float
    last: int | None = None


class Explained(msgspec.Struct, frozen=True, tag=True):
    """Why tasks of plan ``plan_id`` (from solve ``solve_id``) are out."""

    solve_id: int
    plan_id: int
    why: tuple[Blocker, ...] = ()


class SolveDone(msgspec.Struct, frozen=True, tag=True):
    """The result of a :class:`StartSolve`."""

    solve_id: int
    plan: Plan


class SolveFailed(msgspec.Struct, frozen=True, tag=True):
    """A :class:`StartSolve` raised (solver missing, crashed)."""

    solve_id: int
    error: str


Event = (
    Tick
    | GoalArrived
    | ReportArrived
    | LevelArrived
    | InputRejected
    | ClockStalled
    | Explained
    | SolveDone
    | SolveFailed
)

# -- commands ----------------------------------------------------------------


class Publish(msgspec.Struct, frozen=True):
    """Publish ``message`` on ``fsw/<sc>/<suffix>``."""

    suffix: str
    message: msgspec.Struct


class StartSolve(msgspec.Struct, frozen=True):
    """Solve ``problem`` (warm-started from ``warm``); reply with SolveDone.

    ``explain`` asks for the reasons of left-out tasks whatever the node's
    settings (the shedding solve: an alarm must say why).
    """

    solve_id: int
    trigger: str
    problem: Problem
    warm: Plan | None = None
    explain: bool = False


class StartExplain(msgspec.Struct, frozen=True):
    """Explain why tasks of the plan just published are out.

    Runs after the plan is out, so it never delays it; the shell answers
    with :class:`Explained`.
    """

    solve_id: int
    plan_id: int
    problem: Problem
    plan: Plan


class Log(msgspec.Struct, frozen=True):
    """A line for the component's log."""

    level: Literal["debug", "info", "warning", "error"]
    text: str


Command = Publish | StartSolve | StartExplain | Log

# -- configuration -----------------------------------------------------------


class EngineConfig(msgspec.Struct, frozen=True):
    """Settings of the functional core.

    Attributes
    ----------
    report_timeout
        Units after a dispatch without any execution report before the
        activity counts as failed; None waits forever.
    tolerance
        How far a measured level may depart from the prediction before a
        replan.
    heartbeat
        Units between periodic status messages (0: none).
    replan_lead
        Units between a trigger and the start of the plan it causes: the
        time a solve may take without its first activities being late.
    max_tasks_per_goal, max_live_tasks
        A goal with more tasks, or one that would make the plan hold more
        live tasks (planned, running or deferred), is rejected with the
        reason (None: no limit).
    max_goals_waiting
        Goals queued behind a solve; one more is rejected ``busy``.
    max_goals_per_solve
        Goals merged into one solve; the others wait for the next.
    max_history
        Finished activities (completed, failed, preempted, obsolete) kept
        in the lifecycle map; the oldest leave it first.
    explain_after_plan
        Ask for the explanation of a plan's left-out tasks after it is
        published (:class:`StartExplain`) instead of inside the solve.
    """

    report_timeout: int | None = None
    tolerance: Tolerance = Tolerance(absolute=0.5)
    heartbeat: int = 0
    replan_lead: int = 0
    max_tasks_per_goal: int | None = None
    max_live_tasks: int | None = None
    max_goals_waiting: int | None = None
    max_goals_per_solve: int | None = None
    node_id: str | None = None
    max_history: int = 1000
    explain_after_plan: bool = False


# -- the engine -------------------------------------------------------------



def problem_hash(problem: Problem) -> str:
    """SHA-256 of the compact JSON of ``problem`` (solve records)."""
    return hashlib.sha256(msgspec.json.encode(problem)).hexdigest()


class Engine:
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

    def __init__(self, config: EngineConfig, initial: Problem) -> None:
        self.config = config
        self._unsolved_initial: Problem | None = initial
        self.schedule: Schedule | None = None
        self.plan_id: int | None = None
        self.now: int | None = None
        self._solve_id = 0
        self._pending: PendingSolve | None = None
        self._queue: list[QueuedChange] = []
        self._dispatched: dict[str, int] = {}  # task -> unit of dispatch
        self._lifecycle: dict[str, Lifecycle] = {}
        # The lifecycle as last published: statuses carry the difference.
        self._reported: dict[str, Lifecycle] = {}
        # (start, end) of each activity's dispatch still standing.
        self._sent: dict[str, tuple[int, int]] = {}
        self._counters = Counters()
        self._last_solve: SolveSummary | None = None
        self._inputs = 0
        self._health: Literal["ok", "degraded", "error"] = "ok"
        self._health_detail = ""
        self._plan_message: PlanMessage | None = None
        self.initial = initial

    # -- read-only views (for queryables) ---------------------------------

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
            activities=dict(sorted(self._lifecycle.items())),
            counters=self._counters,
            last_solve=self._last_solve,
            node_id=self.config.node_id,
            **extra,  # type: ignore[arg-type]
        )

    # -- snapshots (resume, hot standby) ------------------------------------

    def snapshot(self) -> EngineSnapshot:
        """The whole state, as data (see :mod:`fsw_scheduler.snapshot`)."""
        return EngineSnapshot(
            initial=self.initial,
            unsolved_initial=self._unsolved_initial,
            schedule=self.schedule,
            plan_id=self.plan_id,
            now=self.now,
            solve_id=self._solve_id,
            pending=self._pending,
            queue=tuple(self._queue),
            dispatched=dict(self._dispatched),
            lifecycle=dict(self._lifecycle),
            reported=dict(self._reported),
            sent=dict(self._sent),
            counters=self._counters,
            last_solve=self._last_solve,
            inputs=self._inputs,
            health=self._health,
            health_detail=self._health_detail,
            plan_message=self._plan_message,
        )

    @classmethod
    def restore(
        cls, config: EngineConfig, snapshot: EngineSnapshot
    ) -> Engine:
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
        engine._dispatched = dict(snapshot.dispatched)
        engine._lifecycle = dict(snapshot.lifecycle)
        engine._reported = dict(snapshot.reported)
        engine._sent = dict(snapshot.sent)
        engine._counters = snapshot.counters
        engine._last_solve = snapshot.last_solve
        engine._inputs = snapshot.inputs
        engine._health = snapshot.health
        engine._health_detail = snapshot.health_detail
        engine._plan_message = snapshot.plan_message
        return engine

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
        for activity in schedule.plan.activities:
            task = activity.task
            if self._lifecycle.get(task) != "dispatched" or self._sent.get(
                task
            ) != (activity.start, activity.end):
                continue
            since = self._dispatched.get(task, activity.start)
            out.append(self._dispatch(schedule, activity, since))
        return out

    def resumed(self, event: str = "resumed", **extra: object) -> Command:
        """The status saying this engine was rebuilt and goes on."""
        detail = (
            f"state rebuilt at t={self.now}: plan {self.plan_id}, "
            f"{len(self._lifecycle)} activities known"
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

    def _status(self, event: str, full: bool = False, **extra: Any) -> Status:
        """A status to publish: ``changed`` since the last one published.

        Verdicts and events carry only the lifecycle entries that changed
        since the previous published status; heartbeats (``full``) carry
        the whole map too. Applying every ``changed`` in order to the last
        full map gives the current map.
        """
        lifecycle = self._lifecycle
        reported = self._reported
        changed = {
            k: v for k, v in sorted(lifecycle.items()) if reported.get(k) != v
        }
        self._reported = dict(lifecycle)
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

    def count_dropped(self, dropped: int) -> None:
        """Record inputs the shell dropped because its queue was full."""
        self._count(inputs_dropped=dropped)

    def count_shell(self, **totals: int) -> None:
        """Record the shell's running totals (see ``Counters``)."""
        current = self._counters
        if any(getattr(current, k) != v for k, v in totals.items()):
            self._count(**totals)

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
        elif isinstance(event, SolveDone):
            self._on_solve_done(event, out)
        elif isinstance(event, SolveFailed):
            self._on_solve_failed(event, out)
        if self._pending is None:
            self._start_queued(out)
        self._dispatch_due(out)
        return out

    # -- event handlers ------------------------------------------------------

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
            try:
                self._live_checked(
                    apply_goal(self.schedule, goal, self._clock())
                )
            except InputError as error:
                self._reject_goal(goal.goal_id, error.issues, out)
                return
        self._queue.append(QueuedChange("goal", goal=goal))
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

    def _on_report(self, report: ActivityReport, out: list[Command]) -> None:
        schedule = self.schedule
        if (
            schedule is not None
            and report.task not in {t.id for t in schedule.problem.tasks}
            and report.task in {t.id for t in schedule.catalog}
        ):
            # A late report on a task that already left the problem (for
            # instance finished by the plan's prediction): note it only.
            self._lifecycle[report.task] = report.state
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
        self._count(reports=self._counters.reports + 1)
        self._dispatched.pop(report.task, None)
        self._sent.pop(report.task, None)
        at = min(report.at, self._clock())
        self.schedule = schedule.with_report(
            ExecutionReport(report.task, report.state, at)
        )
        self._lifecycle[report.task] = report.state
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
        at = max(min(level.at, self._clock()), schedule.problem.start)
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

    def _on_solve_done(self, event: SolveDone, out: list[Command]) -> None:
        pending = self._pending
        if pending is None or event.solve_id != pending.solve_id:
            out.append(Log("warning", f"stray solve {event.solve_id}"))
            return
        self._pending = None
        plan = event.plan
        stats = plan.stats or SolverStats(solver="?")
        self._count(solves=self._counters.solves + 1)
        adopted = plan.status.has_plan and pending.stage != "shed"
        reason = "" if plan.status.has_plan else _no_plan_reason(plan)
        self._last_solve = SolveSummary(
            solve_id=event.solve_id,
            trigger=pending.trigger,
            status=plan.status,
            objective=plan.objective,
            wall_s=stats.wall_s,
            adopted=adopted,
            reason=reason,
        )
        out.append(self._solve_record(pending, plan))
        if (
            plan.status is SolveStatus.INFEASIBLE
            and pending.stage == "plan"
            and pending.replan is not None
            and not pending.goals
        ):
            # The world, not a goal, made the plan impossible: do not keep
            # flying it; find the best plan still possible.
            self._start_shedding(pending, plan, out)
            return
        if pending.stage == "shed" and plan.status.has_plan:
            self._start_degraded(pending, plan, out)
            return
        if not adopted:
            self._solve_without_plan(pending, reason, out)
            return
        if pending.stage == "degraded":
            assert pending.replan is not None
            assert pending.infeasible is not None
            shed = shed_blockers(pending.replan.removed, pending.infeasible)
            plan = plan.replace(
                status=SolveStatus.DEGRADED, why=(*shed, *plan.why)
            )
        if pending.replan is None:
            assert self._plan_message is None
            self.schedule = Schedule.begin(pending.problem, plan)
            self._adopt(plan, pending.trigger, pending.goals, (), out)
        else:
            self.schedule = pending.replan.adopt(plan)
            self._adopt(
                plan,
                pending.trigger,
                pending.goals,
                pending.replan.removed,
                out,
            )
        if pending.stage == "degraded":
            self._raise_alarm(plan, out)
        if (
            self.config.explain_after_plan
            and plan.unscheduled
            and self.plan_id is not None
        ):
            out.append(
                StartExplain(
                    event.solve_id, self.plan_id, pending.problem, plan
                )
            )
        if (
            pending.dispatches_at_start != self._counters.dispatches
            and self._clock() > pending.started_at
        ):
            # The old plan dispatched while this one was being computed for
            # an earlier time: replan from what really happened.
            self._queue.append(QueuedChange("levels", at=self._clock()))

    def _on_solve_failed(self, event: SolveFailed, out: list[Command]) -> None:
        pending = self._pending
        if pending is None or event.solve_id != pending.solve_id:
            return
        self._pending = None
        self._count(
            solves=self._counters.solves + 1,
            solves_failed=self._counters.solves_failed + 1,
        )
        self._last_solve = SolveSummary(
            solve_id=event.solve_id,
            trigger=pending.trigger,
            status=SolveStatus.UNKNOWN,
            reason=event.error,
        )
        self._solve_without_plan(pending, event.error, out)

    # -- solving -------------------------------------------------------------

    def _start_queued(self, out: list[Command]) -> None:
        """Start the next solve: failures first, then goals, then levels."""
        while self._queue and self._pending is None:
            schedule = self.schedule
            if schedule is None:
                return
            # A replan governs time from ``now + replan_lead`` on: until
            # its plan is ready, the current one keeps dispatching.
            now = max(
                self._clock() + self.config.replan_lead,
                schedule.problem.start,
            )
            failures = [c for c in self._queue if c.kind == "failure"]
            goals = [c for c in self._queue if c.kind == "goal"][
                : self.config.max_goals_per_solve
            ]
            if failures:
                change = failures[0]
                self._queue.remove(change)
                if change.task not in {t.id for t in schedule.problem.tasks}:
                    # Already handled by an earlier failure replan.
                    continue
                try:
                    replan = apply_failure(
                        schedule, change.task, min(change.at, now), now=now
                    )
                except InputError as error:
                    out.append(Log("warning", f"failure ignored: {error}"))
                    continue
                self._start_solve(
                    "failure", replan.problem, replan, replan.warm, (), out
                )
            elif goals:
                self._start_goals(schedule, goals, now, out)
            else:
                levels: dict[str, float] = {}
                at = now
                for change in self._queue:
                    levels.update(change.levels)
                    at = min(at, change.at)
                trigger = "drift" if levels else "stale"
                if not levels and any(
                    c.trigger == "horizon" for c in self._queue
                ):
                    trigger = "horizon"
                self._queue.clear()
                try:
                    replan = apply_levels(
                        schedule, levels, now, at=at, keep_running=True
                    )
                except InputError as error:
                    out.append(Log("warning", f"levels ignored: {error}"))
                    continue
                self._start_solve(
                    trigger, replan.problem, replan, replan.warm, (), out
                )

    def _start_goals(
        self,
        schedule: Schedule,
        changes: list[QueuedChange],
        now: int,
        out: list[Command],
    ) -> None:
        """Coalesce queued goals into one replan; reject any that clash."""
        accepted: list[Goal] = []
        replan: Replan | None = None
        for change in changes:
            self._queue.remove(change)
            assert change.goal is not None
            candidate = _merge_goals([*accepted, change.goal])
            try:
                replan = self._live_checked(
                    apply_goal(schedule, candidate, now)
                )
            except InputError as error:
                self._reject_goal(change.goal.goal_id, error.issues, out)
                continue
            accepted.append(change.goal)
        if not accepted:
            return
        replan = apply_goal(schedule, _merge_goals(accepted), now)
        self._start_solve(
            "goal",
            replan.problem,
            replan,
            replan.warm,
            tuple(g.goal_id for g in accepted),
            out,
        )

    def _start_shedding(
        self, pending: PendingSolve, infeasible: Plan, out: list[Command]
    ) -> None:
        """Solve which mandatory tasks to keep (see :mod:`.shed`)."""
        assert pending.replan is not None
        reason = _no_plan_reason(infeasible)
        out.append(
            Log(
                "warning",
                f"solve {pending.solve_id} ({pending.trigger}) is "
                f"{reason}; shedding mandatory tasks",
            )
        )
        self._start_solve(
            pending.trigger,
            shedding_problem(pending.replan.problem),
            pending.replan,
            None,
            (),
            out,
            stage="shed",
            infeasible=infeasible,
        )

    def _start_degraded(
        self, pending: PendingSolve, shedding: Plan, out: list[Command]
    ) -> None:
        """Solve the replan without the mandatory tasks it cannot keep."""
        assert pending.replan is not None
        assert pending.infeasible is not None
        dropped = shed_tasks(pending.replan.problem, shedding)
        replan = without_tasks(
            pending.replan,
            dropped,
            f"{pending.trigger} at t={pending.started_at} left no room",
        )
        self._start_solve(
            pending.trigger,
            replan.problem,
            replan,
            replan.warm,
            (),
            out,
            stage="degraded",
            # The shedding solve explains its left-out tasks with the
            # constraint that really blocks each; those reasons win.
            infeasible=pending.infeasible.replace(
                why=(*pending.infeasible.why, *shedding.why)
            ),
        )

    def _raise_alarm(self, plan: Plan, out: list[Command]) -> None:
        """Say loudly that mandatory tasks were dropped, and why."""
        out.append(Log("error", _degraded_detail(self.plan_id, plan)))
        out.append(Publish(topics.STATUS, self.status("alarm")))

    def _start_solve(
        self,
        trigger: str,
        problem: Problem,
        replan: Replan | None,
        warm: Plan | None,
        goals: tuple[str, ...],
        out: list[Command],
        *,
        stage: Literal["plan", "shed", "degraded"] = "plan",
        infeasible: Plan | None = None,
    ) -> None:
        if replan is not None and not problem.tasks:
            # Nothing left to schedule: adopt the empty plan without solving.
            self.schedule = replan.adopt(empty_plan())
            self._adopt(empty_plan(), trigger, goals, replan.removed, out)
            return
        self._solve_id += 1
        self._pending = PendingSolve(
            solve_id=self._solve_id,
            trigger=trigger,
            problem=problem,
            replan=replan,
            goals=goals,
            started_at=self._clock(),
            dispatches_at_start=self._counters.dispatches,
            stage=stage,
            infeasible=infeasible,
            warm=warm,
            explain=stage == "shed",
        )
        out.append(
            Log(
                "info",
                f"solve {self._solve_id} ({trigger}"
                f"{'' if stage == 'plan' else ', ' + stage}): "
                f"{problem.num_tasks} tasks over "
                f"[{problem.start}, {problem.end})",
            )
        )
        pending = self.pending_solve()
        assert pending is not None
        out.append(pending)

    def _solve_without_plan(
        self, pending: PendingSolve, reason: str, out: list[Command]
    ) -> None:
        """Keep the last good plan; say why; reject goals that caused it."""
        self._count(solves_failed=self._counters.solves_failed + 1)
        detail = (
            f"solve {pending.solve_id} ({pending.trigger}) gave no plan: "
            f"{reason}; keeping plan {self.plan_id}"
        )
        self._set_health("degraded", detail)
        out.append(Log("warning", detail))
        for goal_id in pending.goals:
            self._reject_goal(
                goal_id,
                [FieldIssue("", f"no plan with this goal: {reason}")],
                out,
            )
        if not pending.goals:
            out.append(Publish(topics.STATUS, self._status("solve_failed")))

    def _solve_record(self, pending: PendingSolve, plan: Plan) -> Publish:
        problem = pending.problem
        stats = plan.stats or SolverStats(solver="?")
        record = SolveRecord(
            solve_id=pending.solve_id,
            trigger=pending.trigger,
            input_hash=problem_hash(problem),
            problem=problem,
            status=plan.status,
            objective=plan.objective,
            plan_id=(
                (self.plan_id or 0) + 1
                if plan.status.has_plan and pending.stage != "shed"
                else None
            ),
            num_variables=stats.num_variables,
            num_constraints=stats.num_constraints,
            build_s=stats.build_s,
            solve_s=stats.solve_s,
            wall_s=stats.wall_s,
            inputs_seen=self._inputs,
            result=plan,
        )
        return Publish(topics.SOLVES, record)

    # -- adopting and dispatching --------------------------------------------

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
        self.plan_id = (self.plan_id or 0) + 1
        for removal in removed:
            if removal.rule in ("obsolete", "tight_cascade"):
                self._lifecycle[removal.task] = "obsolete"
            elif removal.rule != "finished":
                self._lifecycle.setdefault(removal.task, "preempted")
                if self._lifecycle[removal.task] in ("running", "dispatched"):
                    self._lifecycle[removal.task] = "preempted"
        continuing = set(schedule.continuing)
        for activity in plan.activities:
            if activity.task in continuing:
                continue
            state = self._lifecycle.get(activity.task)
            if state == "dispatched" and self._sent.get(activity.task) == (
                activity.start,
                activity.end,
            ):
                # Unchanged by this plan: the dispatch already sent stands
                # (sending it again with each replan made storms).
                continue
            self._lifecycle[activity.task] = "planned"
            self._dispatched.pop(activity.task, None)
            self._sent.pop(activity.task, None)
        self._forget_history()
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
        )
        if plan.status is SolveStatus.DEGRADED:
            self._set_health("degraded", _degraded_detail(self.plan_id, plan))
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
            self._count(goals_accepted=self._counters.goals_accepted + 1)
            out.append(
                Publish(
                    topics.STATUS,
                    self._status("goal_accepted", goal_id=goal_id),
                )
            )
        out.append(Publish(topics.STATUS, self._status("plan")))

    def _dispatch_due(self, out: list[Command]) -> None:
        schedule = self.schedule
        if schedule is None or self.now is None or self.plan_id is None:
            return
        continuing = set(schedule.continuing)
        for activity in schedule.plan.activities:
            if activity.start > self.now:
                break  # activities are sorted by start
            if (
                activity.task in continuing
                or self._lifecycle.get(activity.task) != "planned"
            ):
                continue
            late = activity.start < self.now
            self._lifecycle[activity.task] = "dispatched"
            self._dispatched[activity.task] = self.now
            self._sent[activity.task] = (activity.start, activity.end)
            self._count(
                dispatches=self._counters.dispatches + 1,
                late_dispatches=self._counters.late_dispatches + late,
            )
            out.append(self._dispatch(schedule, activity, self.now))

    def _dispatch(
        self, schedule: Schedule, activity: Activity, dispatched_at: int
    ) -> Publish:
        """The dispatch of ``activity``, sent at ``dispatched_at``.

        Its ``dispatch_id`` (task, start and end) stays the same for as
        long as the activity keeps its place, so a receiver keeps one.
        """
        task = activity.task
        assert self.plan_id is not None  # dispatches follow a plan
        return Publish(
            f"{topics.DISPATCH}/{task}",
            Dispatch(
                task=task,
                plan_id=self.plan_id,
                start=activity.start,
                end=activity.end,
                uses=dict(sorted(schedule.problem.task(task).uses.items())),
                dispatched_at=dispatched_at,
                late=activity.start < dispatched_at,
                dispatch_id=f"{task}:{activity.start}-{activity.end}",
            ),
        )

    def _forget_history(self) -> None:
        """Keep at most ``max_history`` finished entries (oldest go)."""
        finished = [
            task
            for task, state in self._lifecycle.items()
            if state not in ("planned", "dispatched", "running")
        ]
        excess = max(0, len(finished) - self.config.max_history)
        for task in finished[:excess]:
            del self._lifecycle[task]
            self._reported.pop(task, None)
            self._sent.pop(task, None)

    def _check_report_timeouts(self, out: list[Command]) -> None:
        timeout = self.config.report_timeout
        if timeout is None or self.now is None:
            return
        for task, since in sorted(self._dispatched.items()):
            if self.now - since > timeout:
                del self._dispatched[task]
                self._sent.pop(task, None)
                self._lifecycle[task] = "failed"
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
                self._queue.append(
                    QueuedChange("failure", task=task, at=since)
                )

    # -- status helpers ------------------------------------------------------

    def _reject_goal(
        self,
        goal_id: str | None,
        errors: list[FieldIssue] | tuple[FieldIssue, ...],
        out: list[Command],
    ) -> None:
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


_STALLED = "bus clock stalled"


def _merge_goals(goals: list[Goal]) -> Goal:
    """One goal carrying every task and precedence of ``goals``."""
    if len(goals) == 1:
        return goals[0]
    return Goal(
        goal_id="+".join(g.goal_id for g in goals),
        tasks=tuple(t for g in goals for t in g.tasks),
        precedences=tuple(p for g in goals for p in g.precedences),
    )


def _degraded_detail(plan_id: int | None, plan: Plan) -> str:
    """The alarm text of a degraded plan: each shed task and why."""
    return f"plan {plan_id} is degraded: " + "; ".join(
        f"{b.task} shed ({b.detail})" for b in plan.why if b.cause == "shed"
    )


def _no_plan_reason(plan: Plan) -> str:
    if plan.status is SolveStatus.INFEASIBLE:
        blocked = ", ".join(
            f"{b.task} ({b.cause}: {b.detail})" for b in plan.why
        )
        return "infeasible" + (f": {blocked}" if blocked else "")
    return f"{plan.status.value}: no plan found within the time limit"
