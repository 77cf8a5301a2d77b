"""The solve queue: what waits for a solve, the solve in flight, its ids.

:class:`SolveQueue` is bookkeeping only: it holds the queued changes
(goals, failures, measured levels), the one solve in flight and the
counter that numbers solves, and it remembers the rule pass a goal got on
arrival (:class:`GoalCheck`) so that starting its solve at once does not
run the same pass again. What to solve and when is decided by
:class:`~fsw_scheduler.engine.solves.Replanner`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from .events import StartSolve

if TYPE_CHECKING:
    from ..model.goal import Goal
    from ..replan.schedule import Replan, Schedule
    from .snapshot import PendingSolve, QueuedChange


@dataclass(frozen=True)
class GoalCheck:
    """The rule pass of one goal, with what it depends on.

    A pass depends on the schedule it was applied to, the time it was
    applied at and the goal: the same three give the same replan.
    Schedules and goals are immutable, so identity is a sound (and
    cheap) test of "the same". A memo, not state: a snapshot leaves it
    out and a restored engine makes the pass again.
    """

    schedule: Schedule
    now: int
    goal: Goal
    replan: Replan

    def answers(self, schedule: Schedule, now: int, goal: Goal) -> bool:
        """True when this pass is the one ``(schedule, now, goal)`` gets."""
        return (
            self.schedule is schedule and self.now == now and self.goal is goal
        )


class SolveQueue:
    """Queued changes, the solve in flight and solve ids.

    Parameters
    ----------
    changes
        Queued changes, oldest first.
    pending
        The solve in flight, if any.
    solve_id
        The id of the last solve started.
    """

    def __init__(
        self,
        changes: tuple[QueuedChange, ...] = (),
        pending: PendingSolve | None = None,
        solve_id: int = 0,
    ) -> None:
        self.changes: list[QueuedChange] = list(changes)
        self.pending = pending
        self.solve_id = solve_id
        self.goal_check: GoalCheck | None = None

    @property
    def busy(self) -> bool:
        """True while a solve is in flight."""
        return self.pending is not None

    @property
    def pending_goals(self) -> tuple[str, ...]:
        """Goal ids of the solve in flight (empty when none)."""
        return self.pending.goals if self.pending is not None else ()

    @property
    def goals_waiting(self) -> int:
        """Goals accepted for processing and waiting for a solve."""
        return sum(1 for c in self.changes if c.kind == "goal")

    def has_trigger(self, trigger: str) -> bool:
        """True when a queued change names ``trigger``."""
        return any(c.trigger == trigger for c in self.changes)

    def add(self, change: QueuedChange) -> None:
        """Queue ``change`` behind the others."""
        self.changes.append(change)

    def add_once(self, change: QueuedChange) -> None:
        """Queue ``change`` unless a queued change names its trigger
        already (one replan for an early completion, a forecast...: the
        second would solve the same state again)."""
        if not self.has_trigger(change.trigger):
            self.add(change)

    def remove(self, change: QueuedChange) -> None:
        """Take ``change`` out of the queue (it is being solved)."""
        self.changes.remove(change)

    def clear(self) -> None:
        """Take every queued change out (one solve covers them all)."""
        self.changes.clear()

    def next_id(self) -> int:
        """A new solve id."""
        self.solve_id += 1
        return self.solve_id

    def begin(self, pending: PendingSolve) -> None:
        """Record ``pending`` as the solve in flight."""
        assert self.pending is None, "one solve at a time"
        self.pending = pending

    def finish(self, solve_id: int) -> PendingSolve | None:
        """End the solve in flight if it is ``solve_id`` (None: stray)."""
        pending = self.pending
        if pending is None or pending.solve_id != solve_id:
            return None
        self.pending = None
        return pending

    def remember(self, check: GoalCheck) -> None:
        """Keep the pass a goal got on arrival for its solve."""
        self.goal_check = check

    def recall(self) -> GoalCheck | None:
        """The pass kept by :meth:`remember`, once: the memo is spent."""
        check, self.goal_check = self.goal_check, None
        return check

    def pending_solve(self) -> StartSolve | None:
        """The solve in flight, as the command that asked for it.

        A node that resumes (or takes over) while a solve was running asks
        for it again: the same input gives the same plan.
        """
        pending = self.pending
        if pending is None:
            return None
        return StartSolve(
            pending.solve_id,
            pending.trigger,
            pending.problem,
            pending.warm,
            explain=pending.explain,
            previous=pending.previous,
        )
