"""The solve entry point: one call from problem to explained plan."""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

from .explain import explain as explain_plan

if TYPE_CHECKING:
    from .model import Problem
    from .solution import Plan


def solve(
    problem: Problem,
    solver: str = "cbc",
    *,
    time_limit: float | None = None,
    threads: int = 1,
    seed: int = 0,
    explain: bool = False,
    warm: Plan | None = None,
) -> Plan:
    """Solve ``problem`` and return its plan with an honest status.

    Parameters
    ----------
    problem
        A validated problem (see :func:`fsw_scheduler.model.decode_problem`).
    solver
        ``cbc`` (default, through PuLP) or ``highs``.
    time_limit
        Seconds for the solver. At the limit the best plan found is returned
        with status ``feasible``, or ``unknown`` when none was found.
    threads
        Solver threads; keep 1 for reproducible plans.
    seed
        Solver random seed.
    explain
        Also say why each left-out task is out (and, when infeasible, which
        mandatory tasks cannot be placed); costs extra solves.
    warm
        A previous plan used as a MIP start (CBC).

    Returns
    -------
    Plan
        Every task appears once, in ``activities`` or ``unscheduled``.
    """
    # The backend is imported here so that importing fsw_scheduler does not
    # import PuLP (the pure core must stay free of it).
    from .solvers.ilp import solve_ilp

    run = functools.partial(
        solve_ilp,
        solver=solver,
        time_limit=time_limit,
        threads=threads,
        seed=seed,
    )
    plan = run(problem, warm=warm.starts() if warm else None)
    if explain and (plan.unscheduled or not plan.status.has_plan):
        plan = plan.replace(why=explain_plan(problem, plan, run))
    return plan
