"""Tests of the relaxation in rounds of growing node limits (rounds.py)."""

from __future__ import annotations

import functools

from fsw_scheduler.analysis.bounds import kept_set_bound
from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.analysis.insert import inserted
from fsw_scheduler.solving import large
from fsw_scheduler.solving.ilp import solve_ilp
from fsw_scheduler.solving.incumbent import narrow
from fsw_scheduler.solving.relaxed import around
from fsw_scheduler.solving.rounds import rounds
from fsw_scheduler.solving.solve import best_start

from ..factories import bench_lib

#: The large suite's b30-h1440 of seed 71: CP-SAT proves 3,522,040 in
#: 0.5 s; one round of the relaxation stops on its nodes far below it.
OPTIMUM = 3_522_040


def _b30_h1440():
    generator = bench_lib("generator")
    bench = next(b for b in generator.large_suite(71) if b.name == "b30-h1440")
    return bench.problem()


def test_rounds_prove_a_part_one_round_leaves_open() -> None:
    """Tests that where one node-limited round of the relaxation stops
    with its bound far below the optimum, rounds of growing node limits
    from the same start prove the optimum, a plan the checker accepts."""
    problem = _b30_h1440()
    domains = start_domains(problem)
    start = best_start(problem, None, domains=domains)
    assert start is not None
    start = inserted(problem, start, domains)
    run = functools.partial(solve_ilp, solver="cbc", threads=1, seed=0)
    narrowed = narrow(problem, start, domains)
    one = around(problem, start, narrowed, run, 60.0)
    assert one.plan is None
    assert one.bound is not None and one.bound < OPTIMUM - 100_000
    relaxed = kept_set_bound(problem, start, domains)
    answer = rounds(
        problem,
        start,
        narrowed,
        run,
        120.0,
        lambda plan: (
            large._narrowed(problem, plan, domains, relaxed)
            or narrow(problem, plan, domains)
        ),
    )
    assert answer.plan is not None, answer.said
    assert answer.plan.objective is not None
    assert answer.plan.objective.total == OPTIMUM
    assert answer.bound == OPTIMUM
    assert check_plan(problem, answer.plan).ok
