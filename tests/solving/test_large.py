"""Tests of the large parts' routing and search (large.py)."""

from __future__ import annotations

from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.solving import large
from fsw_scheduler.solving.incumbent import columns
from fsw_scheduler.solving.solve import solve

from ..factories import bench_lib, problem_from


def test_a_part_under_30_tasks_with_a_large_model_is_searched() -> None:
    """Tests that a 25-task part goes to the neighbourhood search when its
    model has more than SEARCH_COLUMNS start times (H = 2880) and whole to
    CBC when it has fewer (H = 336), and that 30 tasks always go to the
    search."""
    fresh = bench_lib("fresh")
    long = problem_from(fresh.generate_problem(25, 2880, 3))
    short = problem_from(fresh.generate_problem(25, 336, 3))
    long_domains, short_domains = start_domains(long), start_domains(short)
    assert columns(long_domains) > large.SEARCH_COLUMNS
    assert columns(short_domains) <= large.SEARCH_COLUMNS
    assert large.searched(long, long_domains)
    assert not large.searched(short, short_domains)
    thirty = problem_from(fresh.generate_problem(30, 336, 3))
    assert large.searched(thirty, start_domains(thirty))


def test_a_large_part_with_a_small_model_is_proved_by_cbc_first() -> None:
    """Tests that a 30-task part whose whole model, narrowed around its
    start plan, has few columns is proved by CBC before any search
    (b30-h1440 of the large suite, seed 31: proved in about 3 s, where
    the search first took 11 s)."""
    generator = bench_lib("generator")
    bench = next(b for b in generator.large_suite(31) if b.name == "b30-h1440")
    problem = bench.problem()
    assert large.searched(problem, start_domains(problem))
    plan = solve(problem, time_limit=20)
    assert plan.status is SolveStatus.OPTIMAL, plan.stats
    assert plan.stats is not None
    assert plan.stats.solver_status.startswith("the whole model, narrowed")
    assert plan.stats.gap == 0.0
    assert check_plan(problem, plan).ok
