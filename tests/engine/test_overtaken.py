"""Tests of what the engine does with what it commanded while a replan
was computed: kept where commanded, never sent twice; and of the reports
of an activity that a replan re-based."""

from __future__ import annotations

import functools
import json

from fsw_scheduler.engine.events import ReportArrived
from fsw_scheduler.model.plan import Activity, Plan, SolveStatus
from fsw_scheduler.model.problem import decode_problem
from fsw_scheduler.wire import messages

from ..factories import make_doc, make_task, problem_from
from .driver import Driver, published, statuses

CAMERA = {"binary": ["camera"], "multiple": {"power": 100}}
#: A node's problem: resources and horizon; goals bring the tasks.
EMPTY = decode_problem(json.dumps(make_doc([], 20, CAMERA)), allow_empty=True)


def _goal(goal_id: str, *tasks: dict) -> dict:
    return {"goal_id": goal_id, "tasks": list(tasks)}


def _dispatched(driver: Driver) -> list[str]:
    return [
        d.dispatch_id for d in published(driver.history, messages.Dispatch)
    ]


def _overtaken(schedule_cost: int) -> Driver:
    """X planned at 1-2 on the camera; a goal's Y, which can only run at
    1, is being solved for when the clock reaches 1 and X is commanded."""
    driver = Driver(EMPTY, hold=True)
    driver.tick(0)
    driver.goal(
        _goal(
            "g1",
            make_task("X", 1, feasible_interval=[1, 10], uses={"camera": 1}),
        )
    )
    driver.finish()
    assert [(a.task, a.start) for a in driver.plan.activities] == [("X", 1)]
    driver.goal(
        _goal(
            "g2",
            make_task(
                "Y",
                1,
                delay_cost=5,
                schedule_cost=schedule_cost,
                feasible_interval=[1, 1],
                feasible_interval_applies_to="start",
                uses={"camera": 1},
            ),
        )
    )
    driver.tick(1)  # the old plan commands X while g2 is solved
    assert _dispatched(driver) == ["X:1-2"]
    driver.finish()
    return driver


def test_a_plan_that_moves_a_command_keeps_it_and_leaves_out_the_rest() -> (
    None
):
    """Tests that a replan posed before X was commanded, which moves X to
    make room for an optional Y, is adopted with X where it was commanded,
    Y left out, and X never commanded a second time."""
    driver = _overtaken(schedule_cost=5)
    plan = driver.plan
    assert [(a.task, a.start, a.end) for a in plan.activities] == [("X", 1, 2)]
    assert "Y" in plan.unscheduled
    assert plan.status == "feasible"
    assert _dispatched(driver) == ["X:1-2"]
    assert "g2" in plan.goals


def test_no_plan_keeps_the_command_and_a_mandatory_task() -> None:
    """Tests that when only leaving out a mandatory task would keep what
    was commanded, the goal is rejected, saying why, and the current plan
    stays, X commanded once."""
    driver = _overtaken(schedule_cost=0)
    rejected = statuses(driver.history, "goal_rejected")
    assert [s.goal_id for s in rejected] == ["g2"]
    assert "commanded while it was computed" in rejected[0].errors[0].reason
    assert [(a.task, a.start) for a in driver.plan.activities] == [("X", 1)]
    assert _dispatched(driver) == ["X:1-2"]


def test_reports_answer_the_dispatch_after_a_replan_rebases_it() -> None:
    """Tests that the reports of a running activity name the dispatch it
    was commanded with, also after a replan re-based it to start now."""
    driver = Driver(EMPTY)
    driver.tick(0)
    driver.goal(_goal("g1", make_task("A", 3, uses={"power": 10})))
    assert _dispatched(driver) == ["A:0-3"]
    # Every report names the dispatch as it was sent: id and term.
    report = functools.partial(
        messages.ActivityReport, dispatch_id="A:0-3", term=driver.engine.term
    )
    driver.step(ReportArrived(report("A", "running", 0)))
    driver.tick(1)
    driver.goal(_goal("g2", make_task("B", 1, uses={"power": 10})))
    assert ("A", 1, 3) in {
        (a.task, a.start, a.end) for a in driver.plan.activities
    }
    driver.tick(3)
    out = driver.step(ReportArrived(report("A", "completed", 3)))
    assert not statuses(out, "input_rejected")
    assert driver.engine.snapshot().lifecycle["A"] == "completed"


def test_keep_commanded_leaves_a_plan_that_keeps_its_commands() -> None:
    """Tests that a plan holding every command is returned as it is."""
    from fsw_scheduler.engine.overtaken import keep_commanded

    problem = problem_from(make_doc([make_task("X", 1)], 5))
    plan = Plan(SolveStatus.OPTIMAL, None, (Activity("X", 0, 1),))
    assert keep_commanded(problem, plan, {"X": (0, 1)}) == (plan, ())
