"""Tests of the list scheduler's resource board."""

from __future__ import annotations

from fsw_scheduler.analysis.board import Board
from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.analysis.greedy import greedy_plan

from ..factories import bench_lib


def test_first_fit_is_the_first_start_that_fits() -> None:
    """Tests that Board.first_fit, which skips starts, finds the same
    start as trying each in turn, for every task of a large broad problem
    (binary and multiple resources, a battery) on the board of half its
    start plan."""
    generator = bench_lib("generator")
    bench = next(p for p in generator.large_suite(47) if p.name == "b45-h1440")
    problem = bench.problem()
    domains = start_domains(problem)
    plan = greedy_plan(problem, domains=domains)
    assert plan is not None
    tasks = {t.id: t for t in problem.tasks}
    board = Board(problem)
    for activity in plan.activities[::2]:
        board.add(tasks[activity.task], activity.start)
    skipped = 0
    for task in problem.tasks:
        domain = domains[task.id]
        if domain.empty:
            continue
        every = next(
            (
                start
                for start in range(domain.earliest, domain.latest + 1)
                if board.fits_one(task, start)
            ),
            None,
        )
        assert board.first_fit(task, domain.earliest, domain.latest) == (
            every
        ), task.id
        skipped += every is None or every > domain.earliest
    assert skipped >= 5
