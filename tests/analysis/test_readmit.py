"""Tests of readmitting left-out tasks into a start plan."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

from fsw_scheduler.analysis.bounds import kept_set_plan
from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.analysis.greedy import plan_in_order
from fsw_scheduler.analysis.readmit import MAX_TRIES, readmitted
from fsw_scheduler.model.plan import Activity, Plan, SolveStatus
from fsw_scheduler.model.problem import decode_problem
from fsw_scheduler.solving.incumbent import _readmitting, worth_a_probe
from fsw_scheduler.solving.solve import solve

from ..factories import bench_lib, crowded_camera, make_task, problem_from

if TYPE_CHECKING:
    from fsw_scheduler.model.problem import Problem


def _crowded() -> Problem:
    """One camera over 10 units: ``long`` (10 units, worth 1) fills it,
    ``a`` and ``b`` (5 units each, worth 5) fit together instead."""
    return problem_from(
        {
            "horizon": 10,
            "resources": {"binary": ["camera"]},
            "tasks": [
                make_task("long", 10, schedule_cost=1, uses={"camera": 1}),
                make_task("a", 5, schedule_cost=5, uses={"camera": 1}),
                make_task("b", 5, schedule_cost=5, uses={"camera": 1}),
            ],
        }
    )


def _long_first(problem: Problem) -> Plan:
    plan = plan_in_order(problem, ["long", "a", "b"], start_domains(problem))
    assert plan is not None
    assert plan.activities == (Activity("long", 0, 10),)
    return plan


def test_a_left_out_task_first_gives_the_better_plan() -> None:
    """Tests that the tasks a long one kept out are readmitted, checked."""
    problem = _crowded()
    start = _long_first(problem)
    better = readmitted(problem, start, start_domains(problem))
    assert better is not start
    assert better.unscheduled == ("long",)
    assert {a.task for a in better.activities} == {"a", "b"}
    assert better.status is SolveStatus.FEASIBLE
    assert check_plan(problem, better).ok
    assert better.objective is not None and start.objective is not None
    assert better.objective.total < start.objective.total


def test_a_left_out_task_goes_first_with_its_predecessors() -> None:
    """Tests that a left-out task is tried at the head of the order with
    what must come before it: alone there it waits for a predecessor
    that the order places too late for the task's window."""
    problem = problem_from(
        {
            "horizon": 30,
            "resources": {"binary": ["camera"]},
            "tasks": [
                make_task("wide", 10, uses={"camera": 1}),
                make_task("pre", 10, uses={"camera": 1}),
                make_task(
                    "late",
                    5,
                    schedule_cost=5,
                    feasible_interval=[10, 15],
                    feasible_interval_applies_to="task",
                ),
            ],
            "precedences": [
                {
                    "before": "pre",
                    "after": "late",
                    "kind": "lax",
                    "scope": "at_least_first",
                }
            ],
        }
    )
    domains = start_domains(problem)
    start = plan_in_order(problem, ["wide", "pre", "late"], domains)
    assert start is not None and start.unscheduled == ("late",)
    # The task alone at the head of the order is no better: its
    # predecessor still comes after ``wide``.
    alone = plan_in_order(problem, ["late", "wide", "pre"], domains)
    assert alone is not None and alone.unscheduled == ("late",)
    better = readmitted(problem, start, domains)
    assert better.unscheduled == ()
    assert {a.task: a.start for a in better.activities} == {
        "pre": 0,
        "late": 10,
        "wide": 10,
    }
    assert check_plan(problem, better).ok


def test_nothing_better_returns_the_plan_itself() -> None:
    """Tests that a plan leaving nothing out, or the best one, is kept."""
    problem = _crowded()
    domains = start_domains(problem)
    best = readmitted(problem, _long_first(problem), domains)
    assert readmitted(problem, best, domains) is best
    alone = problem_from({"horizon": 5, "tasks": [make_task("x", 2)]})
    plan = plan_in_order(alone, ["x"], start_domains(alone))
    assert plan is not None and not plan.unscheduled
    assert readmitted(alone, plan, start_domains(alone)) is plan


def test_a_stop_returns_the_plan_found_so_far() -> None:
    """Tests that the caller's deadline ends the search at once."""
    problem = _crowded()
    start = _long_first(problem)
    assert (
        readmitted(problem, start, start_domains(problem), stop=lambda: True)
        is start
    )


def test_the_search_is_bounded_in_list_schedules() -> None:
    """Tests that at most MAX_TRIES list schedules are made, however many
    tasks are left out (here 40, none of which can be readmitted)."""
    problem = problem_from(crowded_camera(40))
    start = plan_in_order(
        problem, [t.id for t in problem.tasks], start_domains(problem)
    )
    assert start is not None and len(start.unscheduled) == 40
    asked = []

    def stop() -> bool:
        asked.append(1)
        return False

    assert readmitted(problem, start, start_domains(problem), stop=stop) is (
        start
    )
    assert len(asked) == MAX_TRIES


def test_the_probe_starts_from_the_readmitted_plan() -> None:
    """Tests that a start plan far from the kept-set bound is replaced by
    the readmitted one, with the model narrowed around it."""
    problem = _crowded()
    domains = start_domains(problem)
    start = _long_first(problem)
    relaxed = kept_set_plan(problem, start, domains)
    assert worth_a_probe(problem, start, relaxed)
    better, again, narrowed = _readmitting(
        problem, start, domains, relaxed, domains, 0.0, None
    )
    assert better.unscheduled == ("long",)
    # The bound (the camera's energy: "long" or both others go) stays,
    # and it is the readmitted plan's left-out cost.
    assert better.objective is not None
    left_out = better.objective.total - better.objective.delay_cost
    assert again.bound == relaxed.bound == left_out > 0
    assert set(narrowed) == set(domains)
    unchanged = _readmitting(problem, better, domains, again, domains, 0, None)
    assert unchanged[0] is better and unchanged[2] is domains


def test_readmission_keeps_the_optimum_of_campaign_problems() -> None:
    """Tests that solves that readmit tasks still prove CP-SAT's optimum
    (the consumable problem it took from 1.45 s to 0.27 s among them)."""
    import pytest

    pytest.importorskip("ortools")
    cpsat = bench_lib("cpsat")
    generator = bench_lib("generator")
    chosen = [
        p
        for p in generator.campaign(5, "paper")
        if p.name in ("c15-consumable-5", "c10-consumable-5", "c10-all-1")
    ]
    assert len(chosen) == 3
    for bench in chosen:
        problem = decode_problem(json.dumps(bench.doc).encode())
        mine = solve(problem, time_limit=30)
        theirs = cpsat.solve_cpsat(problem, time_limit=30)
        assert mine.status is theirs.status is SolveStatus.OPTIMAL, bench.name
        assert mine.objective == theirs.objective, bench.name
