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

import math
from typing import TYPE_CHECKING

import msgspec

from ..errors import FieldIssue, InputError
from ..replan.triggers import drift
from ..wire import topics
from . import forecasts, overrun
from .dispatch import dispatch_message
from .events import (
    ClockStalled,
    Command,
    Event,
    Explained,
    FactsArrived,
    ForecastArrived,
    GoalArrived,
    InputRejected,
    LevelArrived,
    Log,
    NodePaused,
    Publish,
    ReportArrived,
    SolveDone,
    SolveFailed,
    TermBegan,
    Tick,
)
from .execution import Execution
from .ledger import goal_digest
from .merge import merge_facts
from .queue import SolveQueue
from .reports import Reports
from .snapshot import EngineSnapshot, GoalRecord, QueuedChange
from .solves import Replanner
from .state import CLOCK_STALLED, EngineState
from .verdicts import Verdicts

if TYPE_CHECKING:
    from ..model.goal import Goal
    from ..model.problem import Problem
    from ..replan.schedule import Schedule
    from ..wire.messages import (
        PlanMessage,
        ResourceLevel,
        Status,
    )
    from .config import EngineConfig
    from .events import StartSolve


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

    Notes
    -----
    The engine is composed of parts that each read alone: the shared
    :class:`~fsw_scheduler.engine.state.EngineState`, the
    :class:`~fsw_scheduler.engine.queue.SolveQueue`, the
    :class:`~fsw_scheduler.engine.verdicts.Verdicts` that speak for it,
    the :class:`~fsw_scheduler.engine.execution.Execution` that adopts and
    dispatches plans, and the :class:`~fsw_scheduler.engine.solves.Replanner`
    that decides what to solve. The engine itself holds the handler of
    each event.
    """

    def __init__(
        self,
        config: EngineConfig,
        initial: Problem,
        *,
        state: EngineState | None = None,
        queue: SolveQueue | None = None,
    ) -> None:
        self._state = state or EngineState(config, initial)
        self._queue = queue or SolveQueue()
        self._verdicts = Verdicts(self._state, self._queue)
        self._execution = Execution(self._state, self._queue, self._verdicts)
        self._reports = Reports(self._state, self._queue, self._verdicts)
        self._replanner = Replanner(
            self._state, self._queue, self._verdicts, self._execution
        )

    # -- read-only views (for queryables) ---------------------------------

    @property
    def config(self) -> EngineConfig:
        """Engine settings."""
        return self._state.config

    @property
    def initial(self) -> Problem:
        """The initial problem the engine was given."""
        return self._state.initial

    @property
    def schedule(self) -> Schedule | None:
        """The schedule being flown (None before the first plan)."""
        return self._state.schedule

    @property
    def plan_id(self) -> int | None:
        """The id of the current plan (None before the first)."""
        return self._state.plan_id

    @property
    def now(self) -> int | None:
        """The latest time unit seen (None before the first event)."""
        return self._state.now

    @property
    def term(self) -> int:
        """The command term stamped on every output."""
        return self._state.term

    @property
    def busy(self) -> bool:
        """True while a solve is in flight."""
        return self._queue.busy

    @property
    def inputs_seen(self) -> int:
        """Number of events processed so far."""
        return self._state.inputs

    @property
    def plan_message(self) -> PlanMessage | None:
        """The current plan as published (None before the first plan)."""
        return self._state.plan_message

    @property
    def pending_goals(self) -> tuple[str, ...]:
        """Goal ids of the solve in flight (empty when none)."""
        return self._queue.pending_goals

    @property
    def goals_waiting(self) -> int:
        """Goals accepted for processing and waiting for a solve."""
        return self._queue.goals_waiting

    def status(self, event: str = "heartbeat", **extra: object) -> Status:
        """The current status with the whole lifecycle map (queries)."""
        return self._verdicts.status(event, **extra)

    def pending_solve(self) -> StartSolve | None:
        """The solve in flight, as the command that asked for it.

        A node that resumes (or takes over) while a solve was running asks
        for it again: the same input gives the same plan.
        """
        return self._queue.pending_solve()

    def note_what_if(self) -> None:
        """Count a what-if answered (``counters.what_ifs``): the only
        trace it leaves in the state, at the place it is journaled."""
        self._state.count(what_ifs=self._state.counters.what_ifs + 1)

    def count_shell(self, **totals: int) -> None:
        """Record the shell's running totals (see ``Counters``)."""
        current = self._state.counters
        if any(getattr(current, k) != v for k, v in totals.items()):
            self._state.count(**totals)

    # -- snapshots (resume, hot standby) ------------------------------------

    def snapshot(self) -> EngineSnapshot:
        """The whole state, as data (see
        :mod:`fsw_scheduler.engine.snapshot`)."""
        state, queue = self._state, self._queue
        dispatches = state.dispatches
        return EngineSnapshot(
            initial=state.initial,
            unsolved_initial=state.unsolved_initial,
            schedule=state.schedule,
            plan_id=state.plan_id,
            now=state.now,
            solve_id=queue.solve_id,
            pending=queue.pending,
            queue=tuple(queue.changes),
            dispatched=dict(dispatches.dispatched),
            lifecycle=dict(dispatches.lifecycle),
            reported=dict(dispatches.reported),
            sent=dict(dispatches.sent),
            cancelling=dict(dispatches.cancelling),
            numbers=dict(dispatches.numbers),
            held=tuple(state.held),
            counters=state.counters,
            last_solve=state.last_solve,
            inputs=state.inputs,
            health=state.health,
            health_detail=state.health_detail,
            plan_message=state.plan_message,
            term=state.term,
            ledger=dict(state.ledger.records),
            paused_at=state.paused_at,
            forecasts=tuple(state.forecasts),
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
        return cls(
            config,
            snapshot.initial,
            state=EngineState.restore(config, snapshot),
            queue=SolveQueue(
                snapshot.queue, snapshot.pending, snapshot.solve_id
            ),
        )

    def resume_commands(self, event: str = "resumed") -> list[Command]:
        """What a rebuilt engine says first: the status, then its outputs.

        A node saves its state before its outputs reach the bus, so when
        it died in between, the plan and dispatches of its last step were
        never seen. They are published again: the current plan (same
        ``plan_id``), every dispatch still waiting for its first
        report, with its ``dispatch_id``, so that a receiver that has it
        already drops it, and every cancel still waiting for its answer.
        """
        state = self._state
        out: list[Command] = [self.resumed(event)]
        schedule = state.schedule
        if state.plan_message is not None:
            out.append(Publish(topics.PLAN, state.plan_message))
        if schedule is None or state.plan_id is None:
            return out
        for activity, since in state.dispatches.standing(schedule.plan):
            out.append(
                dispatch_message(
                    state.plan_id,
                    schedule.problem,
                    activity,
                    since,
                    state.term,
                    number=state.dispatches.number(activity.task),
                )
            )
        dispatches = state.dispatches
        for task, since in sorted(dispatches.cancelling.items()):
            span = dispatches.sent.get(task)
            if span is not None:
                out.append(self._execution.cancel_message(task, span, since))
        return out

    def resumed(self, event: str = "resumed", **extra: object) -> Command:
        """The status saying this engine was rebuilt and goes on."""
        state = self._state
        detail = (
            f"state rebuilt at t={state.now}: plan {state.plan_id}, "
            f"{len(state.dispatches.lifecycle)} activities known"
            + (", a solve in flight asked again" if self.busy else "")
        )
        return self._verdicts.publish(
            event,
            full=True,
            detail=detail,
            from_plan_id=state.plan_id,
            at=state.now,
            **extra,
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
        state = self._state
        state.inputs += 1
        before = state.now
        if state.now is None or now > state.now:
            state.now = now
        out: list[Command] = []
        self._reports.release_held(out)
        if overrun.pushing(state):
            # Before any replan of this step: an activity past its end
            # with no report is running on, not finished on time.
            overrun.note_running(state)
        if isinstance(event, Tick):
            self._on_tick(out)
        elif isinstance(event, GoalArrived):
            self._on_goal(event.goal, out)
        elif isinstance(event, ReportArrived):
            self._reports.on_report(event.report, out)
        elif isinstance(event, LevelArrived):
            self._on_level(event.level, out)
        elif isinstance(event, ForecastArrived):
            forecasts.take(
                self._state, self._queue, self._verdicts, event.forecast, out
            )
        elif isinstance(event, InputRejected):
            self._on_rejected(event, out)
        elif isinstance(event, ClockStalled):
            self._on_stalled(event, out)
        elif isinstance(event, NodePaused):
            self._on_paused(event, out)
        elif isinstance(event, Explained):
            self._on_explained(event, out)
        elif isinstance(event, TermBegan):
            self._on_term(event, out)
        elif isinstance(event, FactsArrived):
            self._on_facts(event, out)
        elif isinstance(event, SolveDone):
            self._replanner.on_solve_done(event, out)
        elif isinstance(event, SolveFailed):
            self._replanner.on_solve_failed(event, out)
        # Dispatch first: a replan started in this step then counts what
        # was just commanded as started, never moves it, never sends it
        # twice.
        late = state.paused_at is not None and isinstance(event, Tick)
        # After this node's own pause, what the jump passed over is
        # dispatched late (it is still wanted), not missed.
        self._execution.dispatch_due(out, None if late else before)
        if late:
            state.paused_at = None
        self._execution.alarm_overdue(out, before)
        if not self._queue.busy:
            self._replanner.start_queued(out)
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
        self._state.term = event.term
        out.append(
            Log(
                "info",
                f"term {event.term} begins ({event.reason or 'command'}"
                f"{', node ' + event.node_id if event.node_id else ''})",
            )
        )
        if event.lost:
            # Older state than the bus has seen: never silent.
            out.append(Log("error", event.lost))
            out.append(
                self._verdicts.publish(
                    "alarm", detail=event.lost, state="degraded"
                )
            )
        elif event.unverified:
            # Nothing known lost, nothing proved current: said once.
            out.append(Log("warning", event.unverified))
            out.append(
                self._verdicts.publish("alarm", detail=event.unverified)
            )

    def _on_facts(self, event: FactsArrived, out: list[Command]) -> None:
        """Take what a commander that stood down commanded (see
        :mod:`.merge`), then replan from it."""
        facts = event.facts
        goals, merged, cancelling = merge_facts(self._state, facts)
        if not (goals or merged):
            return
        state = self._state
        for task in cancelling:
            span = state.dispatches.sent[task]
            out.append(
                self._execution.cancel_message(task, span, state.clock())
            )
        detail = (
            f"from {facts.node_id or '?'} (term {facts.term}): "
            f"{len(merged)} commanded activities"
            + (f" ({', '.join(merged)})" if merged else "")
            + f", {len(goals)} goals carried over"
            + (f" ({', '.join(goals)})" if goals else "")
        )
        out.append(Log("info", f"facts merged {detail}"))
        out.append(self._verdicts.publish("facts_merged", detail=detail))
        self._queue.add(
            QueuedChange("levels", at=state.clock(), trigger="merged")
        )

    def _on_explained(self, event: Explained, out: list[Command]) -> None:
        message = self._state.plan_message
        if message is None or message.plan_id != event.plan_id:
            return  # a newer plan is out; its own explanation follows
        self._state.plan_message = msgspec.structs.replace(
            message, why=event.why
        )
        out.append(
            self._verdicts.publish(
                "explained",
                why=event.why,
                detail=f"plan {event.plan_id}: why "
                f"{len(event.why)} tasks are out",
            )
        )

    def _on_stalled(self, event: ClockStalled, out: list[Command]) -> None:
        detail = (
            f"{_STALLED}: no clock message for {event.seconds:g} s "
            f"since unit {event.last}"
        )
        self._state.set_health("degraded", detail)
        out.append(Log("warning", detail))
        out.append(self._verdicts.publish("clock_stalled"))

    def _on_paused(self, event: NodePaused, out: list[Command]) -> None:
        detail = (
            f"this node did not run for {event.seconds:g} s since unit "
            f"{event.last} (under the lease: it still commands); what "
            "came due meanwhile is dispatched late"
        )
        self._state.paused_at = self._state.now
        out.append(Log("warning", detail))
        out.append(self._verdicts.publish("paused", detail=detail))

    def _on_tick(self, out: list[Command]) -> None:
        if self._state.health_detail.startswith(_STALLED):
            self._state.set_health("ok", "")
            out.append(self._verdicts.publish("clock_resumed"))
        if self._state.unsolved_initial is not None and not self.busy:
            self._replanner.start_initial(out)
        self._execution.check_report_timeouts(out)
        self._execution.check_cancels(out)
        if self._deferred_due() and not self._queue.has_trigger("horizon"):
            self._queue.add(
                QueuedChange(
                    "levels", at=self._state.clock(), trigger="horizon"
                )
            )
        beat = self.config.heartbeat
        if beat and self.now is not None and self.now % beat == 0:
            out.append(self._verdicts.publish("heartbeat", full=True))

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

    def _on_goal(self, goal: Goal, out: list[Command]) -> None:
        digest = goal_digest(goal)
        record = self._state.ledger.seen(goal.goal_id)
        if record is not None:
            self._answer_repeat(goal.goal_id, digest, record, out)
            return
        if goal.not_after is not None and self._state.clock() > goal.not_after:
            self._verdicts.reject_goal(
                goal.goal_id,
                [
                    FieldIssue(
                        "not_after",
                        f"the goal expired at t={goal.not_after}; now is "
                        f"t={self._state.clock()}",
                    )
                ],
                out,
            )
            return
        schedule = self.schedule
        if schedule is None and not self.busy:
            self._verdicts.reject_goal(
                goal.goal_id,
                [FieldIssue("", "no plan yet: the scheduler has not started")],
                out,
            )
            return
        config = self.config
        limit = config.max_tasks_per_goal
        if limit is not None and len(goal.tasks) > limit:
            self._verdicts.reject_goal(
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
            self._verdicts.reject_goal(
                goal.goal_id,
                [FieldIssue("", f"busy: {waiting} goals waiting")],
                out,
            )
            return
        # Validate against the live state now so a bad goal is rejected at
        # once, even when it has to wait for a solve in flight.
        if schedule is not None:
            try:
                self._replanner.check_goal(schedule, goal)
            except InputError as error:
                self._verdicts.reject_goal(goal.goal_id, error.issues, out)
                return
        self._queue.add(QueuedChange("goal", goal=goal))
        self._state.ledger.queue(
            goal.goal_id,
            digest,
            self._state.clock(),
            self.term,
            tuple(t.id for t in goal.tasks),
        )
        pending = self._queue.pending
        if pending is not None:
            out.append(
                Log("info", f"goal {goal.goal_id} queued behind a solve")
            )
            out.append(
                self._verdicts.publish(
                    "goal_queued",
                    goal_id=goal.goal_id,
                    detail=f"waiting behind solve "
                    f"{pending.solve_id} ({pending.trigger}); "
                    f"{waiting + 1} goals waiting",
                )
            )

    def _answer_repeat(
        self, goal_id: str, digest: str, record: GoalRecord, out: list[Command]
    ) -> None:
        """A goal id already in the ledger: its verdict again, or no."""
        if record.digest != digest:
            self._verdicts.reject_goal(
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
            self._verdicts.publish(
                event,
                goal_id=goal_id,
                detail=f"goal {goal_id} again, the same as at "
                f"t={record.at}: its verdict stands, nothing changes",
            )
        )

    def _on_level(self, level: ResourceLevel, out: list[Command]) -> None:
        self._state.count(levels=self._state.counters.levels + 1)
        schedule = self.schedule
        if schedule is None:
            # Nothing to compare it with: say so rather than drop it.
            self._verdicts.reject_input(
                f"telemetry/resources/{level.resource}",
                "resource_level",
                [
                    FieldIssue(
                        "",
                        "no plan yet: a measured level is compared with a "
                        "plan's prediction; the first plan starts from the "
                        "problem's levels",
                    )
                ],
                out,
            )
            return
        consumables = schedule.problem.resources.consumable
        if level.resource not in consumables:
            self._verdicts.reject_input(
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
        if not 0 <= level.at <= self._state.clock():
            self._verdicts.reject_input(
                f"telemetry/resources/{level.resource}",
                "resource_level",
                [
                    FieldIssue(
                        "at",
                        f"{level.at} is outside "
                        f"[0, now = {self._state.clock()}]: "
                        "a level is measured, never foreseen",
                    )
                ],
                out,
            )
            return
        outside = _level_outside(
            level.level,
            schedule.problem.resources.ceiling(level.resource),
            self.config.tolerance.absolute,
        )
        if outside is not None:
            # Beyond the store's range: a sensor fault, not a drift (a
            # plan replanned on 1e308 would predict it).
            self._verdicts.reject_input(
                f"telemetry/resources/{level.resource}",
                "resource_level",
                [FieldIssue("level", outside)],
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
            self._verdicts.publish(
                "drift",
                detail=f"{d.resource} measured {d.measured:g} at {at}, "
                f"plan predicted {d.predicted:g}",
            )
        )
        self._queue.add(
            QueuedChange("levels", at=at, levels={level.resource: level.level})
        )

    def _on_rejected(self, event: InputRejected, out: list[Command]) -> None:
        if event.kind == "goal":
            self._verdicts.reject_goal(event.goal_id, event.errors, out)
        else:
            self._verdicts.reject_input(
                event.key, event.kind, event.errors, out
            )

    # -- solving -------------------------------------------------------------

    # -- adopting and dispatching --------------------------------------------

    # -- status helpers ------------------------------------------------------


_STALLED = CLOCK_STALLED


def _level_outside(
    level: float, ceiling: float | None, slack: float
) -> str | None:
    """Why a measured level cannot be the store's (None: it can): not a
    finite number, below empty or above the capacity, beyond ``slack``."""
    if not math.isfinite(level):
        return f"{level} is not a finite level"
    top = f"{ceiling:g}" if ceiling is not None else "no capacity"
    if level < -slack or (ceiling is not None and level > ceiling + slack):
        return f"{level:g} is outside the store's range [0, {top}]"
    return None
