"""Large parts and replans: the neighbourhood search with a bound.

Parts of :attr:`~fsw_scheduler.solving.budget.SolveBudget.lns_min_tasks`
tasks or more under a time limit are not handed whole to CBC at first
(its root LP alone can take longer than the limit):

* :func:`improved`: the start plan improved by neighbourhood search
  (:mod:`fsw_scheduler.solving.improve`), bounded by the kept-set
  relaxation, then the whole model narrowed around the incumbent with
  what is left; the plan carries its bound (``stats.bound``);
* :func:`replanned`: a replan from the plan in force, repaired
  (:mod:`fsw_scheduler.solving.repair`) and searched around what changed.

:func:`fsw_scheduler.solving.solve.solve` calls them and adds the gap.
"""

from __future__ import annotations

import functools
import time
from typing import TYPE_CHECKING

from ..analysis.bounds import kept_set_bound
from ..model.plan import SolverStats, SolveStatus
from .budget import BUDGET
from .improve import improve
from .incumbent import checked, narrow
from .repair import changed_tasks, repair

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..analysis.domains import Domain
    from ..model.plan import Plan
    from ..model.problem import Problem


#: Share of a replan's time its repair (the start heuristic) may take.
REPAIR_SHARE = 0.7

#: Search nodes of a replan's kept-set bound: its default 20,000 took
#: 0.2-0.6 s on 60 tasks, a third of a replan; 5,000 found the same bound
#: on 5 of the 6 large parts (30-60 tasks) where 20,000 found one, in a
#: tenth of a second.
REPLAN_BOUND_NODES = 5_000


def replanned(
    problem: Problem,
    in_force: Plan,
    domains: dict[str, Domain],
    run: Callable[..., Plan],
    began: float,
    time_limit: float,
) -> Plan | None:
    """A large part replanned from the plan in force, or None.

    The plan in force is repaired (:func:`~fsw_scheduler.solving.repair.
    repair`: its tasks stay, the others go into its gaps), then the
    neighbourhood search works around the tasks that changed, within the
    limit (a replan's: :meth:`~fsw_scheduler.solving.budget.SolveBudget.
    replan_limit`), and stops when those neighbourhoods give nothing
    more. The kept-set bound says whether it is optimal, and its gap.
    None when the repair finds no plan (the caller then solves afresh).
    """
    end = began + time_limit - BUDGET.lns_margin_s
    # The start heuristic under the repair took the whole replan on 60
    # tasks (1.9 of 2 s), and the bound after it ran past the limit: it
    # stops at REPAIR_SHARE of the time, keeping the rest for the bound
    # and the search around the change.
    repair_end = began + REPAIR_SHARE * (end - began)

    def stop() -> bool:
        return time.perf_counter() > repair_end

    repaired = repair(problem, in_force, domains, stop=stop)
    if repaired is None:
        return None
    relaxed = kept_set_bound(
        problem, repaired, domains, max_nodes=REPLAN_BOUND_NODES
    )
    if relaxed.plan is not None:
        return _proved_start(
            relaxed.plan,
            began,
            time_limit,
            "replan: the plan in force, repaired, meets the kept-set bound",
        )
    bound = None if relaxed.bound is None else float(relaxed.bound)
    changed = changed_tasks(problem, in_force, repaired)
    best, improved = repaired, 0
    if changed and not meets(best, bound):
        best, improved = improve(
            problem, repaired, domains, run, end, bound, around=changed
        )
    status = SolveStatus.FEASIBLE
    if meets(best, bound) and best.objective is not None:
        status, bound = SolveStatus.OPTIMAL, float(best.objective.total)
    solver = (
        f"{run.keywords.get('solver', 'cbc')}-repair"
        if isinstance(run, functools.partial)
        else "repair"
    )
    return best.replace(
        status=status,
        why=(),
        stats=SolverStats(
            solver=solver,
            wall_s=time.perf_counter() - began,
            bound=bound,
            solver_status=f"replan from the plan in force: {len(changed)} "
            f"tasks changed by its repair; neighbourhood search around "
            f"them: {improved} improvements",
            time_limit_s=time_limit,
        ),
    )


#: Seconds (at most; a tenth of what is left) that the whole model run
#: after the neighbourhood search leaves of the limit for its own end.
FULL_MARGIN_S = 1.0

#: The whole model is run after the neighbourhood search only with at
#: least this long left: a 60-task model's building and CBC's start took
#: all of 1.7 s, and the search had lost that time for nothing.
FULL_MIN_S = 2.0


def improved(
    problem: Problem,
    start: Plan,
    domains: dict[str, Domain],
    run: Callable[..., Plan],
    began: float,
    time_limit: float,
) -> Plan:
    """The start plan improved by
    :func:`fsw_scheduler.solving.improve.improve`, with a proven bound.

    For large problems under a limit: the whole model does not get
    through CBC's root LP in seconds (on the scaling set CBC never
    improved the start plan), small neighbourhood models do. The
    kept-set relaxation (:func:`~fsw_scheduler.analysis.bounds.
    kept_set_plan`) bounds every plan from the start, and the search
    stops when its incumbent meets the bound. Otherwise, once a sweep of
    the largest neighbourhoods finds nothing or its share of the limit
    (:attr:`~fsw_scheduler.solving.budget.SolveBudget.lns_share`) is
    spent, the whole model, narrowed around the incumbent (every plan at
    least as good fits in it), gets the rest of the limit: CBC may prove
    the incumbent, improve it, or at least raise the bound. The plan
    carries the best bound found (``stats.bound``) and its ``gap``.
    """
    deadline = began + time_limit - BUDGET.lns_margin_s
    relaxed = kept_set_bound(problem, start, domains)
    if relaxed.plan is not None:
        return _proved_start(
            relaxed.plan,
            began,
            time_limit,
            "every kept task at its earliest start, and no other choice "
            "of tasks to keep costs less: no solve",
        )
    bound = None if relaxed.bound is None else float(relaxed.bound)
    now = time.perf_counter()
    lns_end = deadline
    if (1 - BUDGET.lns_share) * (deadline - now) >= FULL_MIN_S:
        lns_end = now + BUDGET.lns_share * (deadline - now)
    best, improved = improve(
        problem,
        start,
        domains,
        run,
        lns_end,
        bound,
        # With less than this left the whole model is not run: the
        # search keeps the time rather than end with the gap open.
        hand_over_s=FULL_MIN_S if lns_end == deadline else 0.0,
    )
    said = f"neighbourhood search: {improved} improvements of the start plan"
    solver = (
        f"{run.keywords.get('solver', 'cbc')}-lns"
        if isinstance(run, functools.partial)
        else "lns"
    )
    status = SolveStatus.FEASIBLE
    left = deadline - time.perf_counter()
    if meets(best, bound):
        status = SolveStatus.OPTIMAL
        said += "; it meets the kept-set bound"
    elif left >= FULL_MIN_S:
        again = relaxed
        if improved:
            # The search costs up to a second here: only when it can say
            # more than it did of the start plan.
            again = kept_set_bound(problem, best, domains)
            bound = higher(bound, again.bound)
        answer = checked(
            problem,
            run(
                problem,
                warm=best.starts(),
                domains=narrow(problem, best, domains, again),
                # A large model's CBC, killed at its deadline, and its
                # answer read back, ran up to 1.6 s past a 20 s limit.
                time_limit=left - min(FULL_MARGIN_S, 0.1 * left),
            ),
        )
        found = answer.stats.bound if answer.stats is not None else None
        if answer.status is SolveStatus.OPTIMAL and (
            answer.objective is not None
            and best.objective is not None
            and answer.objective.total <= best.objective.total
        ):
            best, status = answer, SolveStatus.OPTIMAL
            found = float(answer.objective.total)
        elif (
            answer.status.has_plan
            and answer.objective is not None
            and best.objective is not None
            and answer.objective.total < best.objective.total
        ):
            best = answer
        if (
            found is not None
            and best.objective is not None
            and found <= best.objective.total + 0.5
        ):
            # A bound of the narrowed model bounds the whole problem: the
            # optimum fits in it. Above the incumbent it bounds nothing
            # (a stopped CBC's last LP, not its root's).
            bound = higher(bound, found)
        said += "; then the whole model, narrowed: " + (
            answer.stats.solver_status if answer.stats else "no answer"
        )
        if meets(best, bound):
            status = SolveStatus.OPTIMAL
    if status is SolveStatus.OPTIMAL and best.objective is not None:
        bound = float(best.objective.total)
    return best.replace(
        status=status,
        why=(),
        stats=SolverStats(
            solver=solver,
            wall_s=time.perf_counter() - began,
            bound=bound,
            solver_status=said,
            time_limit_s=time_limit,
        ),
    )


def higher(bound: float | None, other: float | None) -> float | None:
    """The higher of two lower bounds, either of which may be unknown."""
    if bound is None or other is None:
        return other if bound is None else bound
    return max(bound, other)


def meets(plan: Plan, bound: float | None) -> bool:
    """True if ``plan``'s objective (an integer) is within half a unit of
    ``bound``: no plan is better."""
    return (
        bound is not None
        and plan.objective is not None
        and plan.objective.total <= bound + 0.5
    )


def _proved_start(
    plan: Plan, began: float, time_limit: float | None, proof: str
) -> Plan:
    """``plan`` proved optimal without a solver, with its statistics."""
    return plan.replace(
        status=SolveStatus.OPTIMAL,
        stats=SolverStats(
            solver="greedy",
            wall_s=time.perf_counter() - began,
            bound=plan.objective.total if plan.objective else None,
            solver_status=proof,
            time_limit_s=time_limit,
        ),
    )
