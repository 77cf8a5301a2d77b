"""The replanner: what to solve next, and what to do with its answer.

One solve runs at a time: goals arriving meanwhile get ``goal_queued`` and
are merged into the next solve (at most ``max_goals_per_solve`` at once;
beyond ``max_goals_waiting`` a goal is rejected ``busy``), other triggers
are queued. When a replan the world forced (not a goal) is infeasible, a
``shed`` solve finds which mandatory tasks to keep, then a ``degraded``
solve plans without the others. A solve that yields no plan leaves the
current plan in place and the status says why.
"""

from __future__ import annotations

import hashlib
from typing import TYPE_CHECKING, Literal

import msgspec

from ..analysis.moved import why_moved
from ..errors import FieldIssue, InputError
from ..model.goal import Goal
from ..model.plan import Blocker, Moved, Plan, SolverStats, SolveStatus
from ..model.stability import Stability, rescored
from ..replan.commit import (
    commit_pins,
    moved_activities,
    pin_blockers,
    pinned_problem,
)
from ..replan.schedule import Replan, Schedule, empty_plan
from ..replan.shed import (
    shed_blockers,
    shed_tasks,
    shedding_problem,
    without_tasks,
)
from ..replan.triggers import (
    apply_failure,
    apply_goal,
    apply_levels,
)
from ..wire import topics
from ..wire.messages import (
    SolveRecord,
    SolveSummary,
)
from . import forecasts, overrun
from .events import (
    Command,
    Log,
    Publish,
    SolveDone,
    SolveFailed,
    StartExplain,
)
from .execution import degraded_detail
from .overtaken import keep_commanded
from .queue import GoalCheck
from .snapshot import PendingSolve, QueuedChange

if TYPE_CHECKING:
    from ..model.problem import Problem
    from .execution import Execution
    from .queue import SolveQueue
    from .state import EngineState
    from .verdicts import Verdicts


def problem_hash(problem: Problem) -> str:
    """SHA-256 of the compact JSON of ``problem`` (solve records)."""
    return hashlib.sha256(msgspec.json.encode(problem)).hexdigest()


def _merge_goals(goals: list[Goal]) -> Goal:
    """One goal carrying every task and precedence of ``goals``."""
    if len(goals) == 1:
        return goals[0]
    return Goal(
        goal_id="+".join(g.goal_id for g in goals),
        tasks=tuple(t for g in goals for t in g.tasks),
        precedences=tuple(p for g in goals for p in g.precedences),
    )


def _no_plan_reason(plan: Plan) -> str:
    if plan.status is SolveStatus.INFEASIBLE:
        blocked = ", ".join(
            f"{b.task} ({b.cause}: {b.detail})" for b in plan.why
        )
        return "infeasible" + (f": {blocked}" if blocked else "")
    return f"{plan.status.value}: no plan found within the time limit"


class Replanner:
    """Start solves from the queue and adopt what they give.

    See the module docstring for the policy. The queue's bookkeeping is
    :class:`~fsw_scheduler.engine.queue.SolveQueue`; adopting a plan and
    dispatching it is :class:`~fsw_scheduler.engine.execution.Execution`.

    Parameters
    ----------
    state
        The engine's state.
    queue
        What waits for a solve, and the solve in flight.
    verdicts
        Statuses and verdicts.
    execution
        Adopts plans.
    """

    def __init__(
        self,
        state: EngineState,
        queue: SolveQueue,
        verdicts: Verdicts,
        execution: Execution,
    ) -> None:
        self._state = state
        self._queue = queue
        self._verdicts = verdicts
        self._execution = execution

    def on_solve_done(self, event: SolveDone, out: list[Command]) -> None:
        """Adopt a solved plan, or go on to shedding, or keep the old one."""
        state = self._state
        pending = self._queue.finish(event.solve_id)
        if pending is None:
            out.append(Log("warning", f"stray solve {event.solve_id}"))
            return
        plan = event.plan
        stats = plan.stats or SolverStats(solver="?")
        state.count(solves=state.counters.solves + 1)
        adopted = plan.status.has_plan and pending.stage != "shed"
        reason = "" if plan.status.has_plan else _no_plan_reason(plan)
        state.last_solve = SolveSummary(
            solve_id=event.solve_id,
            trigger=pending.trigger,
            status=plan.status,
            objective=plan.objective,
            wall_s=stats.wall_s,
            adopted=adopted,
            reason=reason,
        )
        out.append(self.solve_record(pending, plan))
        if (
            plan.status is SolveStatus.INFEASIBLE
            and pending.stage == "plan"
            and pending.pins
        ):
            # The commit window left no plan: solve without it.
            self.release_pins(pending, plan, out)
            return
        if (
            plan.status is SolveStatus.INFEASIBLE
            and pending.stage == "plan"
            and pending.replan is not None
            and not pending.goals
        ):
            # The world, not a goal, made the plan impossible: do not keep
            # flying it; find the best plan still possible.
            self.start_shedding(pending, plan, out)
            return
        if pending.stage == "shed" and plan.status.has_plan:
            self.start_degraded(pending, plan, out)
            return
        if adopted and pending.replan is not None:
            kept, reason = self.keep_commanded(pending, plan, out)
            adopted = kept is not None
            if kept is not None and kept is not plan:
                # Put back where commanded: scored again, moves included.
                kept = rescored(pending.problem, kept, self.stability(pending))
            plan = kept or plan
        if not adopted:
            self.solve_without_plan(pending, reason, out)
            return
        if pending.stage == "degraded":
            assert pending.replan is not None
            assert pending.infeasible is not None
            shed = shed_blockers(pending.replan.removed, pending.infeasible)
            plan = plan.replace(
                status=SolveStatus.DEGRADED, why=(*shed, *plan.why)
            )
        broken = pin_blockers(
            pending.released,
            plan,
            pending.problem.start,
            state.config.commit_window,
        )
        if broken:
            plan = plan.replace(
                status=SolveStatus.DEGRADED, why=(*broken, *plan.why)
            )
        moved = self.count_moved(pending, plan, broken)
        if pending.replan is None:
            assert state.plan_message is None
            state.schedule = Schedule.begin(pending.problem, plan)
            self._execution.adopt(
                plan, pending.trigger, pending.goals, (), out, moved=moved
            )
        else:
            state.schedule = overrun.carried(
                state, state.schedule, pending.replan.adopt(plan)
            )
            self._execution.adopt(
                plan,
                pending.trigger,
                pending.goals,
                pending.replan.removed,
                out,
                readded=pending.replan.readded,
                moved=moved,
            )
        # Forecasts that came during the solve apply to what it gave.
        forecasts.after_adoption(state, self._queue, out)
        if pending.stage == "degraded" or broken:
            self.raise_alarm(plan, out)
        if (
            state.config.explain_after_plan
            and plan.unscheduled
            and state.plan_id is not None
        ):
            out.append(
                StartExplain(
                    event.solve_id, state.plan_id, pending.problem, plan
                )
            )
        if (
            pending.dispatches_at_start != state.counters.dispatches
            and state.clock() > pending.started_at
        ):
            # The old plan dispatched while this one was being computed for
            # an earlier time: replan from what really happened.
            self._queue.add(QueuedChange("levels", at=state.clock()))

    def count_moved(
        self, pending: PendingSolve, plan: Plan, broken: tuple[Blocker, ...]
    ) -> tuple[Moved, ...] | msgspec.UnsetType:
        """What ``plan`` moved of the plan it replaces, also counted in
        ``last_solve.moved`` (UNSET on a node that does not report moves:
        its plans and statuses stay those of a node without them)."""
        state = self._state
        if not state.config.reports_moves:
            return msgspec.UNSET
        reasons = why_moved(pending.problem, plan, pending.previous)
        reasons.update({b.task: b.detail for b in broken})
        moved = moved_activities(pending.previous, plan, reasons)
        if state.last_solve is not None:
            state.last_solve = msgspec.structs.replace(
                state.last_solve, moved=len(moved)
            )
        return moved

    def stability(self, pending: PendingSolve) -> Stability:
        """The move term ``pending``'s solve had (mode off: none)."""
        config = self._state.config
        return Stability(
            previous=dict(pending.previous),
            mode=config.stability,  # type: ignore[arg-type]
            move_cost=config.move_cost,
        )

    def release_pins(
        self, pending: PendingSolve, infeasible: Plan, out: list[Command]
    ) -> None:
        """Solve the replan again without its commit-window pins: keeping
        them left no plan (the degraded path; the plan names each pin it
        breaks)."""
        assert pending.replan is not None
        out.append(
            Log(
                "warning",
                f"solve {pending.solve_id} ({pending.trigger}) is "
                f"{_no_plan_reason(infeasible)} with the commit window's "
                f"pins ({', '.join(pending.pins)}); solving without them",
            )
        )
        self.start_solve(
            pending.trigger,
            pending.replan.problem,
            pending.replan,
            pending.warm,
            pending.goals,
            out,
            previous=pending.previous,
            released=pending.pins,
        )

    def planned_starts(self, replan: Replan) -> dict[str, int]:
        """Starts of the activities planned and not yet dispatched in the
        plan in force that ``replan`` keeps: what it may move. A task the
        rules removed is gone, whatever a goal now names with its id.
        Empty on a node that neither pins nor reports moves."""
        state = self._state
        schedule = state.schedule
        if schedule is None or not state.config.reports_moves:
            return {}
        lifecycle = state.dispatches.lifecycle
        gone = {r.task for r in replan.removed} | set(schedule.continuing)
        live = {t.id for t in replan.problem.tasks}
        return {
            a.task: a.start
            for a in schedule.plan.activities
            if lifecycle.get(a.task, "planned") == "planned"
            and a.task not in gone
            and a.task in live
        }

    def keep_commanded(
        self, pending: PendingSolve, plan: Plan, out: list[Command]
    ) -> tuple[Plan | None, str]:
        """The plan with what was dispatched while it was computed kept
        where it was commanded (:mod:`.overtaken`), or None and why."""
        assert pending.replan is not None
        continuing = set(pending.replan.continuing)
        dispatches = self._state.dispatches
        # Commanded after the problem was posed: inside its window (what
        # was commanded before is pinned, or was let go by the rules).
        commanded = {
            task: span
            for task, span in dispatches.sent.items()
            if task not in continuing
            and span[0] >= pending.problem.start
            and dispatches.lifecycle.get(task) in ("dispatched", "running")
        }
        steady = {
            t.id for t in pending.problem.tasks if t.preemption == "none"
        }
        if self._state.config.cancel_timeout is None:
            # Journals recorded before cancels: a preemptible activity
            # was moved (and commanded again) without a word.
            commanded = {t: s for t, s in commanded.items() if t in steady}
        kept, moved = keep_commanded(pending.problem, plan, commanded)
        if kept is None and set(commanded) - steady:
            # No plan keeps every command: the preemptible ones may move
            # (the rules allow it), each with a cancel first.
            kept, moved = keep_commanded(
                pending.problem,
                plan,
                {t: s for t, s in commanded.items() if t in steady},
            )
        if not moved:
            return plan, ""
        if kept is None:
            return None, (
                f"it moves {', '.join(moved)}, commanded while it was "
                "computed, and no plan keeps them there"
            )
        out.append(
            Log(
                "warning",
                f"solve {pending.solve_id}: {', '.join(moved)} commanded "
                "while it was computed; kept where commanded",
            )
        )
        return kept, ""

    def on_solve_failed(self, event: SolveFailed, out: list[Command]) -> None:
        """A solve that raised: keep the current plan and say why."""
        state = self._state
        pending = self._queue.finish(event.solve_id)
        if pending is None:
            return
        state.count(
            solves=state.counters.solves + 1,
            solves_failed=state.counters.solves_failed + 1,
        )
        state.last_solve = SolveSummary(
            solve_id=event.solve_id,
            trigger=pending.trigger,
            status=SolveStatus.UNKNOWN,
            reason=event.error,
        )
        self.solve_without_plan(pending, event.error, out)

    def replan_time(self, schedule: Schedule) -> int:
        """The time a replan started now governs from.

        ``now + replan_lead``: until its plan is ready, the current one
        keeps dispatching. A goal is checked on arrival at this same time,
        so that its solve, started at once, reuses that rule pass.
        """
        return max(
            self._state.clock() + self._state.config.replan_lead,
            schedule.problem.start,
        )

    def live_checked(self, replan: Replan) -> Replan:
        """``replan``, unless it would hold more than ``max_live_tasks``.

        Raises
        ------
        InputError
            The replan holds too many live tasks.
        """
        limit = self._state.config.max_live_tasks
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

    def check_goal(self, schedule: Schedule, goal: Goal) -> Replan:
        """The rule pass of ``goal`` on ``schedule`` at :meth:`replan_time`,
        kept for its solve.

        Raises
        ------
        InputError
            The goal does not fit the live state (every reason named).
        """
        now = self.replan_time(schedule)
        replan = self.live_checked(apply_goal(schedule, goal, now))
        self._queue.remember(GoalCheck(schedule, now, goal, replan))
        return replan

    def start_initial(self, out: list[Command]) -> None:
        """Solve the initial problem (re-based to now if the clock is past
        its start)."""
        state = self._state
        problem = state.unsolved_initial
        assert problem is not None and state.now is not None
        state.unsolved_initial = None
        if state.now > problem.start:
            problem = problem.replace(start=state.now)
        if not problem.tasks:
            state.schedule = Schedule.begin(problem, empty_plan())
            self._execution.adopt(empty_plan(), "initial", (), (), out)
            return
        self.start_solve("initial", problem, None, None, (), out)

    def start_queued(self, out: list[Command]) -> None:
        """Start the next solve: failures first, then goals, then levels."""
        state, queue = self._state, self._queue
        while queue.changes and not queue.busy:
            schedule = state.schedule
            if schedule is None:
                return
            now = self.replan_time(schedule)
            failures = [c for c in queue.changes if c.kind == "failure"]
            goals = [c for c in queue.changes if c.kind == "goal"][
                : state.config.max_goals_per_solve
            ]
            if failures:
                change = failures[0]
                queue.remove(change)
                if change.task not in {t.id for t in schedule.problem.tasks}:
                    # Already handled by an earlier failure replan.
                    continue
                try:
                    replan = apply_failure(
                        schedule, change.task, min(change.at, now), now=now
                    )
                except InputError as error:
                    # The report was taken, and now cannot be acted on:
                    # its sender hears why (never a log line alone).
                    self._verdicts.reject_input(
                        f"telemetry/activities/{change.task}",
                        "activity_report",
                        error.issues,
                        out,
                    )
                    continue
                self.start_solve(
                    "failure", replan.problem, replan, replan.warm, (), out
                )
            elif goals:
                self.start_goals(schedule, goals, now, out)
            else:
                levels: dict[str, float] = {}
                at = now
                for change in queue.changes:
                    levels.update(change.levels)
                    at = min(at, change.at)
                trigger = "drift" if levels else "stale"
                for named in (
                    "horizon",
                    "missed",
                    "cancelled",
                    "merged",
                    "forecast",
                    "early_completion",
                    overrun.OVERRUN,
                    overrun.LATE_COMPLETION,
                ):
                    if not levels and any(
                        c.trigger == named for c in queue.changes
                    ):
                        trigger = named
                queue.clear()
                try:
                    replan = apply_levels(
                        schedule, levels, now, at=at, keep_running=True
                    )
                except InputError as error:
                    self._reject_levels(levels, error, out)
                    continue
                self.start_solve(
                    trigger, replan.problem, replan, replan.warm, (), out
                )

    def _reject_levels(
        self,
        levels: dict[str, float],
        error: InputError,
        out: list[Command],
    ) -> None:
        """Answer each level a replan could not use (``input_rejected``
        on its key, with the reasons about it), or log why a replan with
        no level failed."""
        if not levels:
            out.append(Log("warning", f"replan skipped: {error}"))
            return
        for name in sorted(levels):
            mine = [
                FieldIssue("level", issue.reason)
                if issue.path == f"levels.{name}"
                else issue
                for issue in error.issues
                if not issue.path.startswith("levels.")
                or issue.path == f"levels.{name}"
            ]
            self._verdicts.reject_input(
                f"telemetry/resources/{name}",
                "resource_level",
                mine or error.issues,
                out,
            )

    def start_goals(
        self,
        schedule: Schedule,
        changes: list[QueuedChange],
        now: int,
        out: list[Command],
    ) -> None:
        """Coalesce queued goals into one replan; reject any that clash.

        One rule pass per goal: each goal is added to those accepted
        before it, and the pass of the last one accepted is the replan.
        """
        accepted: list[Goal] = []
        replan: Replan | None = None
        memo = self._queue.recall()
        for change in changes:
            self._queue.remove(change)
            assert change.goal is not None
            if (
                not accepted
                and memo is not None
                and memo.answers(schedule, now, change.goal)
            ):
                # Checked on arrival against this very schedule and time.
                replan = memo.replan
                accepted.append(change.goal)
                continue
            candidate = _merge_goals([*accepted, change.goal])
            try:
                replan = self.live_checked(
                    apply_goal(schedule, candidate, now)
                )
            except InputError as error:
                self._verdicts.reject_goal(
                    change.goal.goal_id, error.issues, out
                )
                continue
            accepted.append(change.goal)
        if replan is None:
            return
        self.start_solve(
            "goal",
            replan.problem,
            replan,
            replan.warm,
            tuple(g.goal_id for g in accepted),
            out,
        )

    def start_shedding(
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
        self.start_solve(
            pending.trigger,
            shedding_problem(pending.replan.problem),
            pending.replan,
            None,
            (),
            out,
            stage="shed",
            infeasible=infeasible,
            previous=pending.previous,
            released=pending.released,
        )

    def start_degraded(
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
        self.start_solve(
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
            previous=pending.previous,
            released=pending.released,
        )

    def raise_alarm(self, plan: Plan, out: list[Command]) -> None:
        """Say loudly that mandatory tasks were dropped, and why."""
        out.append(Log("error", degraded_detail(self._state.plan_id, plan)))
        out.append(Publish(topics.STATUS, self._verdicts.status("alarm")))

    def start_solve(
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
        previous: dict[str, int] | None = None,
        released: dict[str, int] | None = None,
    ) -> None:
        """Ask for a solve of ``problem`` (or adopt the empty plan at
        once when a replan leaves nothing to schedule).

        ``previous``: the starts the replan may move (default: those of
        the plan in force, :meth:`planned_starts`). An ordinary replan
        keeps those inside the commit window (``pins``), unless
        ``released`` says they were given up already.
        """
        state = self._state
        if previous is None:
            previous = self.planned_starts(replan) if replan else {}
        if replan is not None and not problem.tasks:
            # Nothing left to schedule: adopt the empty plan without solving.
            state.schedule = replan.adopt(empty_plan())
            self._execution.adopt(
                empty_plan(),
                trigger,
                goals,
                replan.removed,
                out,
                # An empty plan moves nothing.
                moved=() if state.config.reports_moves else msgspec.UNSET,
            )
            return
        if (
            stage == "plan"
            and replan is not None
            and problem is replan.problem
        ):
            # Overrunning activities run on as long again (see .overrun).
            longer = overrun.extended(state, replan)
            if longer is not replan:
                replan, problem, warm = longer, longer.problem, longer.warm
        pins: dict[str, int] = {}
        if stage == "plan" and replan is not None and released is None:
            pins = commit_pins(problem, previous, state.config.commit_window)
            problem = pinned_problem(problem, pins)
        solve_id = self._queue.next_id()
        self._queue.begin(
            PendingSolve(
                solve_id=solve_id,
                trigger=trigger,
                problem=problem,
                replan=replan,
                goals=goals,
                started_at=state.clock(),
                dispatches_at_start=state.counters.dispatches,
                stage=stage,
                infeasible=infeasible,
                warm=warm,
                explain=stage == "shed",
                previous=previous,
                pins=pins,
                released=released or {},
            )
        )
        out.append(
            Log(
                "info",
                f"solve {solve_id} ({trigger}"
                f"{'' if stage == 'plan' else ', ' + stage}): "
                f"{problem.num_tasks} tasks over "
                f"[{problem.start}, {problem.end})",
            )
        )
        pending = self._queue.pending_solve()
        assert pending is not None
        out.append(pending)

    def solve_without_plan(
        self, pending: PendingSolve, reason: str, out: list[Command]
    ) -> None:
        """Keep the last good plan; say why; reject goals that caused it."""
        state = self._state
        state.count(solves_failed=state.counters.solves_failed + 1)
        detail = (
            f"solve {pending.solve_id} ({pending.trigger}) gave no plan: "
            f"{reason}; keeping plan {state.plan_id}"
        )
        state.set_health("degraded", detail)
        out.append(Log("warning", detail))
        for goal_id in pending.goals:
            self._verdicts.reject_goal(
                goal_id,
                [FieldIssue("", f"no plan with this goal: {reason}")],
                out,
            )
        if not pending.goals:
            out.append(self._verdicts.publish("solve_failed"))

    def solve_record(self, pending: PendingSolve, plan: Plan) -> Publish:
        """The ``scheduler/solves`` record of a finished solve."""
        state = self._state
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
                (state.plan_id or 0) + 1
                if plan.status.has_plan and pending.stage != "shed"
                else None
            ),
            num_variables=stats.num_variables,
            num_constraints=stats.num_constraints,
            build_s=stats.build_s,
            solve_s=stats.solve_s,
            wall_s=stats.wall_s,
            inputs_seen=state.inputs,
            result=plan,
            previous=pending.previous
            if state.config.stability != "off"
            else {},
        )
        return Publish(topics.SOLVES, record)
