"""Joining the plans of a problem's independent parts into one.

:func:`~fsw_scheduler.solving.solve.solve` solves each independent part
alone (the objective is a sum over tasks, so the parts' optima make the
whole's); here their plans, statuses and bounds become the whole's, and
the status line says which part is unproved and why.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import msgspec

from ..model import groups
from ..model.plan import (
    Objective,
    Plan,
    SolverStats,
    SolveStatus,
    objective_weight,
)

if TYPE_CHECKING:
    from ..model.problem import Problem
    from ..model.stability import Stability


def starved(plan: Plan, least: float) -> bool:
    """True if ``plan``'s part had a share under ``least`` (too short for
    CBC to start) or stopped unproved with most of its share unused."""
    stats = plan.stats
    return (
        stats is not None
        and stats.time_limit_s is not None
        and (
            stats.time_limit_s < least
            or stats.wall_s < 0.5 * stats.time_limit_s
        )
    )


def after(before: Plan, again: Plan) -> Plan:
    """``again``, its status line led by what the first pass of its part
    did: the reader sees both searches, not only the second."""
    if before.stats is None or again.stats is None:
        return again
    return again.replace(
        stats=msgspec.structs.replace(
            again.stats,
            solver_status=f"{before.stats.solver_status}; then with the "
            f"time the other parts left: {again.stats.solver_status}",
        )
    )


def joined(
    problem: Problem,
    plans: list[Plan],
    subs: list[Problem],
    began: float,
    time_limit: float | None,
    stability: Stability | None = None,
    skipped: int = 0,
) -> Plan:
    """One plan of ``problem`` from the plans of its parts (smallest
    first: the status line ends with the largest part's). The move part
    is a sum over tasks too, so the parts' optima join into the whole's
    (with the weights of the whole). ``skipped`` parts were not solved,
    one before them being infeasible."""
    statuses = {plan.status for plan in plans}
    stats = [plan.stats for plan in plans if plan.stats is not None]
    summary = SolverStats(
        solver="+".join(sorted({s.solver for s in stats})) or "none",
        build_s=sum(s.build_s for s in stats),
        solve_s=sum(s.solve_s for s in stats),
        wall_s=time.perf_counter() - began,
        num_variables=sum(s.num_variables for s in stats),
        num_constraints=sum(s.num_constraints for s in stats),
        solver_status=f"{len(plans) + skipped} independent parts: "
        + ", ".join(
            f"{sum(p.status is status for p in plans)} {status.value}"
            for status in SolveStatus
            if status in statuses
        )
        + (
            f"; {'infeasible' if skipped else 'largest'}: "
            f"{stats[-1].solver_status}"
            if stats
            else ""
        )
        + "".join(unproved(plan) for plan in plans)
        + (
            f"; {skipped} not solved: the problem is infeasible whatever "
            "they hold"
            if skipped
            else ""
        ),
        time_limit_s=time_limit,
    )
    everything = tuple(task.id for task in problem.tasks)
    for status in (SolveStatus.INFEASIBLE, SolveStatus.UNKNOWN):
        if status in statuses:
            return Plan(status, None, unscheduled=everything, stats=summary)
    activities = tuple(
        sorted(
            (a for plan in plans for a in plan.activities),
            key=lambda a: (a.start, a.task),
        )
    )
    scheduled = {a.task for a in activities}
    missed = groups.unscheduled_cost(problem, scheduled)
    delay = sum(
        problem.task(a.task).delay_cost * (a.start - problem.start)
        for a in activities
    )
    weight = objective_weight(
        [t.delay_cost for t in problem.tasks], problem.horizon
    )
    optimal = statuses == {SolveStatus.OPTIMAL}
    objective = Objective(missed, delay, weight * missed + delay)
    if stability is not None:
        objective = stability.objective(
            problem, missed, delay, {a.task: a.start for a in activities}
        )
    total = objective.total
    bound: float | None = float(total)
    if not optimal:
        # The parts' bounds join in the paper's weights only: with a move
        # part the whole's weight is another.
        bound = (
            None
            if stability is not None
            else joined_bound(problem, plans, subs)
        )
    return Plan(
        status=SolveStatus.OPTIMAL if optimal else SolveStatus.FEASIBLE,
        objective=objective,
        activities=activities,
        unscheduled=groups.left_out(problem, scheduled),
        chosen=groups.chosen(problem, scheduled),
        stats=msgspec.structs.replace(summary, bound=bound),
    )


def joined_bound(
    problem: Problem, plans: list[Plan], subs: list[Problem]
) -> float | None:
    """A bound on the whole objective from the parts' bounds, if each
    part has one.

    A part's objective weighs a left-out cost by its own ``W_p`` (its
    tasks' delay costs), the whole's by ``W``: a part bound ``L`` says
    that a plan leaving out ``m = L // W_p`` has a delay of at least
    ``L - m W_p``, and one leaving out more costs more than any delay, so
    ``W m + L - m W_p`` bounds the part in the whole's units; the parts'
    bounds add up.
    """
    delay = {task.id: task.delay_cost for task in problem.tasks}
    whole = objective_weight(list(delay.values()), problem.horizon)
    total = 0.0
    for plan, sub in zip(plans, subs, strict=True):
        if plan.stats is None or plan.stats.bound is None:
            return None
        weight = objective_weight(
            [delay[t.id] for t in sub.tasks], problem.horizon
        )
        missed = int(plan.stats.bound // weight)
        total += whole * missed + plan.stats.bound - weight * missed
    return total


def unproved(plan: Plan) -> str:
    """What the joined status says of a part that is not proved: its
    tasks, the limit it had, and its own solver status (why)."""
    if plan.status is SolveStatus.OPTIMAL:
        return ""
    names = sorted([a.task for a in plan.activities] + list(plan.unscheduled))
    stats = plan.stats
    limit = (
        ""
        if stats is None or stats.time_limit_s is None
        else f" after {stats.wall_s:.2f} s of {stats.time_limit_s:.2f} s"
    )
    why = stats.solver_status if stats is not None else "no statistics"
    return (
        f"; {plan.status.value}: the part of {len(names)} tasks from "
        f"{names[0] if names else '-'}{limit}: {why}"
    )
