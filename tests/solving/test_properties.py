"""Property tests: solvers against the checker and a brute-force oracle.

Random small problems are generated valid by construction (every window
holds at least one start inside the horizon, pins sit on such a start);
only contradictory tight-precedence cycles are filtered out. Three oracles
judge the solvers: :func:`fsw_scheduler.analysis.check.check_plan`, the
other backend, and the exhaustive enumeration of ``tests/problems.py``,
written from the problem format alone (it shares no code with either the
checker or the ILP).
"""

from __future__ import annotations

import json

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from fsw_scheduler.analysis.check import check_plan, format_report
from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.model.problem import decode_problem
from fsw_scheduler.solving.ilp import solve_ilp
from fsw_scheduler.solving.solve import solve

from ..factories import bench_lib
from ..problems import (
    COMMON,
    Assignment,
    assert_brute_force_optimum,
    brute_force,
    decode_doc,
    is_feasible,
    mission_docs,
    objective_of,
    plan_of,
    problem_docs,
    show,
    start_ok,
    starts_of,
)

# --------------------------------------------------------------------------
# Properties that need no solver: the two oracles agree with each other


@settings(COMMON, max_examples=300)
@given(doc=problem_docs(max_tasks=4, max_horizon=8), data=st.data())
def test_checker_agrees_with_brute_force_feasibility(
    doc: dict, data: st.DataObject
) -> None:
    """Tests that check_plan accepts exactly the feasible assignments."""
    problem = decode_doc(doc)
    starts: Assignment = {}
    for task in problem.tasks:
        last = problem.start + problem.horizon - task.length
        # Mostly starts the task admits on its own, so that precedences and
        # resources decide; sometimes anything around the horizon.
        admitted = [
            s
            for s in range(problem.start, last + 1)
            if start_ok(problem, task, s)
        ]
        starts[task.id] = data.draw(
            st.none()
            | st.sampled_from(admitted)
            | st.integers(problem.start - 1, last + 1),
            label=task.id,
        )
    report = check_plan(problem, plan_of(problem, starts))
    assert report.ok == is_feasible(problem, starts), format_report(report)
    assert report.objective == objective_of(problem, starts)


@settings(COMMON, max_examples=150)
@given(doc=problem_docs(max_tasks=4, max_horizon=8))
def test_brute_force_optimum_passes_checker(doc: dict) -> None:
    """Tests that the brute-force optimum is a valid plan for check_plan."""
    problem = decode_doc(doc)
    best = brute_force(problem)
    assume(best is not None)
    assert best is not None
    objective, starts = best
    report = check_plan(problem, plan_of(problem, starts))
    assert report.ok, format_report(report)
    assert report.objective == objective


# --------------------------------------------------------------------------
# Solver properties


@settings(COMMON, max_examples=150)
@given(doc=problem_docs())
def test_cbc_plans_pass_the_checker(doc: dict) -> None:
    """Tests that every optimal CBC plan passes check_plan exactly."""
    problem = decode_doc(doc)
    plan = solve(problem, solver="cbc")
    assert plan.status in (SolveStatus.OPTIMAL, SolveStatus.INFEASIBLE), show(
        doc, plan
    )
    report = check_plan(problem, plan)
    assert report.ok, f"{format_report(report)}\n{show(doc, plan)}"
    if plan.status is SolveStatus.OPTIMAL:
        assert plan.objective == report.objective, show(doc, plan)


@settings(COMMON, max_examples=100)
@given(doc=problem_docs())
def test_cbc_and_highs_agree(doc: dict) -> None:
    """Tests that CBC and HiGHS agree on status and objective total."""
    problem = decode_doc(doc)
    cbc = solve(problem, solver="cbc")
    highs = solve(problem, solver="highs")
    assert cbc.status == highs.status, show(doc, cbc, highs)
    if cbc.objective is not None or highs.objective is not None:
        assert cbc.objective is not None, show(doc, cbc, highs)
        assert highs.objective is not None, show(doc, cbc, highs)
        assert cbc.objective.total == highs.objective.total, show(
            doc, cbc, highs
        )
    report = check_plan(problem, highs)
    assert report.ok, f"{format_report(report)}\n{show(doc, highs)}"


@settings(COMMON, max_examples=200)
@given(doc=problem_docs(max_tasks=4, max_horizon=8))
def test_cbc_matches_brute_force(doc: dict) -> None:
    """Tests that CBC's optimum and infeasibility match exhaustive search."""
    problem = decode_doc(doc)
    plan = solve(problem, solver="cbc")
    objective = assert_brute_force_optimum(doc, problem, plan)
    if objective is None:
        return
    assert plan.objective == objective, show(doc, plan)
    assert is_feasible(problem, starts_of(problem, plan)), show(doc, plan)


# --------------------------------------------------------------------------
# The broad benchmark generator (issue 15): plans valid, statuses honest


@settings(COMMON, max_examples=60)
@given(
    seed=st.integers(0, 2**31),
    size=st.sampled_from([3, 5, 6]),
    cls=st.sampled_from(["none", "binary", "multiple", "consumable", "mixed"]),
    horizon=st.sampled_from([24, 48, 96]),
)
def test_broad_problems_get_valid_plans_and_honest_statuses(
    seed: int, size: int, cls: str, horizon: int
) -> None:
    """Tests that every plan on broad problems passes the checker, and that
    'optimal' and 'infeasible' agree with CP-SAT, 'feasible' with its bound.
    """

    broad = bench_lib("broad")
    cpsat = bench_lib("cpsat")
    doc = broad.generate_problem(size, cls, horizon, seed)
    problem = decode_problem(json.dumps(doc))
    plan = solve(problem, solver="cbc", time_limit=20)
    report = check_plan(problem, plan)
    assert report.ok, f"{format_report(report)}\n{show(doc, plan)}"
    assert plan.status is not SolveStatus.UNKNOWN, show(doc, plan)
    reference = cpsat.solve_cpsat(problem, time_limit=20)
    if plan.status is SolveStatus.INFEASIBLE:
        assert reference.status is SolveStatus.INFEASIBLE, show(doc, plan)
        assert plan.why, show(doc, plan)
        return
    assert plan.objective is not None
    assert reference.status is SolveStatus.OPTIMAL, show(doc, reference)
    assert reference.objective is not None
    if plan.status is SolveStatus.OPTIMAL:
        assert plan.objective.total == reference.objective.total, show(
            doc, plan, reference
        )
    else:
        assert plan.objective.total >= reference.objective.total
        bound = plan.stats.bound if plan.stats else None
        assert bound is None or bound <= reference.objective.total + 0.5


# --------------------------------------------------------------------------
# Consumables with a capacity (issue 16): the same oracles, problems whose
# consumables mostly have a capacity a little above their initial level


@settings(COMMON, max_examples=200)
@given(
    doc=problem_docs(max_tasks=4, max_horizon=8, capacities=True),
    data=st.data(),
)
def test_checker_agrees_with_brute_force_under_capacities(
    doc: dict, data: st.DataObject
) -> None:
    """Tests that check_plan and the brute force agree on capped levels."""
    problem = decode_doc(doc)
    starts: Assignment = {}
    for task in problem.tasks:
        admitted = [
            s
            for s in range(problem.start, problem.end - task.length + 1)
            if start_ok(problem, task, s)
        ]
        starts[task.id] = data.draw(
            st.none() | st.sampled_from(admitted), label=task.id
        )
    report = check_plan(problem, plan_of(problem, starts))
    assert report.ok == is_feasible(problem, starts), format_report(report)


@settings(COMMON, max_examples=200)
@given(doc=problem_docs(max_tasks=4, max_horizon=8, capacities=True))
def test_cbc_matches_brute_force_under_capacities(doc: dict) -> None:
    """Tests that every plan the solver returns passes the checker and
    that CBC's optimum equals exhaustive search, with capacities."""
    problem = decode_doc(doc)
    plan = solve(problem, solver="cbc")
    report = check_plan(problem, plan)
    assert report.ok, f"{format_report(report)}\n{show(doc, plan)}"
    objective = assert_brute_force_optimum(doc, problem, plan)
    if objective is None:
        return
    assert plan.objective == objective, show(doc, plan)
    assert is_feasible(problem, starts_of(problem, plan)), show(doc, plan)


@settings(COMMON, max_examples=80)
@given(doc=problem_docs(capacities=True))
def test_cbc_plans_pass_the_checker_under_capacities(doc: dict) -> None:
    """Tests larger problems with capacities: CBC's plans (and HiGHS's,
    with the same objective) pass the checker."""
    problem = decode_doc(doc)
    plan = solve(problem, solver="cbc")
    assert plan.status in (SolveStatus.OPTIMAL, SolveStatus.INFEASIBLE), show(
        doc, plan
    )
    report = check_plan(problem, plan)
    assert report.ok, f"{format_report(report)}\n{show(doc, plan)}"
    highs = solve(problem, solver="highs")
    assert highs.status == plan.status, show(doc, plan, highs)
    assert check_plan(problem, highs).ok, show(doc, highs)
    if plan.objective is not None:
        assert highs.objective is not None
        assert highs.objective.total == plan.objective.total, show(
            doc, plan, highs
        )


@settings(COMMON, max_examples=100)
@given(doc=problem_docs(max_tasks=4, max_horizon=8, capacities=True))
def test_cpsat_baseline_matches_brute_force_under_capacities(
    doc: dict,
) -> None:
    """Tests that the CP-SAT baseline models capacities as the format
    says: its optimum equals exhaustive search."""

    pytest.importorskip("ortools")
    cpsat = bench_lib("cpsat")
    problem = decode_doc(doc)
    plan = cpsat.solve_cpsat(problem, time_limit=20)
    best = brute_force(problem)
    if best is None:
        assert plan.status is SolveStatus.INFEASIBLE, show(doc, plan)
        return
    assert plan.status is SolveStatus.OPTIMAL, show(doc, plan)
    assert plan.objective == best[0], f"{show(doc, plan)}\n{best}"
    assert check_plan(problem, plan).ok, show(doc, plan)


# --------------------------------------------------------------------------
# The mission model (issue 28): alternatives, windows, capacity steps and
# external rates, every one in each generated problem


@settings(COMMON, max_examples=300)
@given(doc=mission_docs(max_tasks=4, max_horizon=8), data=st.data())
def test_checker_agrees_with_brute_force_on_the_mission_model(
    doc: dict, data: st.DataObject
) -> None:
    """Tests that check_plan accepts exactly the assignments the brute
    force calls feasible, with groups, windows, steps and external rates."""
    problem = decode_doc(doc)
    starts: Assignment = {}
    for task in problem.tasks:
        admitted = [
            s
            for s in range(problem.start, problem.end - task.length + 1)
            if start_ok(problem, task, s)
        ]
        starts[task.id] = data.draw(
            st.none() | st.sampled_from(admitted), label=task.id
        )
    report = check_plan(problem, plan_of(problem, starts))
    assert report.ok == is_feasible(problem, starts), (
        f"{format_report(report)}\n{json.dumps(doc)}\n{starts}"
    )


@settings(COMMON, max_examples=150)
@given(doc=mission_docs(max_tasks=4, max_horizon=8))
def test_cbc_cpsat_and_brute_force_agree_on_the_mission_model(
    doc: dict,
) -> None:
    """Tests that on problems with every field of the mission model CBC's
    plan passes the checker and its proved optimum equals exhaustive
    search's and the CP-SAT baseline's (whose plan passes too)."""
    pytest.importorskip("ortools")
    cpsat = bench_lib("cpsat")
    problem = decode_doc(doc)
    plan = solve(problem, solver="cbc")
    report = check_plan(problem, plan)
    assert report.ok, f"{format_report(report)}\n{show(doc, plan)}"
    objective = assert_brute_force_optimum(doc, problem, plan)
    baseline = cpsat.solve_cpsat(problem, time_limit=20)
    assert baseline.status is plan.status, show(doc, plan, baseline)
    if objective is None:
        return
    assert plan.objective == objective, show(doc, plan)
    assert baseline.objective == objective, show(doc, plan, baseline)
    assert check_plan(problem, baseline).ok, show(doc, baseline)


@settings(COMMON, max_examples=80)
@given(doc=mission_docs(max_tasks=4, max_horizon=8))
def test_both_formulations_agree_on_alternatives(doc: dict) -> None:
    """Tests that the disjunctive model, given the problems it takes (no
    consumable, no changing resource in use), finds the time-indexed
    optimum with alternatives."""
    problem = decode_doc(doc)
    kept = {
        "binary": [n for n in problem.resources.binary if n != "w0"],
        "multiple": {
            n: v for n, v in doc["resources"]["multiple"].items() if n != "s0"
        },
    }
    for task in doc["tasks"]:
        task["uses"] = {
            n: a
            for n, a in task.get("uses", {}).items()
            if n in {*kept["binary"], *kept["multiple"]}
        }
    doc["resources"] = kept
    problem = decode_doc(doc)
    indexed = solve_ilp(problem, formulation="time-indexed")
    disjunctive = solve_ilp(problem, formulation="disjunctive")
    assert check_plan(problem, disjunctive).ok, show(doc, disjunctive)
    assert indexed.status is disjunctive.status, show(
        doc, indexed, disjunctive
    )
    if indexed.objective is not None:
        assert disjunctive.objective == indexed.objective, show(
            doc, indexed, disjunctive
        )
