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

The mission model, written with CP-SAT's own means rather than per-unit
rows:

* alternatives: one literal per option, the presence of every task of the
  option equal to it, at most one option literal per group true (exactly
  one for a group of cost 0); a member is never mandatory on its own, and
  a group left out costs ``W x`` its cost once;
* binary ``available`` windows: fixed intervals over the gaps between the
  windows join the resource's ``NoOverlap``;
* capacity ``steps``: ``Cumulative`` at the largest capacity, with a fixed
  interval of demand ``peak - c_k`` over each step;
* ``external`` rates: one fixed, always active reservoir event per unit
  with a rate (``L[t] <= L[t-1] + external(t) - net use`` with a capacity).

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
    members = _members(problem)
    constant = 0
    for group in problem.alternatives:
        picks = _options(model, group, present)
        if group.schedule_cost == 0:
            model.add(sum(picks) == 1)
        else:
            model.add(sum(picks) <= 1)
            terms.append(weight * group.schedule_cost * (1 - sum(picks)))
    if stability is not None:
        terms += _move_terms(model, problem, present, starts, stability)
    for task in problem.tasks:
        lit = present[task.id]
        if task.id in members:
            pass
        elif task.schedule_cost and lit is not None:
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
    constant += weight * sum(
        problem.task(tid).schedule_cost
        for tid in impossible
        if tid not in members
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
    chosen: dict[str, int] = {}
    if status.has_plan:
        for task in problem.tasks:
            lit = present[task.id]
            if lit is not None and solver.boolean_value(lit):
                start = solver.value(starts[task.id])
                activities.append(
                    Activity(task.id, start, start + task.length)
                )
            elif task.id not in members:
                unscheduled.append(task.id)
        placed = {a.task for a in activities}
        for group in problem.alternatives:
            for idx, option in enumerate(group.options):
                if option[0] in placed:
                    chosen[group.id] = idx
            if group.id not in chosen:
                unscheduled.append(group.id)
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
    plan = Plan(
        status=status,
        objective=objective,
        activities=tuple(activities),
        unscheduled=tuple(unscheduled),
        stats=stats,
    )
    return plan.replace(chosen=chosen) if problem.alternatives else plan


def _members(problem: Problem) -> set[str]:
    return {
        name
        for group in problem.alternatives
        for option in group.options
        for name in option
    }


def _options(model: Any, group: Any, present: dict[str, Any]) -> list[Any]:
    """One literal per option of ``group``: its tasks' common presence."""
    picks: list[Any] = []
    for option in group.options:
        pick = model.new_bool_var(f"o_{group.id}_{len(picks)}")
        for name in option:
            lit = present.get(name)
            if lit is None:
                model.add(pick == 0)  # a task that cannot be placed
            else:
                model.add(lit == pick)
        picks.append(pick)
    return picks


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
    groups = {group.id: group for group in problem.alternatives}
    unscheduled_cost = sum(
        groups[tid].schedule_cost
        if tid in groups
        else problem.task(tid).schedule_cost
        for tid in unscheduled
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
    members = _members(problem)
    for task in problem.tasks:
        # A group member is never mandatory alone: its group may be.
        mandatory = task.fixed_start is not None or (
            task.schedule_cost == 0 and task.id not in members
        )
        earliest, latest = problem.start_bounds(task)
        if earliest > latest:
            present[task.id] = None
            impossible.append(task.id)
            if mandatory:
                model.add_bool_or([])  # nothing can satisfy it
            continue
        starts[task.id] = model.new_int_var(earliest, latest, f"s_{task.id}")
        if mandatory:
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
        closed = _closed(model, problem, name)
        if len(users[name]) + len(closed) > 1:
            model.add_no_overlap(
                [intervals[tid] for tid, _ in users[name]] + closed
            )
    for name, value in problem.resources.multiple.items():
        if not users[name]:
            continue
        steps = (
            [(problem.start, value)]
            if isinstance(value, int | float)
            else list(value.steps)
        )
        capacity = max(c for _, c in steps)
        scale = integer_scale([capacity, *(a for _, a in users[name])])
        # The capacity below the peak, as fixed demand over each step.
        fixed = []
        for k, (since, cap) in enumerate(steps):
            until = steps[k + 1][0] if k + 1 < len(steps) else problem.end
            low, high = max(since, problem.start), min(until, problem.end)
            if high > low and cap < capacity:
                fixed.append(
                    (
                        model.new_fixed_size_interval_var(
                            low, high - low, f"cap_{name}_{k}"
                        ),
                        round((capacity - cap) * scale),
                    )
                )
        model.add_cumulative(
            [intervals[tid] for tid, _ in users[name]] + [f for f, _ in fixed],
            [round(a * scale) for _, a in users[name]] + [d for _, d in fixed],
            math.floor(capacity * scale + 1e-9),
        )
    ceilings = problem.resources.ceilings
    for name, initial in problem.resources.initial_levels.items():
        external = _external(problem, name)
        if not users[name] and not any(external):
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
                external,
            )
            continue
        scale = integer_scale(
            [initial, *(a for _, a in users[name]), *external]
        )
        times: list[Any] = []
        changes: list[int] = []
        actives: list[Any] = []
        generation = 0
        for unit, rate in enumerate(external):
            if rate:
                times.append(problem.start + unit)
                changes.append(round(rate * scale))
                actives.append(model.new_constant(1))
                generation += max(0, round(rate * scale))
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
    external: list[float],
) -> None:
    """Per-unit levels of one consumable with a capacity.

    ``x[i, s]`` is "task ``i`` starts at ``s``" (their sum is the presence
    literal, and ``start = sum s x[i, s]`` when present); task ``i`` runs
    at ``t`` iff one of ``x[i, t - length + 1 .. t]`` is set.
    """
    amounts = [a for _, a in users]
    scale = integer_scale([initial, ceiling, *amounts, *external])
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
        charge = round(external[t] * scale)
        model.add(level <= previous + charge - sum(c * x for c, x in terms))
        previous = level


def _external(problem: Problem, name: str) -> list[float]:
    """The external rate of consumable ``name`` per unit, from its steps."""
    spec = problem.resources.consumable[name]
    rates = [0.0] * problem.horizon
    steps = list(getattr(spec, "external", ()))
    for k, (since, rate) in enumerate(steps):
        until = steps[k + 1][0] if k + 1 < len(steps) else problem.end
        for t in range(max(since, problem.start), min(until, problem.end)):
            rates[t - problem.start] = float(rate)
    return rates


def _closed(model: Any, problem: Problem, name: str) -> list[Any]:
    """Fixed intervals over the gaps between binary ``name``'s windows."""
    binary = problem.resources.binary
    spec = binary.get(name) if isinstance(binary, dict) else None
    if spec is None or spec.available is None:
        return []
    gaps, since = [], problem.start
    for low, high in [*spec.available, (problem.end, problem.end)]:
        low = min(max(low, problem.start), problem.end)
        if low > since:
            gaps.append((since, low))
        since = max(since, min(high, problem.end))
    return [
        model.new_fixed_size_interval_var(a, b - a, f"off_{name}_{a}")
        for a, b in gaps
    ]


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
