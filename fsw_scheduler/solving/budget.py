"""Every time budget of a solve, in one small policy object.

A solve on board answers within a limit; the pieces that share it are
set here and nowhere else: the start heuristic's share, when and how long
neighbourhood search runs, how long explanations may take together, the
floor below which no solve is started, and the margin a node keeps to
publish before a goal's response deadline. :func:`fsw_scheduler.solving.
solve.solve`, the node's solve policy (:mod:`fsw_scheduler.runtime.policy`)
and replay all read the one :data:`BUDGET`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..model.plan import Plan, SolveStatus

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    from ..model.problem import Problem


@dataclass(frozen=True)
class SolveBudget:
    """How a solve's time is shared out.

    Attributes
    ----------
    greedy_share
        Share of the time limit the start heuristic may take (its trivial
        plan, the forced tasks alone, is always completed).
    lns_min_tasks
        From this many tasks on, a solve under a time limit improves the
        start plan by neighbourhood search
        (:mod:`fsw_scheduler.solving.improve`) instead of handing the whole
        model to the solver.
    lns_margin_s
        Seconds of the limit left when the neighbourhood search stops.
    lns_share
        Share of the time left after the start plan that the
        neighbourhood search may take before the whole model, narrowed
        around its incumbent, gets the rest (to prove it, improve it or
        raise the bound); the search stops sooner when its incumbent
        meets the kept-set bound or a sweep of its largest
        neighbourhoods finds nothing, and the whole model then gets what
        is left. All of it by default: with half, on 17 problems of 30-60
        tasks (fresh seeds 7000 and 9000, 20 s), the whole model improved
        one plan by a few delay units and proved none, while the search,
        cut short, left out more on three (40 tasks: 8 improvements with
        the whole time, 3 with half).
    explain_budget_s
        Seconds all explanation solves may take together when the solve
        itself has no time limit (with one, they share what it left).
    min_solve_s
        No solve is started with less than this left: an explanation
        answers ``unknown`` instead, and a deadline-cut solve gets at least
        this long (its start plan).
    publish_margin_s
        Seconds of a goal's response deadline kept for what a solve's
        limit does not cover: the start plan of a large merged problem,
        reading CBC's answer back, publishing (the soak's p99 overran
        0.2 s by 0.3 s).
    replan_share
        Share of the time limit a solve from a plan in force (a replan:
        ``warm`` given) with a large part may take, at least
        :attr:`replan_min_s`: large parts are repaired and searched
        around what changed (:mod:`fsw_scheduler.solving.repair`). A
        replan pays for what changed, not for a whole fresh solve. A
        replan whose parts are all small
        (under :attr:`lns_min_tasks` tasks) has the whole limit: a part
        its share left unproved was solved again from its plan, and that
        took longer than one solve; but a small part whose narrowed model
        is too long for CBC's root (:data:`~.rounds.LONG_COLUMNS` start
        times) has this share of its own limit (see
        :func:`~.solve._solve_whole`).
    replan_min_s
        The least limit of a replan (when the caller's allows it).
    min_start_s
        The least time a part that handed its share back unproved (CBC
        not started in it) is given again from what the other parts left
        (:func:`~fsw_scheduler.solving.solve.solve`'s second pass): CBC
        starts on a small part's model with it (its stop margin and
        minimum are about 0.1 s on a 15-task model, 0.35 s on a large one:
        :func:`~fsw_scheduler.solving.ilp.cbc.stop_margin`) and proves
        most such parts in 0.01-0.1 s. With less left, the part gets
        what is left when that is at least twice its first share (a
        tiny part under a 0.3 s limit).
    proof_share
        Share of the limit the cheap infeasibility proofs
        (:func:`~fsw_scheduler.analysis.proofs.infeasibility`) may take
        before the solve goes on without them (the solver then decides):
        their interval sweeps grow with the cube of the tasks every plan
        must hold (0.14 s on 300 mandatory tasks over H = 2,880).
    min_part_s
        The least share of the limit an independent part of a problem
        gets when the limit has room for it (:meth:`part_share`): enough
        for CBC to start on a small model and prove it, and on a large one
        (CBC's stop margin grows to 0.3 s with the model,
        :func:`~fsw_scheduler.solving.ilp.cbc.stop_margin`, beside the
        model's reading margin and ``MIN_CBC_S``); a part that gets too
        little for CBC keeps its start plan unproved.
    """

    greedy_share: float = 0.4
    lns_min_tasks: int = 30
    lns_margin_s: float = 0.2
    lns_share: float = 1.0
    explain_budget_s: float = 10.0
    min_solve_s: float = 0.05
    publish_margin_s: float = 1.0
    min_part_s: float = 1.0
    proof_share: float = 0.2
    min_start_s: float = 0.5
    replan_share: float = 0.2
    replan_min_s: float = 1.5

    def budgeted(
        self, run: Callable[..., Plan], budget_s: float
    ) -> Callable[[Problem], Plan]:
        """``run`` sharing one time budget of ``budget_s`` over its calls.

        Explanations take several solves per left-out task; on board they
        must not hold a new plan back for long. Once the budget is spent, a
        call answers ``unknown`` at once and the task is reported
        ``not_analysed``. ``run`` is called as ``run(problem,
        time_limit=left)``.
        """
        deadline = time.monotonic() + budget_s

        def attempt(problem: Problem) -> Plan:
            left = deadline - time.monotonic()
            if left <= self.min_solve_s:
                return Plan(
                    status=SolveStatus.UNKNOWN,
                    objective=None,
                    unscheduled=tuple(t.id for t in problem.tasks),
                )
            return run(problem, time_limit=left)

        return attempt

    def part_share(self, left_s: float, weights: Sequence[float]) -> float:
        """The limit of the first of the parts still to solve.

        Parameters
        ----------
        left_s
            Seconds left of the whole solve's limit.
        weights
            The sizes of the parts still to solve (their start times), the
            one to solve now first.

        Returns
        -------
        float
            Its share of ``left_s`` by size, raised to :attr:`min_part_s`
            when an equal split of ``left_s`` among the parts still to
            solve allows it (else to that equal split): a small part that
            needs CBC is never given less than CBC needs to start only
            because the other parts are large. A part done early leaves
            the rest of its share to the parts after it.
        """
        if left_s <= 0 or not weights:
            return 0.0
        share = left_s * weights[0] / sum(weights)
        floor = min(self.min_part_s, left_s / len(weights))
        return max(share, floor)

    def replan_limit(self, time_limit: float) -> float:
        """The limit of a solve from a plan in force under ``time_limit``
        (see :attr:`replan_share`)."""
        return min(
            time_limit, max(self.replan_min_s, self.replan_share * time_limit)
        )

    def deadline_limit(
        self, left_s: float, batches: int, time_limit: float | None
    ) -> float | None:
        """A solve's limit cut to the response deadline of its goals.

        Parameters
        ----------
        left_s
            Seconds left until the oldest goal's deadline.
        batches
            Solves queued behind this one: each batch gets an equal share
            of what is left.
        time_limit
            The configured limit (None: none).

        Returns
        -------
        float or None
            The configured limit when it is already the shorter, else the
            cut one (never below :attr:`min_solve_s`).
        """
        limit = max(
            (left_s - self.publish_margin_s) / (1 + batches), self.min_solve_s
        )
        if time_limit is not None and time_limit <= limit:
            return time_limit
        return limit


#: The budgets every solve uses.
BUDGET = SolveBudget()


def stop_at(end: float) -> Callable[[], bool]:
    """A ``stop`` callback for the pure heuristics (they read no clock):
    true once :func:`time.perf_counter` passes ``end``."""
    return lambda: time.perf_counter() > end


def stop_share(deadline: float, share: float) -> Callable[[], bool]:
    """A ``stop`` at ``share`` of the time left now before ``deadline``."""
    now = time.perf_counter()
    return stop_at(now + share * (deadline - now))


#: Share of the time left that a kept-set search
#: (:func:`~fsw_scheduler.analysis.bounds.kept_set_plan`) may take: its
#: nodes are bounded in count, not in seconds (a second on 150 tasks over
#: H = 10,000, which a 1 s limit does not have).
BOUND_SHARE = 0.5


def stop_within(
    began: float, time_limit: float | None, share: float = BOUND_SHARE
) -> Callable[[], bool] | None:
    """A ``stop`` at ``share`` of what is left now of ``time_limit``
    counted from ``began``; None without a limit."""
    if time_limit is None:
        return None
    return stop_share(began + time_limit, share)
