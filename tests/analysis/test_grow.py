"""Tests of kept sets grown with list scheduling as the judge
(:mod:`fsw_scheduler.analysis.grow`)."""

from __future__ import annotations

import json

from hypothesis import given, settings
from hypothesis import strategies as st

from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.greedy import checked_starts, greedy_plan
from fsw_scheduler.analysis.grow import grown
from fsw_scheduler.model.problem import Problem, decode_problem

from ..factories import large_suite_problem
from ..problems import COMMON, brute_force, decode_doc, problem_docs


def _crowded_camera() -> Problem:
    """A camera of 12 units: an early cheap task that list scheduling
    places first at 0 (the start plan keeps it), and two valuable tasks
    each due by 6 that then no longer fit; keeping those two and leaving
    the cheap one out is worth more."""
    return decode_problem(
        json.dumps(
            {
                "horizon": 12,
                "resources": {"binary": ["camera"]},
                "tasks": [
                    {"id": "cheap", "length": 8, "delay_cost": 1,
                     "schedule_cost": 1, "uses": {"camera": 1}},
                    {"id": "dawn", "length": 3, "delay_cost": 1,
                     "schedule_cost": 3, "uses": {"camera": 1},
                     "feasible_interval": [0, 6]},
                    {"id": "noon", "length": 3, "delay_cost": 1,
                     "schedule_cost": 3, "uses": {"camera": 1},
                     "feasible_interval": [0, 6]},
                ],
            }
        )
    )  # fmt: skip


def test_a_cheap_task_is_swapped_out_for_a_valuable_one() -> None:
    """Tests that a kept set holding a cheap task that blocks a valuable
    one grows by swapping them, into a checked plan keeping more."""
    problem = _crowded_camera()
    start = checked_starts(problem, {"cheap": 0})
    assert start is not None and start.objective is not None
    more = grown(problem, start)
    assert more is not None and more.objective is not None
    assert check_plan(problem, more).ok
    assert "cheap" not in more.starts()
    assert more.objective.unscheduled_cost < start.objective.unscheduled_cost
    best = brute_force(problem)
    assert best is not None and more.objective.total >= best[0].total


def test_nothing_grows_where_every_valuable_task_is_kept() -> None:
    """Tests that a plan keeping every task it can gives None."""
    problem = _crowded_camera()
    start = checked_starts(problem, {"dawn": 0, "noon": 3})
    assert start is not None
    assert grown(problem, start) is None


def test_the_dense_day_keeps_what_the_search_could_not() -> None:
    """Tests the large suite's b60-h2880 of seed 217 (60 tasks over H =
    2880, three binary resources, power, data rate and a battery): from
    the start heuristic's plan, the grown kept set leaves out at most
    55 schedule-cost units (the start 66; the product's plan 63 before,
    CP-SAT's 52 at 20 s), and its plan passes the checker."""
    problem = large_suite_problem(217, "b60-h2880")
    start = greedy_plan(problem)
    assert start is not None and start.objective is not None
    more = grown(problem, start)
    assert more is not None and more.objective is not None
    assert check_plan(problem, more).ok
    assert more.objective.unscheduled_cost <= 55
    assert more.objective.unscheduled_cost < start.objective.unscheduled_cost


@settings(COMMON, max_examples=200)
@given(doc=problem_docs(max_tasks=5, max_horizon=12), data=st.data())
def test_a_grown_plan_is_valid_keeps_more_and_no_better_than_optimal(
    doc: dict, data: st.DataObject
) -> None:
    """Tests on drawn problems, from the start heuristic's plan with
    drawn tasks taken out (when that is still a plan), that a grown plan
    passes the checker, keeps more schedule cost than the plan it grew
    from, and is never better than the exhaustive optimum; and that a
    plan with nothing left out is never grown."""
    problem = decode_doc(doc)
    full = greedy_plan(problem)
    if full is None:
        return
    starts = full.starts()
    dropped = data.draw(st.sets(st.sampled_from(sorted(starts) or [""])))
    start = checked_starts(
        problem, {n: s for n, s in starts.items() if n not in dropped}
    )
    if start is None or start.objective is None:
        return
    more = grown(problem, start)
    if not start.unscheduled:
        assert more is None
        return
    if more is None:
        return
    assert more.objective is not None
    assert check_plan(problem, more).ok
    assert more.objective.unscheduled_cost < start.objective.unscheduled_cost
    best = brute_force(problem)
    assert best is not None
    assert more.objective.total >= best[0].total
