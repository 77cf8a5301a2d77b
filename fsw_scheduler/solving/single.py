"""A part of one task under a move term, solved by trying every start.

Most parts of a problem without resources hold one task; with a move
part (``stability``) the shortcuts that close them without a solver are
off, and their share of the limit is often too short for CBC to start.
Trying every start, each judged by the independent checker with the move
part, proves the best plan instead.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

from ..analysis.check import check_plan
from ..model import groups
from ..model.plan import Activity, Plan, SolverStats, SolveStatus

if TYPE_CHECKING:
    from ..analysis.domains import Domain
    from ..model.problem import Problem
    from ..model.stability import Stability


def one_task(
    problem: Problem,
    domains: dict[str, Domain],
    stability: Stability,
    began: float,
    time_limit: float | None,
) -> Plan:
    """The best plan of a one-task problem, by trying every start and,
    if it may be, leaving it out: optimal (or infeasible) by exhaustion,
    each candidate judged by the checker, move part included."""
    (task,) = problem.tasks
    domain = domains[task.id]
    candidates = []
    if not problem.required(task):
        candidates.append(
            Plan(
                SolveStatus.OPTIMAL,
                None,
                unscheduled=groups.left_out(problem, ()),
                chosen=groups.chosen(problem, ()),
            )
        )
    for start in range(domain.earliest, domain.latest + 1):
        activity = Activity(task.id, start, start + task.length)
        candidates.append(
            Plan(
                SolveStatus.OPTIMAL,
                None,
                activities=(activity,),
                unscheduled=groups.left_out(problem, (task.id,)),
                chosen=groups.chosen(problem, (task.id,)),
            )
        )
    best: Plan | None = None
    for plan in candidates:
        report = check_plan(problem, plan, stability)
        if report.ok and (
            best is None
            or best.objective is None
            or report.objective.total < best.objective.total
        ):
            best = plan.replace(objective=report.objective)
    stats = SolverStats(
        solver="enumeration",
        wall_s=time.perf_counter() - began,
        bound=best.objective.total if best and best.objective else None,
        solver_status="one task: every start tried, no solve",
        time_limit_s=time_limit,
    )
    if best is None:
        return Plan(
            SolveStatus.INFEASIBLE,
            None,
            unscheduled=(task.id,),
            stats=stats,
        )
    return best.replace(stats=stats)
