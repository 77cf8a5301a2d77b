"""Reference CP-SAT model of the scheduling problem (OR-Tools).

The same semantics as the problem format, written independently of the ILP:

* one optional fixed-size interval per task, present iff scheduled;
  mandatory tasks (``schedule_cost`` 0 or ``fixed_start``) are present;
* start domain from :meth:`Problem.start_bounds` (both window readings);
* binary resources: ``NoOverlap`` of the users' intervals;
* multiple resources: ``Cumulative`` with the capacity;
* consumable resources: a reservoir with one event per time unit a task
  runs, at that unit (``start + k`` for ``k < length``), so that the level at
  the end of unit ``t`` is ``initial - sum(amount x units run up to and
  including t)``; the reservoir keeps it ``>= 0`` at every event time, which
  covers every ``t`` because the level only changes at event times;
* consumables with a capacity ``max``: a reservoir cannot lose what a full
  store is offered, so these get a level variable per time unit instead,
  ``0 <= L[t] <= max`` and ``L[t] <= L[t-1] - net use in t``, the net use
  read from one start literal per task and start (exact for feasibility:
  the true level ``min(max, L[t-1] - net use)`` is the largest value
  allowed, and a lower one only restricts);
* precedences: ``tight`` ``s_after == s_before + l_before + offset``, ``lax``
  ``>=``, enforced when both tasks are present; scope ``both`` ties the two
  presence literals, ``at_least_first`` makes ``after`` imply ``before``;
* objective ``W x unscheduled + delay`` with
  ``W = 1 + sum(delay_cost) x horizon`` (lexicographic by construction);
  with a stability term (``stability``, the replan's previous starts and
  mode), ``W_unscheduled x unscheduled + W_move x moves + delay``, the
  weights of :class:`fsw_scheduler.model.stability.Stability`, a move
  being a present task whose start differs from its previous one: one
  reified literal ``start == previous`` per such task.

Fractional amounts are scaled to integers per resource (powers of ten up
to 10**6). OR-Tools is imported lazily: it is the optional ``bench`` extra.
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING, Any

from fsw_scheduler.model.plan import (
    Activity,
    Objective,
    Plan,
    SolverStats,
    SolveStatus,
    objective_weight,
)

if TYPE_CHECKING:
    from fsw_scheduler.model.problem import Problem
    from fsw_scheduler.model.stability import Stability

MAX_SCALE_DIGITS = 6


def integer_scale(values: list[float]) -> int:
    """Smallest power of ten (up to 10**6) making every value integral.

    Parameters
    ----------
    values
        Amounts, capacities or levels of one resource.

    Returns
    -------
    int
        The factor; 10**6 if no smaller power of ten is exact.
    """
    for digits in range(MAX_SCALE_DIGITS + 1):
        factor = 10**digits
        if all(
            math.isclose(v * factor, round(v * factor), abs_tol=1e-9)
            for v in values
        ):
            return factor
    return 10**MAX_SCALE_DIGITS


def solve_cpsat(
    problem: Problem,
    *,
    time_limit: float | None = None,
    workers: int = 1,
    seed: int = 0,
    expand_reservoir: bool = False,
    stability: Stability | None = None,
) -> Plan:
    """Solve ``problem`` with CP-SAT and return a plan.

    Parameters
    ----------
    problem
        A validated problem.
    time_limit
        Wall-clock limit of the search in seconds; None for no limit.
    workers
        CP-SAT ``num_workers`` (1 is deterministic with a fixed seed).
    seed
        CP-SAT ``random_seed``.
    expand_reservoir
        CP-SAT ``expand_reservoir_constraints``. Off by default: expanding
        the per-unit reservoir events into pairwise order literals made the
        15-task consumable problems 100-600 times slower.
    stability
        Price moves from previous starts (the replan objective of
        :mod:`fsw_scheduler.model.stability`); default: none.

    Returns
    -------
    Plan
        Status read from CP-SAT (OPTIMAL -> optimal, FEASIBLE -> feasible,
        INFEASIBLE -> infeasible, anything else -> unknown); objective
        recomputed from the plan; ``stats.solver`` is ``cpsat`` or
        ``cpsat<workers>w``. ``build_s`` is the Python model build,
        ``solve_s`` the solver's wall time, ``overhead_s`` the rest
        (model hand-over, solution read-back), ``wall_s`` end to end.
    """
    from ortools.sat.python import cp_model

    began = time.perf_counter()
    name = "cpsat" if workers == 1 else f"cpsat{workers}w"
    model = cp_model.CpModel()
    present, starts, impossible = _tasks(model, problem)
    _resources(model, problem, present, starts)
    _precedences(model, problem, present, starts)
    weight = objective_weight(
        [task.delay_cost for task in problem.tasks], problem.horizon
    )
    if stability is not None and stability.active:
        weight, _ = stability.weights(problem)
    else:
        stability = None
    terms: list[Any] = []
    if stability is not None:
        terms += _move_terms(model, problem, present, starts, stability)
    for task in problem.tasks:
        lit = present[task.id]
        if task.schedule_cost and lit is not None:
            terms.append(weight * task.schedule_cost * (1 - lit))
        if lit is None:
            continue
        latest = problem.start_bounds(task)[1]
        delay = model.new_int_var(0, latest - problem.start, f"d_{task.id}")
        model.add(delay == starts[task.id] - problem.start).only_enforce_if(
            lit
        )
        model.add(delay == 0).only_enforce_if(~lit)
        terms.append(task.delay_cost * delay)
    constant = weight * sum(
        problem.task(tid).schedule_cost for tid in impossible
    )
    model.minimize(sum(terms) + constant)
    proto = model.proto
    build_s = time.perf_counter() - began

    solver = cp_model.CpSolver()
    solver.parameters.num_workers = workers
    solver.parameters.random_seed = seed
    solver.parameters.expand_reservoir_constraints = expand_reservoir
    if time_limit is not None:
        solver.parameters.max_time_in_seconds = float(time_limit)
    code = solver.solve(model)
    status = {
        cp_model.OPTIMAL: SolveStatus.OPTIMAL,
        cp_model.FEASIBLE: SolveStatus.FEASIBLE,
        cp_model.INFEASIBLE: SolveStatus.INFEASIBLE,
    }.get(code, SolveStatus.UNKNOWN)
    activities: list[Activity] = []
    unscheduled: list[str] = []
    objective = None
    if status.has_plan:
        for task in problem.tasks:
            lit = present[task.id]
            if lit is not None and solver.boolean_value(lit):
                start = solver.value(starts[task.id])
                activities.append(
                    Activity(task.id, start, start + task.length)
                )
            else:
                unscheduled.append(task.id)
        objective = _objective(problem, activities, unscheduled, weight)
        if stability is not None:
            objective = stability.objective(
                problem,
                objective.unscheduled_cost,
                objective.delay_cost,
                {a.task: a.start for a in activities},
            )
    else:
        unscheduled = [task.id for task in problem.tasks]
    wall_s = time.perf_counter() - began
    stats = SolverStats(
        solver=name,
        build_s=build_s,
        solve_s=solver.wall_time,
        overhead_s=max(0.0, wall_s - build_s - solver.wall_time),
        wall_s=wall_s,
        num_variables=len(proto.variables),
        num_constraints=len(proto.constraints),
        bound=(solver.best_objective_bound if status.has_plan else None),
        solver_status=solver.status_name(code),
        time_limit_s=time_limit,
    )
    return Plan(
        status=status,
        objective=objective,
        activities=tuple(activities),
        unscheduled=tuple(unscheduled),
        stats=stats,
    )


def _move_terms(
    model: Any,
    problem: Problem,
    present: dict[str, Any],
    starts: dict[str, Any],
    stability: Stability,
) -> list[Any]:
    """``W_move x moved`` per previously planned task: ``moved`` is
    implied by "present and not at its previous start"."""
    _, per_move = stability.weights(problem)
    terms: list[Any] = []
    for name, was in stability.kept(problem).items():
        lit = present[name]
        if lit is None:
            continue
        moved = model.new_bool_var(f"m_{name}")
        stays = model.new_bool_var(f"k_{name}")
        model.add(starts[name] == was).only_enforce_if(stays)
        # Present and not where it was: moved (minimised, so never more).
        model.add_bool_or([~lit, stays, moved])
        terms.append(per_move * moved)
    return terms


def _objective(
    problem: Problem,
    activities: list[Activity],
    unscheduled: list[str],
    weight: int,
) -> Objective:
    unscheduled_cost = sum(
        problem.task(tid).schedule_cost for tid in unscheduled
    )
    delay = sum(
        problem.task(a.task).delay_cost * (a.start - problem.start)
        for a in activities
    )
    return Objective(
        unscheduled_cost, delay, weight * unscheduled_cost + delay
    )


def _tasks(
    model: Any, problem: Problem
) -> tuple[dict[str, Any], dict[str, Any], list[str]]:
    """Presence literal and start variable per task.

    A task with no possible start has neither (None); a mandatory one makes
    the model infeasible.
    """
    present: dict[str, Any] = {}
    starts: dict[str, Any] = {}
    impossible: list[str] = []
    for task in problem.tasks:
        earliest, latest = problem.start_bounds(task)
        if earliest > latest:
            present[task.id] = None
            impossible.append(task.id)
            if task.mandatory:
                model.add_bool_or([])  # nothing can satisfy it
            continue
        starts[task.id] = model.new_int_var(earliest, latest, f"s_{task.id}")
        if task.mandatory:
            present[task.id] = model.new_constant(1)
        else:
            present[task.id] = model.new_bool_var(f"p_{task.id}")
    return present, starts, impossible


def _resources(
    model: Any,
    problem: Problem,
    present: dict[str, Any],
    starts: dict[str, Any],
) -> None:
    intervals = {
        tid: model.new_optional_fixed_size_interval_var(
            starts[tid], problem.task(tid).length, present[tid], f"i_{tid}"
        )
        for tid in starts
    }
    users: dict[str, list[tuple[str, float]]] = {
        name: [] for name in problem.resources.names
    }
    for task in problem.tasks:
        if task.id not in starts:
            continue
        for name, amount in task.uses.items():
            if amount != 0:
                users[name].append((task.id, amount))
    for name in problem.resources.binary:
        if len(users[name]) > 1:
            model.add_no_overlap([intervals[tid] for tid, _ in users[name]])
    for name, capacity in problem.resources.multiple.items():
        if not users[name]:
            continue
        scale = integer_scale([capacity, *(a for _, a in users[name])])
        model.add_cumulative(
            [intervals[tid] for tid, _ in users[name]],
            [round(a * scale) for _, a in users[name]],
            math.floor(capacity * scale + 1e-9),
        )
    ceilings = problem.resources.ceilings
    for name, initial in problem.resources.initial_levels.items():
        if not users[name]:
            continue
        if name in ceilings:
            _capped_levels(
                model,
                problem,
                initial,
                ceilings[name],
                users[name],
                present,
                starts,
            )
            continue
        scale = integer_scale([initial, *(a for _, a in users[name])])
        times: list[Any] = []
        changes: list[int] = []
        actives: list[Any] = []
        generation = 0
        for tid, amount in users[name]:
            change = -round(amount * scale)
            generation += max(0, change) * problem.task(tid).length
            for unit in range(problem.task(tid).length):
                times.append(starts[tid] + unit)
                changes.append(change)
                actives.append(present[tid])
        level0 = math.floor(initial * scale + 1e-9)
        model.add_reservoir_constraint_with_active(
            times, changes, actives, -level0, generation + 1
        )


def _capped_levels(
    model: Any,
    problem: Problem,
    initial: float,
    ceiling: float,
    users: list[tuple[str, float]],
    present: dict[str, Any],
    starts: dict[str, Any],
) -> None:
    """Per-unit levels of one consumable with a capacity.

    ``x[i, s]`` is "task ``i`` starts at ``s``" (their sum is the presence
    literal, and ``start = sum s x[i, s]`` when present); task ``i`` runs
    at ``t`` iff one of ``x[i, t - length + 1 .. t]`` is set.
    """
    amounts = [a for _, a in users]
    scale = integer_scale([initial, ceiling, *amounts])
    top = math.floor(ceiling * scale + 1e-9)
    net: list[list[tuple[int, Any]]] = [[] for _ in range(problem.horizon)]
    for tid, amount in users:
        task = problem.task(tid)
        earliest, latest = problem.start_bounds(task)
        picks = {
            s: model.new_bool_var(f"x_{tid}_{s}")
            for s in range(earliest, latest + 1)
        }
        model.add(sum(picks.values()) == present[tid])
        model.add(
            starts[tid] == sum(s * x for s, x in picks.items())
        ).only_enforce_if(present[tid])
        change = round(amount * scale)
        for s, x in picks.items():
            for t in range(s, s + task.length):
                net[t - problem.start].append((change, x))
    previous: Any = math.floor(initial * scale + 1e-9)
    for t, terms in enumerate(net):
        level = model.new_int_var(0, top, f"L_{t}")
        model.add(level <= previous - sum(c * x for c, x in terms))
        previous = level


def _precedences(
    model: Any,
    problem: Problem,
    present: dict[str, Any],
    starts: dict[str, Any],
) -> None:
    for prec in problem.precedences:
        before, after = present[prec.before], present[prec.after]
        if after is None:
            if prec.scope == "both" and before is not None:
                model.add(before == 0)
            continue
        if before is None:
            model.add(after == 0)  # both scopes: after needs before
            continue
        if prec.scope == "both":
            model.add(before == after)
        else:
            model.add_implication(after, before)
        gap = problem.task(prec.before).length + prec.offset
        lhs = starts[prec.after]
        rhs = starts[prec.before] + gap
        constraint = model.add(
            lhs == rhs if prec.kind == "tight" else lhs >= rhs
        )
        constraint.only_enforce_if([before, after])
