"""The solve queue: one solve at a time, goals coalesced, shed then degrade.

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

from ..errors import FieldIssue, InputError
from ..model.goal import Goal
from ..model.plan import Plan, SolverStats, SolveStatus
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
from .base import EngineState, degraded_detail
from .events import (
    Command,
    Log,
    Publish,
    SolveDone,
    SolveFailed,
    StartExplain,
)
from .overtaken import keep_commanded
from .snapshot import PendingSolve, QueuedChange

if TYPE_CHECKING:
    from ..model.problem import Problem


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


class SolveQueue(EngineState):
    """The engine's solve queue (see the module docstring)."""

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
        if adopted and pending.replan is not None:
            kept, reason = self._keep_commanded(pending, plan, out)
            adopted = kept is not None
            plan = kept or plan
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

    def _keep_commanded(
        self, pending: PendingSolve, plan: Plan, out: list[Command]
    ) -> tuple[Plan | None, str]:
        """The plan with what was dispatched while it was computed kept
        where it was commanded (:mod:`.overtaken`), or None and why."""
        assert pending.replan is not None
        continuing = set(pending.replan.continuing)
        dispatches = self._dispatches
        # Commanded after the problem was posed: inside its window (what
        # was commanded before is pinned, or was let go by the rules), and
        # not preemptible (a replan may move those: that is preemption).
        steady = {
            t.id for t in pending.problem.tasks if t.preemption == "none"
        }
        commanded = {
            task: span
            for task, span in dispatches.sent.items()
            if task in steady
            and task not in continuing
            and span[0] >= pending.problem.start
            and dispatches.lifecycle.get(task) in ("dispatched", "running")
        }
        kept, moved = keep_commanded(pending.problem, plan, commanded)
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
                for named in ("horizon", "missed"):
                    if not levels and any(
                        c.trigger == named for c in self._queue
                    ):
                        trigger = named
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
        """Coalesce queued goals into one replan; reject any that clash.

        One rule pass per goal: each goal is added to those accepted
        before it, and the pass of the last one accepted is the replan.
        """
        accepted: list[Goal] = []
        replan: Replan | None = None
        memo, self._goal_checked = self._goal_checked, None
        for change in changes:
            self._queue.remove(change)
            assert change.goal is not None
            if (
                not accepted
                and memo is not None
                and memo[0] is schedule
                and memo[1] == now
                and memo[2] is change.goal
            ):
                # Checked on arrival against this very schedule and time.
                replan = memo[3]
                accepted.append(change.goal)
                continue
            candidate = _merge_goals([*accepted, change.goal])
            try:
                replan = self._live_checked(
                    apply_goal(schedule, candidate, now)
                )
            except InputError as error:
                self._reject_goal(change.goal.goal_id, error.issues, out)
                continue
            accepted.append(change.goal)
        if replan is None:
            return
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
        out.append(Log("error", degraded_detail(self.plan_id, plan)))
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
