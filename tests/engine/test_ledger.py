"""Tests of every input answered once: the goal ledger and reports that
must answer a dispatch."""

from __future__ import annotations

import json

import msgspec

from fsw_scheduler.engine.config import EngineConfig
from fsw_scheduler.engine.core import Engine
from fsw_scheduler.engine.events import (
    ReportArrived,
    StartSolve,
    TermBegan,
)
from fsw_scheduler.engine.snapshot import EngineSnapshot
from fsw_scheduler.wire import messages

from .driver import Driver, published, small_goal, statuses


def _started() -> Driver:
    driver = Driver()
    driver.tick(0)
    return driver


def _solves(out: list) -> list[StartSolve]:
    return [c for c in out if isinstance(c, StartSolve)]


def test_identical_retransmission_gets_its_verdict_again() -> None:
    """Tests that the same goal again (other JSON spelling) changes
    nothing and is answered goal_accepted again."""
    driver = _started()
    driver.goal(small_goal("g1", "Ping"), 1)
    plan_id = driver.plan.plan_id
    # Same content, keys in another order.
    again = json.loads(json.dumps(small_goal("g1", "Ping"), sort_keys=True))
    out = driver.goal(again, 2)
    assert not _solves(out)
    (answer,) = statuses(out, "goal_accepted")
    assert answer.goal_id == "g1" and "again" in answer.detail
    assert driver.plan.plan_id == plan_id
    assert driver.engine.status().counters.goals_accepted == 1


def test_other_content_under_a_used_id_is_rejected() -> None:
    """Tests that a goal id accepted once cannot carry another goal."""
    driver = _started()
    driver.goal(small_goal("g1", "Ping"), 1)
    out = driver.goal(small_goal("g1", "Pong"), 2)
    (rejected,) = statuses(out, "goal_rejected")
    assert rejected.errors[0].path == "goal_id"
    assert "taken by another goal" in rejected.errors[0].reason
    assert "Pong" not in {a.task for a in driver.plan.activities}
    # And the original still stands: its retransmission is accepted.
    assert statuses(driver.goal(small_goal("g1", "Ping"), 3), "goal_accepted")


def test_a_finished_goal_is_never_executed_again() -> None:
    """Tests a goal re-sent after its task flew, also after a restart."""
    driver = _started()
    driver.goal(small_goal("g1", "Ping"), 1)
    ping = next(a for a in driver.plan.activities if a.task == "Ping")
    for now in range(2, ping.end + 2):
        driver.tick(now)
        if now == ping.start + 1:
            driver.report("Ping", "running", now)
        if now == ping.end + 1:
            driver.report("Ping", "completed", now)
    data = msgspec.json.encode(driver.engine.snapshot())
    restarted = Driver()
    restarted.engine = Engine.restore(
        EngineConfig(), msgspec.json.decode(data, type=EngineSnapshot)
    )
    restarted.now = driver.now
    for engine_driver in (driver, restarted):
        out = engine_driver.goal(small_goal("g1", "Ping"), engine_driver.now)
        assert not _solves(out)
        assert not published(out, messages.Dispatch)
        assert statuses(out, "goal_accepted")


def test_a_rejected_id_may_be_used_again() -> None:
    """Tests that a rejection leaves no ledger entry: a corrected goal
    under the same id is accepted."""
    driver = _started()
    bad = small_goal("g1", "Ping")
    bad["tasks"][0]["uses"] = {"nope": 1}
    assert statuses(driver.goal(bad, 1), "goal_rejected")
    assert statuses(driver.goal(small_goal("g1", "Ping"), 2), "goal_accepted")


def test_an_expired_goal_is_rejected() -> None:
    """Tests ``not_after``: a goal arriving later is rejected, naming it."""
    driver = _started()
    goal = {**small_goal("late", "Ping"), "not_after": 3}
    out = driver.goal(goal, 4)
    (rejected,) = statuses(out, "goal_rejected")
    assert rejected.errors[0].path == "not_after"
    assert statuses(driver.goal({**goal, "not_after": 9}, 5), "goal_accepted")


def test_the_ledger_is_bounded() -> None:
    """Tests that only the last max_goal_ids accepted ids are kept."""
    driver = Driver(config=EngineConfig(max_goal_ids=2))
    driver.tick(0)
    for i in range(4):
        driver.goal(small_goal(f"g{i}", f"P{i}"), 1)
    assert driver.engine.status().counters.goals_accepted == 4
    assert list(driver.engine.snapshot().ledger) == ["g2", "g3"]


def _report(driver: Driver, **fields: object) -> list:
    report = msgspec.convert(fields, messages.ActivityReport)
    return driver.step(ReportArrived(report))


def _rejected_reason(out: list) -> str:
    (status,) = statuses(out, "input_rejected")
    return status.errors[0].path + ": " + status.errors[0].reason


def test_reports_must_answer_a_dispatch() -> None:
    """Tests reports on a task never dispatched, naming another dispatch,
    from a later term or from the future: each rejected with its reason;
    the right one is taken."""
    driver = _started()
    dispatched = {
        d.task: d for d in published(driver.history, messages.Dispatch)
    }
    task, dispatch = sorted(dispatched.items())[0]
    never = next(
        a.task for a in driver.plan.activities if a.task not in dispatched
    )
    out = _report(driver, task=never, state="completed", at=0)
    assert "never dispatched" in _rejected_reason(out)
    out = _report(
        driver, task=task, state="running", at=0, dispatch_id=f"{task}:7-9"
    )
    assert _rejected_reason(out).startswith("dispatch_id")
    out = _report(driver, task=task, state="running", at=0, term=9)
    assert _rejected_reason(out).startswith("term")
    out = _report(driver, task=task, state="running", at=40)
    assert _rejected_reason(out).startswith("at")
    assert driver.engine.status().counters.reports == 0
    out = _report(
        driver,
        task=task,
        state="running",
        at=0,
        dispatch_id=dispatch.dispatch_id,
        term=dispatch.term,
    )
    assert not statuses(out, "input_rejected")
    assert driver.engine.status().activities[task] == "running"


def test_strict_reports_need_their_dispatch_id() -> None:
    """Tests ``reports_need_dispatch``: a report without its id is out."""
    driver = Driver(config=EngineConfig(reports_need_dispatch=True))
    driver.tick(0)
    task = published(driver.history, messages.Dispatch)[0].task
    out = _report(driver, task=task, state="running", at=0)
    assert _rejected_reason(out).startswith("dispatch_id: missing")


def test_a_clock_jump_never_dispatches_the_past() -> None:
    """Tests a clock step over activities (0 -> 30): none whose start the
    jump passed over is dispatched (not even one still running by the
    plan); each is reported missed and a ``missed`` replan plans what can
    still be flown."""
    driver = _started()
    out = driver.tick(30)
    sent = published(out, messages.Dispatch)
    assert all(d.start >= 30 for d in sent), [(d.task, d.start) for d in sent]
    missed = statuses(out, "activity_missed")
    assert missed, "the jumped-over activities are reported"
    plans = published(out, messages.PlanMessage)
    assert plans and plans[-1].trigger == "missed"
    again = published(driver.history, messages.Dispatch)
    assert all(d.start >= 30 or d.dispatched_at == 0 for d in again)


def test_levels_out_of_time_are_rejected() -> None:
    """Tests a level measured at a time ahead of the clock or before the
    horizon: rejected with the reason, no drift replan."""
    driver = _started()
    for at in (-5, 10**6):
        out = driver.level("battery", 1.0, at)
        assert _rejected_reason(out).startswith("at"), at
        assert not _solves(out)


def test_an_executor_following_a_higher_term_is_an_alarm() -> None:
    """Tests a report echoing a term above the node's: the executor acts
    on another commander's dispatches and fences this node's, so the
    node says ``alarm`` and turns ``degraded`` instead of reporting ok."""
    driver = _started()
    task = published(driver.history, messages.Dispatch)[0].task
    out = _report(driver, task=task, state="running", at=0, term=9)
    (alarm,) = statuses(out, "alarm")
    assert alarm.state == "degraded"
    assert "term 9" in alarm.detail and "ignores" in alarm.detail
    assert driver.engine.status().state == "degraded"


def test_a_term_no_one_vouches_for_is_an_alarm_not_a_degradation() -> None:
    """Tests a term begun from a state no receiver or peer confirmed: the
    node says ``alarm`` with why, once, and stays ``ok`` (nothing is known
    lost); a term with something lost degrades instead."""
    driver = _started()
    out = driver.step(TermBegan(2, unverified="term 2 begins from ..."))
    (alarm,) = statuses(out, "alarm")
    assert alarm.detail == "term 2 begins from ..."
    assert alarm.state == "ok" and driver.engine.status().state == "ok"
    out = driver.step(TermBegan(3, lost="state of term 2 is older"))
    (alarm,) = statuses(out, "alarm")
    assert alarm.state == "degraded"
