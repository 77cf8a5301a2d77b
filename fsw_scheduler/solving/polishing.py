"""Polishing a large part's or an unproved answer's plan by a deadline.

:func:`~fsw_scheduler.analysis.polish.polished` moves kept tasks earlier
where that is better (pure, bounded in checks); here it runs against the
caller's clock, not on a plan already at its bound, and counts what it
saved for the answer's status line.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..analysis.polish import polished
from .budget import stop_at
from .improve import meets

if TYPE_CHECKING:
    from ..analysis.domains import Domain
    from ..model.plan import Plan
    from ..model.problem import Problem

#: Share of a replan's time left after its repair, and seconds at most,
#: that its search leaves for polishing the plan it ends with.
POLISH_SHARE = 0.15
POLISH_MAX_S = 0.3


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

    def said(self) -> str:
        """What the polish saved, for the status line ("" if nothing)."""
        if not self.saved:
            return ""
        return f"; tasks moved earlier: {self.saved} delay units saved"
