"""Tests of degraded plans: shedding mandatory tasks the world made
impossible (fsw_scheduler.replan.shed and its use by the engine)."""

from __future__ import annotations

import json

import msgspec

from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.engine.config import EngineConfig
from fsw_scheduler.model.plan import Plan, SolveStatus
from fsw_scheduler.model.problem import Problem, decode_problem
from fsw_scheduler.replan.shed import (
    MANDATORY_LOSS,
    PARTNER_LOSS,
    mandatory_closure,
    shed_tasks,
    shedding_problem,
    without_tasks,
)
from fsw_scheduler.replan.triggers import apply_failure
from fsw_scheduler.solving.solve import solve
from fsw_scheduler.wire import messages

from ..engine.driver import Driver, published, small_goal, statuses


def _task(name: str, cost: int, **extra: object) -> dict:
    return {
        "id": name,
        "length": 4,
        "delay_cost": 1,
        "schedule_cost": cost,
        "preemption": "from_start",
        "uses": {"camera": 1},
        **extra,
    }


def three_mandatory() -> Problem:
    """Three mandatory 4-unit camera tasks; A and B must end by 8."""
    return decode_problem(
        json.dumps(
            {
                "horizon": 12,
                "resources": {"binary": ["camera"]},
                "tasks": [
                    _task("A", 0, feasible_interval=[0, 8]),
                    _task("B", 0, feasible_interval=[0, 8]),
                    _task("C", 0),
                    {**_task("Cal", 2), "length": 1, "uses": {}},
                ],
                "precedences": [
                    {"before": "Cal", "after": "C", "kind": "lax"},
                ],
            }
        )
    )


def test_mandatory_closure_follows_what_mandatory_tasks_need() -> None:
    """Tests that the partners a mandatory task needs join the closure."""
    problem = three_mandatory()
    assert mandatory_closure(problem) == ["A", "B", "C", "Cal"]
    shedding = shedding_problem(problem)
    costs = {t.id: t.schedule_cost for t in shedding.tasks}
    assert costs == {
        "A": MANDATORY_LOSS,
        "B": MANDATORY_LOSS,
        "C": MANDATORY_LOSS,
        "Cal": PARTNER_LOSS,
    }
    assert not any(t.mandatory for t in shedding.tasks)


def test_a_pinned_task_keeps_its_start_but_may_be_shed() -> None:
    """Tests that fixed_start becomes a one-unit start window."""
    problem = three_mandatory()
    pinned = problem.replace(
        tasks=tuple(
            msgspec.structs.replace(t, fixed_start=5) if t.id == "C" else t
            for t in problem.tasks
        )
    )
    (c,) = (t for t in shedding_problem(pinned).tasks if t.id == "C")
    assert c.fixed_start is None and not c.mandatory
    assert c.feasible_interval == (5, 5)
    assert c.feasible_interval_applies_to == "start"


def test_failure_that_leaves_no_room_sheds_exactly_one_task() -> None:
    """Tests the shed step on a failure replan: fewest losses, valid plan."""
    driver = Driver(three_mandatory(), EngineConfig())
    driver.tick(0)
    first = driver.plan
    assert first.status is SolveStatus.OPTIMAL and not first.unscheduled
    starts = {a.task: a.start for a in first.activities}
    failed = min(("A", "B"), key=starts.__getitem__)
    driver.tick(starts[failed])
    driver.report(failed, "running", starts[failed])
    out = driver.tick(starts[failed] + 2)
    out += driver.report(failed, "failed", starts[failed] + 2)
    plans = published(out, messages.PlanMessage)
    assert plans, "a failure replan publishes a plan"
    degraded = plans[-1]
    assert degraded.status is SolveStatus.DEGRADED
    shed = [b for b in degraded.why if b.cause == "shed"]
    assert len(shed) == 1 and shed[0].task in ("A", "B")
    # The trigger is named (the harness solves without explanations).
    assert "failure at t=" in shed[0].detail
    assert any(r.rule == "shed" for r in degraded.removed)
    # The rest still flies: C and the other of A/B are scheduled.
    flying = {a.task for a in degraded.activities}
    assert "C" in flying and ({"A", "B"} - {shed[0].task}) <= flying
    schedule = driver.engine.schedule
    assert schedule is not None
    report = check_plan(schedule.problem, schedule.plan)
    assert report.ok, report
    (alarm,) = statuses(out, "alarm")
    assert alarm.state == "degraded" and shed[0].task in alarm.detail


def test_paper_battery_far_below_prediction_gives_a_degraded_plan() -> None:
    """Tests the paper scenario: a battery reading far below the plan
    while a downlink runs. The plan is not kept; a degraded one flies, an
    alarm names the task and the battery, and later goals are judged on
    their own merits."""
    driver = Driver()
    driver.tick(0)
    driver.tick(1)
    driver.report("DownlinkSat2Sat", "running", 1)
    driver.tick(3)
    out = driver.level("battery", 1.0, 3)
    (plan,) = published(out, messages.PlanMessage)
    assert plan.status is SolveStatus.DEGRADED and plan.plan_id == 2
    (shed,) = (b for b in plan.why if b.cause == "shed")
    assert shed.task == "DownlinkSat2Sat"
    assert "consumable" in shed.detail and "battery" in shed.detail
    (alarm,) = statuses(out, "alarm")
    assert "DownlinkSat2Sat" in alarm.detail
    assert driver.engine.status().state == "degraded"
    assert driver.engine.status().activities["DownlinkSat2Sat"] == (
        "preempted"
    )
    schedule = driver.engine.schedule
    assert schedule is not None
    assert check_plan(schedule.problem, schedule.plan).ok
    # A goal afterwards is evaluated on its own merits.
    out = driver.goal(small_goal("after-alarm", "Ping"), 4)
    assert statuses(out, "goal_accepted")
    assert driver.plan.status is SolveStatus.OPTIMAL
    assert driver.engine.status().state == "ok"


def test_goal_that_does_not_fit_is_still_rejected_not_shed() -> None:
    """Tests that only the world, never a goal, causes shedding."""
    driver = Driver()
    driver.tick(0)
    goal = {
        "goal_id": "too-much",
        "tasks": [
            {
                "id": "Huge",
                "length": 40,
                "delay_cost": 1,
                "schedule_cost": 0,
                "uses": {"battery": 5},
            }
        ],
    }
    out = driver.goal(goal, 1)
    assert statuses(out, "goal_rejected")
    assert not statuses(out, "alarm")
    assert driver.plan.plan_id == 1


def test_without_tasks_cascades_tight_followers() -> None:
    """Tests that shedding a task takes its tight followers with it."""
    problem = decode_problem(
        json.dumps(
            {
                "horizon": 20,
                "resources": {"binary": ["camera"]},
                "tasks": [
                    _task("Point", 0),
                    _task("Shoot", 3),
                    _task("Send", 3),
                ],
                "precedences": [
                    {"before": "Point", "after": "Shoot", "kind": "tight"},
                    {"before": "Shoot", "after": "Send", "kind": "lax"},
                ],
            }
        )
    )
    plan = solve(problem, "cbc", explain=False)
    from fsw_scheduler.replan.schedule import Schedule

    schedule = Schedule.begin(problem, plan)
    replan = apply_failure(schedule, "Point", 0, now=1)
    smaller = without_tasks(replan, ("Point",), "test")
    names = {t.id for t in smaller.problem.tasks}
    assert names == {"Send"}
    rules = {r.task: r.rule for r in smaller.removed}
    assert rules["Point"] == "shed" and rules["Shoot"] == "tight_cascade"
    assert shed_tasks(problem, Plan(SolveStatus.OPTIMAL, None)) == ()


def test_a_mandatory_group_that_no_longer_fits_is_shed_whole() -> None:
    """Tests shedding with alternatives: a mandatory group none of whose
    options can run any more (the antenna has no window left) is made
    optional in the shedding problem, left out there, and shed with all
    its members."""
    problem = decode_problem(
        json.dumps(
            {
                "horizon": 8,
                "resources": {
                    "binary": {"camera": {}, "antenna": {"available": []}}
                },
                "tasks": [
                    _task("A", 0),
                    _task("B", 0),
                    {**_task("HF", 0), "length": 3, "uses": {"antenna": 1}},
                    {**_task("LF", 0), "length": 2, "uses": {"antenna": 1}},
                ],
                "alternatives": [
                    {
                        "id": "img",
                        "schedule_cost": 0,
                        "options": [["HF"], ["LF"]],
                    }
                ],
            }
        )
    )
    assert solve(problem).status is SolveStatus.INFEASIBLE
    shedding = shedding_problem(problem)
    assert [g.schedule_cost for g in shedding.alternatives] == [MANDATORY_LOSS]
    plan = solve(shedding)
    assert check_plan(shedding, plan).ok
    assert plan.unscheduled == ("img",)
    assert shed_tasks(problem, plan) == ("HF", "LF")
