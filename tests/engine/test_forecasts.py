"""Tests of forecasts in the engine (fsw_scheduler.engine.forecasts):
taken into the running problem, a replan only when the plan breaks."""

from __future__ import annotations

from typing import TYPE_CHECKING

from fsw_scheduler.engine.events import Log, StartSolve
from fsw_scheduler.wire import messages

from ..factories import make_doc, make_task, problem_from
from .driver import Driver, published, small_goal, statuses

if TYPE_CHECKING:
    from fsw_scheduler.engine.events import Command


def _pass() -> Driver:
    """A downlink that may start from t=5 inside an antenna window, a
    survey on stepped power, and a battery the sun charges; first plan
    solved at t=0 (Down at 5)."""
    problem = problem_from(
        make_doc(
            [
                make_task(
                    "Down", 4, uses={"antenna": 1}, feasible_interval=[5, 30]
                ),
                make_task("Survey", 3, uses={"power": 2, "battery": 1}),
            ],
            horizon=30,
            resources={
                "binary": {"antenna": {"available": [[0, 30]]}},
                "multiple": {"power": {"steps": [[0, 2]]}},
                "consumable": {
                    "battery": {"initial": 3, "external": [[0, 0.5]]}
                },
            },
        )
    )
    driver = Driver(problem)
    driver.tick(0)
    assert driver.plan.trigger == "initial"
    assert {a.task: a.start for a in driver.plan.activities} == {
        "Down": 5,
        "Survey": 0,
    }
    return driver


def _solves(out: list[Command]) -> list[StartSolve]:
    return [c for c in out if isinstance(c, StartSolve)]


def test_a_forecast_that_breaks_the_plan_replans() -> None:
    """Tests that a forecast closing the antenna over the planned
    downlink replans with trigger ``forecast``, into the new window."""
    driver = _pass()
    out = driver.forecast("antenna", 2, available=[[12, 20]])
    (solve,) = _solves(out)
    assert solve.trigger == "forecast"
    assert driver.plan.trigger == "forecast"
    starts = {a.task: a.start for a in driver.plan.activities}
    assert starts["Down"] == 12
    summary = driver.engine.snapshot().last_solve
    assert summary is not None and summary.trigger == "forecast"
    # The forecast is part of the problem from now on.
    schedule = driver.engine.snapshot().schedule
    assert schedule is not None
    binary = schedule.problem.resources.binary
    assert isinstance(binary, dict)  # the forecast wrote windows
    antenna = binary["antenna"]
    assert antenna.available == ((0, 2), (12, 20))


def test_a_forecast_the_plan_still_meets_does_not_replan() -> None:
    """Tests that a forecast the plan meets is taken without a solve."""
    driver = _pass()
    out = driver.forecast("antenna", 2, available=[[4, 10]])
    assert _solves(out) == []
    assert any(isinstance(c, Log) and "still holds" in c.text for c in out)
    assert driver.plan.trigger == "initial"
    out = driver.forecast("power", 1, steps=[[1, 2], [20, 0]])
    assert _solves(out) == []


def test_power_dropping_under_a_running_task_degrades_the_plan() -> None:
    """Tests a power forecast below what a running task that cannot stop
    uses: the forecast replan is infeasible, and the degraded path sheds
    the task, saying it was the stepped power capacity."""
    driver = _pass()
    driver.tick(1)
    out = driver.forecast("power", 1, steps=[[1, 2], [2, 1], [10, 2]])
    solves = _solves(out)
    assert {solve.trigger for solve in solves} == {"forecast"}
    assert solves[0].problem.resources.capacity_profile("power", 0, 12) == [
        2,
        2,
        1,
        1,
        1,
        1,
        1,
        1,
        1,
        1,
        2,
        2,
    ]
    plan = driver.plan
    assert (plan.trigger, plan.status.value) == ("forecast", "degraded")
    (shed,) = [b for b in plan.why if b.task == "Survey"]
    assert "power capacity below its use at every start" in shed.detail


def test_an_invalid_forecast_is_rejected_with_its_reasons() -> None:
    """Tests that a forecast of the wrong kind, with unsorted windows or
    of an unknown resource is answered ``input_rejected`` with paths."""
    driver = _pass()

    def paths(out: list[Command]) -> dict[str, str]:
        (status,) = statuses(out, "input_rejected")
        return {issue.path: issue.reason for issue in status.errors}

    found = paths(driver.forecast("antenna", 2, steps=[[2, 1]]))
    assert set(found) == {"steps", "available"}
    assert "its forecast carries 'available'" in found["steps"]
    found = paths(
        driver.forecast("antenna", 2, available=[[10, 20], [15, 25]])
    )
    assert "sorted and disjoint" in found["available[1]"]
    found = paths(driver.forecast("power", 5, steps=[[6, 1]]))
    assert "after at 5" in found["steps[0][0]"]
    found = paths(driver.forecast("laser", 2, available=[[10, 20]]))
    assert "unknown resource" in found["resource"]
    assert driver.plan.trigger == "initial"


def test_a_forecast_during_a_solve_applies_to_its_plan() -> None:
    """Tests that a forecast arriving while a solve runs is taken into the
    plan that solve gives, which then replans if the forecast breaks it."""
    driver = _pass()
    driver.hold = True
    driver.goal(small_goal("g1", "Ping"), 1)
    assert len(driver.held) == 1
    driver.forecast("antenna", 2, available=[[12, 20]])
    out = driver.finish()
    plans = published(out, messages.PlanMessage)
    assert [p.trigger for p in plans] == ["goal"]
    (solve,) = driver.held
    assert solve.trigger == "forecast"
    driver.finish()
    assert {a.task: a.start for a in driver.plan.activities}["Down"] == 12
