"""The engine's settings: limits, tolerances and time budgets.

Built from the node's settings by
:func:`fsw_scheduler.runtime.policy.engine_config`, and recorded in the
journal so that replay runs the same engine.
"""

from __future__ import annotations

import msgspec

from ..replan.triggers import (
    Tolerance,
)

#: Execution reports held at most, waiting for the clock to reach them;
#: one more is rejected (a bounded state, whatever an executor sends).
HELD_REPORTS = 64


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
    max_goal_ids
        Goal ids the ledger remembers once their goal was accepted (the
        oldest leave first; the ids of queued goals always stay): within
        them a goal id is accepted at most once, whatever is re-sent.
    reports_need_dispatch
        Reject an execution report that does not name the ``dispatch_id``
        it answers (a report always must answer a dispatch of its task).
    report_ahead
        Units an execution report's ``at`` may lie ahead of the clock: the
        executor saw a clock message this node has not processed yet (two
        publishers, no order between them). Such a report is held, at most
        :data:`HELD_REPORTS` of them, and applied at the first step whose
        time reaches ``at``; one further ahead is rejected. 0 rejects
        every report ahead (journals recorded before held reports).
    cancel_timeout
        Units a cancel waits for its answer (``cancelled``, ``completed``
        or ``failed``) before its activity turns ``unknown``: taken as
        having run, and never commanded again. None: a commanded activity
        a replan moves is planned again without a cancel (journals
        recorded before cancels existed).
    commit_window
        Units from a replan's time in which every planned activity keeps
        its start (0: none); see :mod:`fsw_scheduler.replan.commit`.
    stability, move_cost
        How a replan weighs moving a previously planned activity (``off``,
        ``moves`` at ``move_cost`` each, ``lexicographic``).
    early_completion_gain
        Units a ``completed`` report must come before the end of its
        dispatch to replan at once (0: never).
    late_completion
        ``off``: the plan is flown by the clock. ``push``: what depends on
        an activity waits for it, and an overrun or a late completion
        replans (:mod:`fsw_scheduler.engine.overrun`).
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
    max_goal_ids: int = 1024
    reports_need_dispatch: bool = False
    report_ahead: int = 0
    cancel_timeout: int | None = None
    commit_window: int = 0
    stability: str = "off"
    move_cost: int = 5
    early_completion_gain: int = 0
    late_completion: str = "off"

    @property
    def reports_moves(self) -> bool:
        """Whether plans say what they moved (``moved``, ``last_solve.
        moved``): with a commit window or a stability term. Off, plans
        and statuses are exactly those of a node without these settings,
        so that recordings of one replay identical on the other."""
        return self.commit_window > 0 or self.stability != "off"
