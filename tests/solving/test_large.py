"""Tests of the large parts' routing and search (large.py)."""

from __future__ import annotations

from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.solving import large
from fsw_scheduler.solving.budget import BUDGET
from fsw_scheduler.solving.incumbent import columns
from fsw_scheduler.solving.solve import solve

from ..factories import bench_lib, problem_from


def test_the_search_takes_parts_from_lns_min_tasks() -> None:
    """Tests that a part goes to the neighbourhood search from
    BUDGET.lns_min_tasks tasks on, however long its horizon, and that a
    29-task part over H = 2880 (a model of more than 15,000 columns)
    still goes whole to CBC."""
    fresh = bench_lib("fresh")
    thirty = problem_from(fresh.generate_problem(30, 336, 3))
    assert thirty.num_tasks == BUDGET.lns_min_tasks
    assert large.searched(thirty)
    long = problem_from(fresh.generate_problem(29, 2880, 3))
    assert columns(start_domains(long)) > 15_000
    assert not large.searched(long)


def test_a_large_part_with_a_small_model_is_proved_before_any_search() -> None:
    """Tests that a 30-task part whose relaxation or whole model, narrowed
    around its start plan, is small is proved before any search
    (b30-h1440 of the large suite, seed 31: proved in about 3 s by the
    whole model, now by the disjunctive relaxation; the search first
    took 11 s)."""
    generator = bench_lib("generator")
    bench = next(b for b in generator.large_suite(31) if b.name == "b30-h1440")
    problem = bench.problem()
    assert large.searched(problem)
    plan = solve(problem, time_limit=20)
    assert plan.status is SolveStatus.OPTIMAL, plan.stats
    assert plan.stats is not None
    assert "neighbourhood search" not in plan.stats.solver_status
    assert plan.stats.gap == 0.0
    assert check_plan(problem, plan).ok
