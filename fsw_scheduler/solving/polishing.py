"""Polishing a large part's or an unproved answer's plan by a deadline.

:func:`~fsw_scheduler.analysis.polish.polished` moves kept tasks earlier
where that is better (pure, bounded in checks); here it runs against the
caller's clock, not on a plan already at its bound, and counts what it
saved for the answer's status line.

:meth:`Polishing.shifted` goes further with CBC: every kept task may
move by a few units either way at once (:data:`SHIFT_DELTAS`), where
the polish moves one or two and the neighbourhood search frees a few
over a window. A delay gap left by the search is often such a chain of
small shifts across the horizon: the large suite's f45-h1440 of seed 59,
2 delay units above CP-SAT's optimum after 20 s, reaches it in 0.02 s
with every task within 5 units of its start; b30-h2880 of seed 57, 44
above, comes 14 units closer within 10 units (0.06 s).
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

from ..analysis.domains import Domain
from ..analysis.polish import polished
from ..model.plan import SolveStatus
from .budget import stop_at
from .improve import MIN_ROUND_S, meets
from .incumbent import checked
from .stats import stopped_on_nodes

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..model.plan import Plan
    from ..model.problem import Problem

#: Share of a replan's time left after its repair, and seconds at most,
#: that its search leaves for polishing the plan it ends with.
POLISH_SHARE = 0.15
POLISH_MAX_S = 0.3

#: Half-widths of the shift windows (:meth:`Polishing.shifted`), in time
#: units, tried in turn, each from the plan the one before left: the
#: narrow window's model is a few hundred columns and CBC proves it in
#: milliseconds; the wider one finds longer chains of moves.
SHIFT_DELTAS = (5, 10)

#: Search nodes of one shift window's CBC run: an answer stopped by time
#: is not taken (it would differ between machines), one stopped on its
#: nodes is.
SHIFT_NODES = 2_000

#: Seconds the shift windows may take from now (:func:`shift_deadline`):
#: on a large part's start plan and an unproved answer at most this; a
#: replan's past its share when less of that is left (CBC is not started
#: with less than :data:`~fsw_scheduler.solving.improve.MIN_ROUND_S`).
SHIFT_S = 0.6


def shift_deadline(last: float, end: float = 0.0) -> float:
    """When shift windows stop: :data:`SHIFT_S` from now, or at ``end``
    when that is later (a replan's share), never past ``last`` (the
    caller's whole limit)."""
    return min(max(end, time.perf_counter() + SHIFT_S), last)


class Polishing:
    """Polish plans by a deadline (:func:`~fsw_scheduler.analysis.polish.
    polished`: kept tasks moved earlier where that is better), counting
    the delay units it saves for the status line.

    Single moves the neighbourhood search had not been given the time to
    find: on the replan suite's unproved answers (seeds 34-35) a polish
    took 0.04-0.4 s and turned two of four answers worse than a fresh
    solve's into its plan or better.

    Parameters
    ----------
    problem
        The part being solved.
    domains
        Its start domains.
    deadline
        When polishing must stop (:func:`time.perf_counter`).
    bound
        A proven bound: a plan that meets it is not polished (None: no
        bound).
    """

    def __init__(
        self,
        problem: Problem,
        domains: dict[str, Domain],
        deadline: float,
        bound: float | None,
    ) -> None:
        self.problem = problem
        self.domains = domains
        self.deadline = deadline
        self.bound = bound
        self.saved = 0
        self.shift_saved = 0

    def __call__(self, plan: Plan) -> Plan:
        """``plan`` polished, or itself when it meets the bound."""
        if meets(plan, self.bound) or plan.objective is None:
            return plan
        better = polished(
            self.problem, plan, self.domains, stop=stop_at(self.deadline)
        )
        if better.objective is not None:
            self.saved += plan.objective.total - better.objective.total
        return better

    def shifted(
        self, plan: Plan, run: Callable[..., Plan], deadline: float
    ) -> Plan:
        """``plan`` improved by CBC over windows around its starts.

        For each half-width of :data:`SHIFT_DELTAS`, the same model with
        every kept task's domain cut to its start plus or minus that
        many units and the left-out tasks kept out: any solution is a
        plan of the part, so CBC's best is taken when the checker
        accepts it and it costs less. Runs are node-limited
        (:data:`SHIFT_NODES`) and stop at ``deadline``; one stopped by
        time is not taken. ``plan`` itself when it meets the bound.
        """
        for delta in SHIFT_DELTAS:
            left = deadline - time.perf_counter()
            if (
                left < MIN_ROUND_S
                or plan.objective is None
                or meets(plan, self.bound)
            ):
                break
            starts = plan.starts()
            window: dict[str, Domain] = {}
            for task in self.problem.tasks:
                domain = self.domains[task.id]
                start = starts.get(task.id)
                window[task.id] = (
                    Domain(domain.earliest, domain.earliest - 1)
                    if start is None
                    else Domain(
                        max(domain.earliest, start - delta),
                        min(domain.latest, start + delta),
                    )
                )
            # A plan the checker refuses comes back without an objective.
            answer = checked(
                self.problem,
                run(
                    self.problem,
                    warm=starts,
                    domains=window,
                    time_limit=left,
                    max_nodes=SHIFT_NODES,
                ),
            )
            said = answer.stats.solver_status if answer.stats else ""
            if (
                answer.objective is None
                or answer.objective.total >= plan.objective.total
                or not (
                    answer.status is SolveStatus.OPTIMAL
                    or stopped_on_nodes(said)
                )
            ):
                continue
            self.shift_saved += plan.objective.total - answer.objective.total
            plan = answer.replace(
                status=SolveStatus.FEASIBLE, why=(), stats=plan.stats
            )
        return plan

    def said(self) -> str:
        """What the polish saved, for the status line ("" if nothing)."""
        said = ""
        if self.saved:
            said += f"; tasks moved earlier: {self.saved} delay units saved"
        if self.shift_saved:
            said += (
                f"; tasks shifted together: {self.shift_saved} delay "
                "units saved"
            )
        return said
