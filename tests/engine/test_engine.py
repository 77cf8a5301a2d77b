"""Tests of the functional core: events in, commands out, no bus."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING, Any

import pytest

from fsw_scheduler.engine.config import HELD_REPORTS, EngineConfig
from fsw_scheduler.engine.core import Engine
from fsw_scheduler.engine.events import (
    ClockStalled,
    Command,
    InputRejected,
    Log,
    NodePaused,
    ReportArrived,
    SolveFailed,
    StartSolve,
    Tick,
)
from fsw_scheduler.errors import FieldIssue
from fsw_scheduler.model.levels import predicted_levels
from fsw_scheduler.model.problem import Problem, decode_problem
from fsw_scheduler.runtime.config import NodeConfig
from fsw_scheduler.runtime.policy import engine_config
from fsw_scheduler.wire import messages

if TYPE_CHECKING:
    from fsw_scheduler.model.plan import Activity

from ..factories import make_doc, make_task, problem_from
from .driver import (
    Driver,
    encoded,
    paper,
    paper_goal,
    published,
    small_goal,
    statuses,
)


@pytest.fixture
def started() -> Driver:
    """An engine on Table 1 that has adopted its initial plan at t=0."""
    driver = Driver()
    driver.tick(0)
    return driver


# -- the initial plan and dispatching --------------------------------------


def test_initial_plan_at_first_tick() -> None:
    """Tests that the first tick starts the initial solve and adopts plan 1."""
    driver = Driver()
    assert driver.engine.plan_message is None
    out = driver.tick(0)
    starts = [c for c in out if isinstance(c, StartSolve)]
    assert [s.trigger for s in starts] == ["initial"]
    (plan,) = published(out, messages.PlanMessage)
    assert (plan.plan_id, plan.trigger, plan.issued_at) == (1, "initial", 0)
    assert plan.status.value == "optimal"
    assert (plan.horizon_start, plan.horizon_end) == (0, 50)
    tasks = {a.task for a in plan.activities} | set(plan.unscheduled)
    assert tasks == {t.id for t in paper().tasks}
    assert statuses(out, "plan")[-1].plan_id == 1


def test_goal_before_first_tick_is_rejected() -> None:
    """Tests that a goal arriving before any plan exists is rejected."""
    driver = Driver()
    out = driver.goal(small_goal("early", "Ping"), 0)
    (status,) = statuses(out, "goal_rejected")
    assert status.goal_id == "early"
    assert "no plan yet" in status.errors[0].reason
    assert not [c for c in out if isinstance(c, StartSolve)]


def test_dispatch_on_time(started: Driver) -> None:
    """Tests that each activity is dispatched at its start, not before."""
    plan = started.plan
    starts = {a.task: a.start for a in plan.activities}
    dispatched: dict[str, messages.Dispatch] = {}
    for d in published(started.history, messages.Dispatch):
        dispatched[d.task] = d
    for now in range(1, 8):
        before = set(dispatched)
        for d in published(started.tick(now), messages.Dispatch):
            dispatched[d.task] = d
        due = {t for t, s in starts.items() if s <= now}
        assert set(dispatched) == due, now
        assert not {t for t in set(dispatched) - before if starts[t] != now}
    for task, d in dispatched.items():
        activity = next(a for a in plan.activities if a.task == task)
        assert (d.start, d.end, d.dispatched_at) == (
            activity.start,
            activity.end,
            activity.start,
        )
        assert d.plan_id == 1
        assert not d.late
        assert d.uses == paper().task(task).uses


def test_late_plan_dispatches_late() -> None:
    """Tests that a plan adopted after its activities' starts flags late."""
    driver = Driver(hold=True)
    driver.tick(0)
    driver.tick(1)
    driver.tick(2)
    assert not published(driver.history, messages.Dispatch)
    out = driver.finish()
    dispatches = {d.task: d for d in published(out, messages.Dispatch)}
    plan = driver.plan
    due = {a.task: a.start for a in plan.activities if a.start <= 2}
    assert set(dispatches) == set(due)
    for task, start in due.items():
        assert dispatches[task].late is (start < 2)
        assert dispatches[task].dispatched_at == 2
    late = sum(d.late for d in dispatches.values())
    assert late > 0
    status = driver.engine.status()
    assert status.counters.late_dispatches == late


def test_plan_ids_strictly_increase(started: Driver) -> None:
    """Tests that plan ids rise by one with every adopted plan."""
    started.tick(1)
    started.goal(small_goal("g1", "Ping1"), 1)
    started.tick(2)
    started.level("battery", 30.0, 2)
    started.goal(small_goal("g2", "Ping2"), 2)
    ids = [p.plan_id for p in published(started.history, messages.PlanMessage)]
    assert len(ids) >= 4
    assert ids == list(range(1, len(ids) + 1))
    records = published(started.history, messages.SolveRecord)
    assert [r.plan_id for r in records] == ids


# -- goals -------------------------------------------------------------------


def test_goal_id_collision_rejected_plan_untouched(started: Driver) -> None:
    """Tests that a goal reusing a live task id is rejected as a whole."""
    before = started.plan
    goal = small_goal("clash", "Ping", "BatteryCharge")
    out = started.goal(goal, 0)
    (status,) = statuses(out, "goal_rejected")
    assert status.goal_id == "clash"
    assert [e.path for e in status.errors] == ["tasks[1].id"]
    assert "BatteryCharge" in status.errors[0].reason
    assert not [c for c in out if isinstance(c, StartSolve)]
    assert not published(out, messages.PlanMessage)
    assert started.plan is before
    assert started.engine.status().counters.goals_rejected == 1


def test_goals_during_a_solve_are_coalesced() -> None:
    """Tests that two goals arriving during a solve share the next solve."""
    driver = Driver(hold=True)
    driver.tick(0)
    driver.finish()
    driver.goal(small_goal("first", "PingA"), 1)
    assert len(driver.held) == 1
    out = driver.goal(small_goal("second", "PingB"), 1)
    out += driver.goal(small_goal("third", "PingC"), 1)
    assert not [c for c in out if isinstance(c, StartSolve)]
    assert len(driver.held) == 1
    driver.finish()  # "first" adopted; the two others start one solve
    assert driver.plan.goals == ("first",)
    assert len(driver.held) == 1
    assert driver.held[0].trigger == "goal"
    driver.finish()
    plan = driver.plan
    assert plan.goals == ("second", "third")
    assert {"PingB", "PingC"} <= {a.task for a in plan.activities}
    solves = [c for c in driver.history if isinstance(c, StartSolve)]
    assert [s.trigger for s in solves] == ["initial", "goal", "goal"]
    accepted = statuses(driver.history, "goal_accepted")
    assert [s.goal_id for s in accepted] == ["first", "second", "third"]


def mandatory_problem() -> Problem:
    """A mandatory task M in [5, 10] on a camera, and an optional task."""
    return decode_problem(
        json.dumps(
            {
                "horizon": 30,
                "resources": {
                    "binary": ["camera"],
                    "consumable": {"battery": 10},
                },
                "tasks": [
                    {
                        "id": "M",
                        "length": 5,
                        "delay_cost": 1,
                        "schedule_cost": 0,
                        "feasible_interval": [5, 10],
                        "feasible_interval_applies_to": "start",
                        "uses": {"camera": 1},
                    },
                    {
                        "id": "Opt",
                        "length": 2,
                        "delay_cost": 1,
                        "schedule_cost": 2,
                        "uses": {"battery": 1},
                    },
                ],
            }
        )
    )


def test_goal_making_mandatory_task_infeasible() -> None:
    """Tests that a goal leaving no room for a mandatory task is rejected."""
    driver = Driver(mandatory_problem())
    driver.tick(0)
    before = driver.plan
    goal = {
        "goal_id": "blocker",
        "tasks": [
            {
                "id": "Long",
                "length": 20,
                "delay_cost": 1,
                "schedule_cost": 1,
                "uses": {"camera": 1},
            }
        ],
        # M needs Long before it: M could only start after its window.
        "precedences": [
            {
                "before": "Long",
                "after": "M",
                "kind": "lax",
                "scope": "at_least_first",
            }
        ],
    }
    out = driver.goal(goal, 1)
    (status,) = statuses(out, "goal_rejected")
    assert status.goal_id == "blocker"
    assert "infeasible" in status.errors[0].reason
    assert status.state == "degraded"
    assert status.plan_id == before.plan_id
    assert driver.plan is before
    assert not published(out, messages.PlanMessage)
    records = published(out, messages.SolveRecord)
    assert records[-1].status.value == "infeasible"
    assert records[-1].plan_id is None


def test_goal_with_mandatory_task_accepted(started: Driver) -> None:
    """Tests that a feasible goal with a mandatory task is accepted."""
    goal = small_goal("must", "MustDo")
    goal["tasks"][0]["schedule_cost"] = 0
    out = started.goal(goal, 0)
    assert statuses(out, "goal_accepted")
    assert "MustDo" in {a.task for a in started.plan.activities}


def test_solve_failed_keeps_the_plan(started: Driver) -> None:
    """Tests that a crashed solve leaves the plan and rejects its goal."""
    started.hold = True
    before = started.plan
    started.goal(small_goal("doomed", "Ping"), 1)
    (command,) = started.held
    out = started.step(SolveFailed(command.solve_id, "SolverError: boom"))
    (status,) = statuses(out, "goal_rejected")
    assert status.goal_id == "doomed"
    assert "boom" in status.errors[0].reason
    assert status.state == "degraded"
    assert started.plan is before
    summary = started.engine.status().last_solve
    assert summary is not None
    assert summary.reason == "SolverError: boom"
    assert not summary.adopted
    # The next plan clears the degraded state.
    started.hold = False
    started.goal(small_goal("fine", "Pong"), 2)
    assert started.plan.plan_id == before.plan_id + 1
    assert started.engine.status().state == "ok"


def test_solve_failed_without_goal_reports_solve_failed(
    started: Driver,
) -> None:
    """Tests that a crashed replan with no goal says solve_failed."""
    started.hold = True
    started.tick(1)
    started.report("DownlinkSat2Sat", "failed", 1)
    (command,) = started.held
    out = started.step(SolveFailed(command.solve_id, "boom"))
    (status,) = statuses(out, "solve_failed")
    assert status.state == "degraded"
    assert started.plan.plan_id == 1


# -- execution reports, timeouts and levels ---------------------------------


def test_failure_report_triggers_failure_replan(started: Driver) -> None:
    """Tests that a failed activity report causes a replan from `failure`."""
    started.tick(1)
    started.report("DownlinkSat2Sat", "running", 1)
    started.tick(2)
    out = started.report("DownlinkSat2Sat", "failed", 2)
    assert statuses(out, "activity")[0].detail == "DownlinkSat2Sat failed at 2"
    (plan,) = published(out, messages.PlanMessage)
    assert (plan.plan_id, plan.trigger, plan.issued_at) == (2, "failure", 2)
    assert "DownlinkSat2Sat" not in plan.continuing
    assert started.engine.status().counters.reports == 2


def test_report_timeout_counts_as_failure() -> None:
    """Tests that a dispatch without a report in time counts as failed."""
    driver = Driver(config=EngineConfig(report_timeout=2))
    driver.tick(0)
    driver.tick(1)
    driver.report("SetPositionX", "completed", 1)
    assert not [c for c in driver.tick(2) if isinstance(c, StartSolve)]
    out = driver.tick(3)
    warnings = [c.text for c in out if isinstance(c, Log)]
    assert any(
        "SetHFOption: no report 2 units after dispatch" in w for w in warnings
    )
    solves = [c for c in out if isinstance(c, StartSolve)]
    assert [s.trigger for s in solves] == ["failure"]
    (plan,) = published(out, messages.PlanMessage)
    assert plan.trigger == "failure"
    assert "SetHFOption" in {a.task for a in plan.activities}
    redispatch = [
        d for d in published(out, messages.Dispatch) if d.task == "SetHFOption"
    ]
    assert redispatch and redispatch[0].plan_id == plan.plan_id


def test_two_report_timeouts_both_count() -> None:
    """Tests that two activities timing out together are both failures."""
    driver = Driver(config=EngineConfig(report_timeout=2))
    driver.tick(0)  # SetHFOption and SetPositionX dispatched, never reported
    out = driver.tick(3)
    ignored = [
        c.text
        for c in out
        if isinstance(c, Log) and c.text.startswith("failure ignored")
    ]
    assert ignored == []
    finished = {r.task for r in driver.plan.removed if r.rule == "finished"}
    assert "SetPositionX" not in finished


def battery_at(driver: Driver, at: int) -> float:
    """The battery level the current plan predicts at the start of ``at``."""
    schedule = driver.engine.schedule
    assert schedule is not None
    return predicted_levels(schedule.problem, schedule.plan, at)["battery"]


def test_drift_beyond_tolerance_replans(started: Driver) -> None:
    """Tests that a level departing from the prediction triggers a replan."""
    for now in range(1, 6):
        started.tick(now)
    predicted = battery_at(started, 5)
    out = started.level("battery", predicted + 4.0, 5)
    (drift,) = statuses(out, "drift")
    assert "battery measured" in drift.detail
    (plan,) = published(out, messages.PlanMessage)
    assert (plan.plan_id, plan.trigger) == (2, "drift")


@pytest.mark.parametrize("offset", [0.0, 0.4, -0.4])
def test_drift_within_tolerance_keeps_plan(
    started: Driver, offset: float
) -> None:
    """Tests that a level within the tolerance causes no replan."""
    for now in range(1, 6):
        started.tick(now)
    predicted = battery_at(started, 5)
    out = started.level("battery", predicted + offset, 5)
    assert not [c for c in out if isinstance(c, StartSolve)]
    assert not statuses(out, "drift")
    assert not published(out, messages.PlanMessage)
    assert started.plan.plan_id == 1


def test_report_for_unknown_task_rejected(started: Driver) -> None:
    """Tests that a report on a task nobody planned is an input_rejected."""
    out = started.report("Nope", "running", 0)
    (status,) = statuses(out, "input_rejected")
    assert [e.path for e in status.errors] == ["task"]
    assert "Nope" in status.errors[0].reason
    assert started.engine.status().counters.inputs_rejected == 1
    assert started.plan.plan_id == 1


def test_level_for_unknown_resource_rejected(started: Driver) -> None:
    """Tests that a level of a resource that is not consumable is rejected."""
    out = started.level("power", 3.0, 0)
    (status,) = statuses(out, "input_rejected")
    assert [e.path for e in status.errors] == ["resource"]


@pytest.mark.parametrize(
    ("kind", "goal_id", "event"),
    [
        ("clock", None, "input_rejected"),
        ("activity_report", None, "input_rejected"),
        ("goal", "g-bad", "goal_rejected"),
    ],
)
def test_input_rejected_reported_in_status(
    started: Driver, kind: str, goal_id: str | None, event: str
) -> None:
    """Tests that an undecodable input becomes a status naming the field."""
    issue = FieldIssue("now", "expected `int`, got `str`")
    out = started.step(
        InputRejected(f"fsw/sat1/{kind}", kind, (issue,), goal_id)
    )
    (status,) = statuses(out, event)
    assert status.errors == (issue,)
    assert status.goal_id == goal_id
    assert started.plan.plan_id == 1
    counters = started.engine.status().counters
    assert (counters.goals_rejected, counters.inputs_rejected) == (
        (1, 0) if kind == "goal" else (0, 1)
    )


def test_dropped_inputs_count_is_a_total(started: Driver) -> None:
    """Tests that the dropped-input counter follows the shell's total."""
    started.engine.count_shell(inputs_dropped=3)
    assert started.engine.status().counters.inputs_dropped == 3
    started.engine.count_shell(inputs_dropped=5)
    assert started.engine.status().counters.inputs_dropped == 5


# -- determinism and the paper's story -------------------------------------


def _session(driver: Driver) -> list[Command]:
    """A session with goals, reports, a drift and a failure."""
    driver.tick(0)
    for now in range(1, 8):
        driver.tick(now)
        for d in published(driver.history, messages.Dispatch):
            if d.dispatched_at == now:
                driver.report(d.task, "running", now)
    driver.goal(small_goal("g1", "Ping1"), 7)
    driver.goal(paper_goal(), 7)
    driver.level("battery", battery_at(driver, 7) + 3.0, 7)
    driver.report("BatteryCharge", "failed", 8)
    driver.tick(9)
    driver.report("Nope", "running", 9)
    return driver.history


def test_same_events_give_same_commands() -> None:
    """Tests that replaying one event sequence gives identical commands."""
    first = _session(Driver(cache=False))
    second = _session(Driver(cache=False))
    assert len(first) > 20
    assert encoded(first) == encoded(second)


def test_paper_story() -> None:
    """Tests the paper's scenario: Table 1 at 0, the Table 2 goal at 15."""
    driver = Driver()
    running: dict[str, int] = {}
    for now in range(16):
        out = driver.tick(now)
        for task, end in sorted(running.items()):
            if end <= now:  # reported once the clock says so
                driver.report(task, "completed", now)
                del running[task]
        for d in published(out, messages.Dispatch):
            driver.report(d.task, "running", now)
            running[d.task] = now + d.end - d.start
    assert driver.plan.plan_id == 1
    assert set(running) == {"BatteryCharge"}
    out = driver.goal(paper_goal(), 15)
    (plan,) = published(out, messages.PlanMessage)
    assert (plan.plan_id, plan.trigger, plan.goals) == (
        2,
        "goal",
        ("monitor-target-lf",),
    )
    assert plan.continuing == ("BatteryCharge",)
    scheduled = {a.task for a in plan.activities}
    assert {
        "BatteryCharge",
        "AcquisitionLF",
        "SetLFOption",
        "SetPositionZ",
    } <= (scheduled)
    assert not {"AcquisitionHF", "SetHFOption"} & scheduled
    assert not {"AcquisitionHF", "SetHFOption"} & set(plan.unscheduled)
    rules = {r.task: r.rule for r in plan.removed}
    assert rules["AcquisitionHF"] == "obsolete"
    assert (plan.horizon_start, plan.horizon_end) == (15, 65)
    charge = next(a for a in plan.activities if a.task == "BatteryCharge")
    assert charge.end == 17
    lf = next(a for a in plan.activities if a.task == "AcquisitionLF")
    z = next(a for a in plan.activities if a.task == "SetPositionZ")
    assert lf.start == z.end  # tight precedence of the goal
    assert statuses(out, "goal_accepted")[0].goal_id == "monitor-target-lf"


def test_replan_lead_starts_the_new_plan_later() -> None:
    """Tests that a goal's plan starts replan_lead units after it arrives."""
    driver = Driver(config=EngineConfig(replan_lead=2))
    for now in range(16):
        driver.tick(now)
    out = driver.goal(paper_goal(), 15)
    (plan,) = published(out, messages.PlanMessage)
    assert plan.horizon_start == 17
    assert all(a.start >= 17 for a in plan.activities)
    # The old plan kept its dispatch at 15..16 meanwhile.
    assert plan.issued_at == 15


def test_deferred_goal_task_enters_when_the_horizon_reaches_it() -> None:
    """Tests that a task beyond the horizon waits, then gets planned."""
    driver = Driver()
    for now in range(3):
        driver.tick(now)
    goal = {
        "goal_id": "late-pass",
        "tasks": [
            {
                "id": "Pass",
                "length": 2,
                "delay_cost": 1,
                "schedule_cost": 3,
                "feasible_interval": [60, 70],
            },
        ],
    }
    (plan,) = published(driver.goal(goal, 3), messages.PlanMessage)
    assert plan.deferred == ("Pass",)
    assert "Pass" not in {a.task for a in plan.activities}
    planned = None
    for now in range(4, 30):
        for message in published(driver.tick(now), messages.PlanMessage):
            planned = (now, message)
        if planned:
            break
    assert planned is not None
    when, later = planned
    assert later.trigger == "horizon"
    starts = {a.task: a.start for a in later.activities}
    assert starts["Pass"] == 60
    assert when + 50 > 60  # the horizon [when, when + 50) now holds it


def _count_rule_passes(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Count every rule pass a goal gets (the goal ids, in order)."""
    from fsw_scheduler.engine import solves
    from fsw_scheduler.replan import triggers

    passes: list[str] = []

    def counted(*args: Any, **kwargs: Any) -> Any:
        passes.append(args[1].goal_id)
        return triggers.apply_goal(*args, **kwargs)

    monkeypatch.setattr(solves, "apply_goal", counted)
    return passes


def test_one_rule_pass_per_goal_with_the_node_defaults(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Tests that with the engine settings a node gets from its default
    settings (wall clock, a replan lead of one unit), a goal arriving with
    no solve in flight is checked and replanned with one rule pass."""
    config = engine_config(NodeConfig())
    assert config.replan_lead == 1  # the default this test is about
    driver = Driver(config=config)
    driver.tick(0)
    driver.tick(1)
    passes = _count_rule_passes(monkeypatch)
    driver.goal(small_goal("g1", "Ping1"), 1)
    assert passes == ["g1"]
    assert "g1" in driver.plan.goals
    passes.clear()
    driver.tick(2)
    driver.goal(small_goal("g2", "Ping2"), 2)
    assert passes == ["g2"]
    assert "g2" in driver.plan.goals


def test_one_rule_pass_per_goal(
    started: Driver, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Tests that a goal arriving with no solve in flight is checked and
    replanned with one rule pass, and two goals coalesced behind a solve
    with one pass each."""
    passes = _count_rule_passes(monkeypatch)
    # At 0, after the tick's dispatches (a dispatch in the same step
    # changes the schedule, and the pass is rightly made again).
    started.goal(small_goal("g1", "Ping1"), 0)
    assert passes == ["g1"]
    assert "g1" in started.plan.goals

    held = Driver(hold=True)
    held.tick(0)
    held.finish()
    passes.clear()
    held.level("battery", battery_at(held, 0) + 5.0, 0)  # a solve in flight
    held.goal(small_goal("g2", "Ping2"), 0)
    held.goal(small_goal("g3", "Ping3"), 0)
    assert passes == ["g2", "g3"]  # checked on arrival
    passes.clear()
    held.finish()
    # Behind the solve: g2 alone, then g2+g3 (the replan itself).
    assert passes == ["g2", "g2+g3"]


def test_a_dispatch_without_a_report_is_said_once_at_its_end(
    started: Driver,
) -> None:
    """Tests that an activity dispatched and never reported raises one
    ``report_overdue`` status when its planned end comes, and no more."""
    dispatched = {
        d.task: d.end for d in published(started.history, messages.Dispatch)
    }
    assert dispatched
    first_end = min(dispatched.values())
    due = sorted(t for t, end in dispatched.items() if end == first_end)
    out = started.tick(first_end)
    said = statuses(out, "report_overdue")
    assert sorted(s.detail.split(":")[0] for s in said) == due
    later = started.tick(first_end + 1) + started.tick(first_end + 2)
    again = [s.detail.split(":")[0] for s in statuses(later, "report_overdue")]
    assert not set(again) & set(due)


# -- reports that race the clock ---------------------------------------------


def _ahead_driver() -> tuple[Driver, messages.Dispatch]:
    """Table 1 at t=0 with reports one unit ahead held; an activity
    dispatched at 0 that ends at 1."""
    driver = Driver(config=EngineConfig(report_ahead=1))
    driver.tick(0)
    first = next(
        d for d in published(driver.history, messages.Dispatch) if d.end == 1
    )
    return driver, first


def _completed(driver: Driver, dispatch: messages.Dispatch, at: int) -> list:
    report = messages.ActivityReport(
        dispatch.task, "completed", at, dispatch_id=dispatch.dispatch_id
    )
    return driver.step(ReportArrived(report))


def test_a_report_ahead_of_the_clock_is_held_then_applied() -> None:
    """Tests that a report one unit ahead of the node's clock (the
    executor saw a tick the node has not processed) is held, not rejected,
    and applied at the step whose time reaches it."""
    driver, first = _ahead_driver()
    out = _completed(driver, first, 1)
    assert not statuses(out, "input_rejected")
    assert not statuses(out, "activity")
    assert driver.engine.status().activities[first.task] == "dispatched"
    assert driver.engine.snapshot().held
    out = driver.tick(1)
    (said,) = statuses(out, "activity")
    assert said.detail == f"{first.task} completed at 1"
    assert driver.engine.status().activities[first.task] == "completed"
    assert not driver.engine.snapshot().held


def test_a_held_report_survives_a_resume() -> None:
    """Tests that held reports are part of the engine's state: an engine
    rebuilt from its snapshot applies them when the clock reaches them."""
    driver, first = _ahead_driver()
    _completed(driver, first, 1)
    rebuilt = Engine.restore(driver.engine.config, driver.engine.snapshot())
    rebuilt.step(Tick(1), 1)
    assert rebuilt.status().activities[first.task] == "completed"


def test_a_report_beyond_the_tolerance_is_rejected() -> None:
    """Tests that a report further ahead than ``report_ahead`` is rejected
    naming the tolerance, and that at most HELD_REPORTS are held."""
    driver, first = _ahead_driver()
    (rejected,) = statuses(_completed(driver, first, 2), "input_rejected")
    assert "after now (0) by more than report-ahead (1)" in (
        rejected.errors[0].reason
    )
    for _ in range(HELD_REPORTS):
        assert not statuses(_completed(driver, first, 1), "input_rejected")
    (full,) = statuses(_completed(driver, first, 1), "input_rejected")
    assert f"{HELD_REPORTS} reports are held already" in full.errors[0].reason


def test_recorded_sessions_reject_every_report_ahead() -> None:
    """Tests that without ``report_ahead`` (journals recorded before held
    reports) a report ahead of the clock is rejected, as they recorded."""
    driver = Driver()
    driver.tick(0)
    first = published(driver.history, messages.Dispatch)[0]
    assert statuses(_completed(driver, first, 1), "input_rejected")


@pytest.mark.parametrize("level", [1e308, -1e308, float("inf"), 80.6, -0.6])
def test_level_outside_the_store_is_rejected(level: float) -> None:
    """Tests that a measured level beyond a battery's range (capacity 80)
    is ``input_rejected`` on ``level``, never taken as drift."""
    doc = make_doc(
        [make_task("a", length=2, uses={"battery": 10})],
        resources={"consumable": {"battery": {"initial": 60, "max": 80}}},
    )
    driver = Driver(problem_from(doc))
    driver.tick(0)
    out = driver.level("battery", level, 0)
    (status,) = statuses(out, "input_rejected")
    assert [e.path for e in status.errors] == ["level"]
    assert not statuses(out, "drift")
    assert driver.engine.pending_solve() is None


def test_level_inside_the_store_is_drift() -> None:
    """Tests that a level within the range but off the plan is drift."""
    doc = make_doc(
        [make_task("a", length=2, uses={"battery": 10})],
        resources={"consumable": {"battery": {"initial": 60, "max": 80}}},
    )
    driver = Driver(problem_from(doc))
    driver.tick(0)
    out = driver.level("battery", 5.0, 0)
    assert statuses(out, "drift")
    assert not statuses(out, "input_rejected")


def _next_planned(driver: Driver) -> Activity:
    """The next planned activity of the schedule being flown."""
    snapshot = driver.engine.snapshot()
    assert snapshot.schedule is not None and snapshot.now is not None
    return min(
        (
            a
            for a in snapshot.schedule.plan.activities
            if a.start > snapshot.now
            and snapshot.lifecycle.get(a.task) == "planned"
        ),
        key=lambda a: a.start,
    )


@pytest.mark.parametrize("paused", [True, False])
def test_a_pause_of_this_node_dispatches_late_not_missed(paused: bool) -> None:
    """Tests the clock jump after this node's own pause (a stall under its
    lease, said by ``NodePaused``): what the jump passed over is
    dispatched late (``late: true``), with a ``paused`` status; the same
    jump without the pause is the bus's, and the activity is missed."""
    driver = Driver()
    driver.tick(0)
    now = 0
    # Unit by unit (no jump) until an activity starts two units on.
    while (activity := _next_planned(driver)).start > now + 2:
        now += 1
        driver.tick(now)
    if paused:
        out = driver.step(NodePaused(1.6, now))
        (said,) = statuses(out, "paused")
        assert "1.6 s" in said.detail
    out = driver.tick(activity.start + 1)
    sent = {d.task: d for d in published(out, messages.Dispatch)}
    missed = statuses(out, "activity_missed")
    if paused:
        assert sent[activity.task].late
        assert not missed
        # Only the jump right after the pause: the next one is the bus's.
        assert driver.engine.snapshot().paused_at is None
    else:
        assert activity.task not in sent
        assert missed


def test_level_before_any_plan_is_answered() -> None:
    """Tests that a level arriving before the first plan is rejected with
    its reason, not dropped in silence."""
    driver = Driver()
    out = driver.level("battery", 3.0, 0)
    (status,) = statuses(out, "input_rejected")
    assert "no plan yet" in status.errors[0].reason
    assert "telemetry/resources/battery" in status.detail


def test_a_level_the_replan_cannot_use_is_answered() -> None:
    """Tests a drift queued behind a goal's solve whose time the goal's
    plan has left behind: ``input_rejected`` on the level's key names why
    (it was a log line only)."""
    driver = Driver(hold=True)
    driver.tick(0)
    driver.finish()
    for now in range(1, 6):
        driver.tick(now)
    driver.goal(small_goal("g1", "Ping"))
    predicted = battery_at(driver, 3)
    out = driver.level("battery", predicted + 6.0, 3)
    assert statuses(out, "drift")
    out = driver.finish()
    (status,) = statuses(out, "input_rejected")
    assert status.detail.startswith("resource_level on ")
    assert "telemetry/resources/battery" in status.detail
    assert [e.path for e in status.errors] == ["at"]
    assert driver.engine.status().counters.inputs_rejected == 1


def test_a_plan_adopted_while_the_clock_is_stalled_keeps_it_said() -> None:
    """Tests a stall during the initial solve: the plan adopted meanwhile
    does not clear ``bus clock stalled`` (it did, so the next tick never
    said ``clock_resumed``); the next tick does."""
    driver = Driver(hold=True)
    driver.tick(0)
    out = driver.step(ClockStalled(31.0, 0))
    assert statuses(out, "clock_stalled")
    driver.finish()
    status = driver.engine.status()
    assert status.plan_id == 1
    assert (status.state, status.detail[:17]) == (
        "degraded",
        "bus clock stalled",
    )
    out = driver.tick(1)
    (resumed,) = statuses(out, "clock_resumed")
    assert resumed.state == "ok"


# -- early completion ----------------------------------------------------


def _observe_then_downlink() -> Problem:
    """Observe [0, 6) on the camera and battery, Downlink lax after it,
    and Calibrate waiting for the camera."""
    return decode_problem(
        json.dumps(
            {
                "horizon": 30,
                "resources": {
                    "binary": ["camera"],
                    "consumable": {"battery": 20},
                },
                "tasks": [
                    {
                        "id": "Observe",
                        "length": 6,
                        "delay_cost": 5,
                        "schedule_cost": 0,
                        "uses": {"camera": 1, "battery": 2},
                    },
                    {
                        "id": "Downlink",
                        "length": 2,
                        "delay_cost": 1,
                        "schedule_cost": 1,
                    },
                    {
                        "id": "Calibrate",
                        "length": 2,
                        "delay_cost": 1,
                        "schedule_cost": 1,
                        "uses": {"camera": 1},
                    },
                ],
                "precedences": [
                    {"before": "Observe", "after": "Downlink", "kind": "lax"}
                ],
            }
        )
    )


def _completed_at_2(gain: int) -> tuple[Driver, list[Command]]:
    driver = Driver(
        _observe_then_downlink(),
        EngineConfig(early_completion_gain=gain),
    )
    driver.tick(0)
    starts = {a.task: a.start for a in driver.plan.activities}
    assert starts == {"Observe": 0, "Downlink": 6, "Calibrate": 6}
    driver.report("Observe", "running", 0)
    driver.tick(1)
    driver.tick(2)
    return driver, driver.report("Observe", "completed", 2)


def test_early_completion_pulls_successors_and_waiters_forward() -> None:
    """Tests that a completion 4 units before the end of its dispatch,
    with a gain of 3, replans at once (trigger ``early_completion``):
    the lax successor and the task waiting for the camera start at 2, and
    the battery counts only the 2 units Observe ran."""
    driver, out = _completed_at_2(3)
    (solve,) = [c for c in out if isinstance(c, StartSolve)]
    assert solve.trigger == "early_completion"
    assert solve.problem.start == 2
    assert solve.problem.resources.initial("battery") == 20 - 2 * 2
    (plan,) = published(out, messages.PlanMessage)
    assert plan.trigger == "early_completion"
    starts = {a.task: a.start for a in plan.activities}
    assert starts == {"Downlink": 2, "Calibrate": 2}
    status = driver.engine.status()
    assert status.last_solve is not None
    assert status.last_solve.trigger == "early_completion"


def test_a_smaller_gain_replans_nothing() -> None:
    """Tests that a completion 4 units early with a gain of 5 (or with
    the default, 0: off) replans nothing: the plan stays, successors keep
    their starts."""
    for gain in (5, 0):
        driver, out = _completed_at_2(gain)
        assert not [c for c in out if isinstance(c, StartSolve)]
        assert driver.plan.plan_id == 1
        starts = {a.task: a.start for a in driver.plan.activities}
        assert starts["Downlink"] == 6
