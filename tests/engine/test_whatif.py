"""Tests of what-if answers from a copy of the engine (no bus): the
answer is the plan the real goal then produces, and nothing changes."""

from __future__ import annotations

import json

import msgspec

from fsw_scheduler.engine.config import EngineConfig
from fsw_scheduler.engine.whatif import what_if
from fsw_scheduler.model.goal import decode_goal
from fsw_scheduler.wire import messages

from .driver import Driver, paper_goal, small_goal, solve, statuses


def _paper_at(now: int, config: EngineConfig | None = None) -> Driver:
    driver = Driver(config=config)
    for unit in range(now + 1):
        driver.tick(unit)
    return driver


def _ask(driver: Driver, doc: dict) -> messages.WhatIfAnswer:
    goal = decode_goal(json.dumps(doc))
    engine = driver.engine
    return what_if(engine.snapshot(), engine.config, goal, solve).answer


def test_what_if_equals_the_plan_the_goal_then_produces() -> None:
    """Tests the Table 2 goal asked at t=15, then sent: the what-if's
    verdict, activities, unscheduled tasks and removals are those of the
    real plan, and its plan has no plan_id."""
    driver = _paper_at(15)
    before = driver.engine.snapshot()
    answer = _ask(driver, paper_goal())
    assert answer.verdict == "goal_accepted"
    assert answer.goal_id == "monitor-target-lf"
    assert answer.plan is not None and answer.plan.plan_id is None
    assert (
        msgspec.json.decode(messages.encode(answer))["plan"]["plan_id"] is None
    )
    # Nothing changed: same state, same plan id, same ledger.
    assert driver.engine.snapshot() == before
    assert driver.plan.plan_id == 1
    out = driver.goal(paper_goal())
    assert statuses(out, "goal_accepted")  # not "already accepted"
    real = driver.plan
    assert real.plan_id == 2
    assert answer.plan.activities == real.activities
    assert answer.unscheduled == real.unscheduled
    assert answer.plan.removed == real.removed
    assert answer.plan.objective == real.objective
    # Under the defaults plans carry no "moved"; the answer still says.
    assert [(m.task, m.from_, m.to) for m in answer.moved] == [
        ("SetPositionY", 38, 33),
        ("DownlinkSat2Ground", 39, 34),
    ]
    # Each says why it moved, in the answer's ``why`` too.
    assert answer.why["SetPositionY"].cause == "moved"
    assert "still free" in answer.why["SetPositionY"].detail


def test_what_if_of_a_rejected_goal_gives_the_reasons() -> None:
    """Tests a goal naming an unknown task: ``goal_rejected`` with the
    reason and its path, no plan; the ledger does not keep its id."""
    driver = _paper_at(3)
    doc = small_goal("bad", "Ping")
    doc["precedences"] = [
        {"before": "Nowhere", "after": "Ping", "kind": "lax"}
    ]
    answer = _ask(driver, doc)
    assert answer.verdict == "goal_rejected"
    assert answer.plan is None
    assert [r.path for r in answer.reasons] == ["precedences[0].before"]
    good = small_goal("bad", "Ping")
    out = driver.goal(good)
    assert statuses(out, "goal_accepted")


def test_what_if_under_a_commit_window_lists_moves_and_pins() -> None:
    """Tests that with a window of 25 at t=15 the what-if foresees the
    pinned plan (nothing moved), as the real goal then gets it."""
    config = EngineConfig(commit_window=25)
    driver = _paper_at(15, config)
    answer = _ask(driver, paper_goal())
    assert answer.verdict == "goal_accepted" and answer.moved == ()
    driver.goal(paper_goal())
    assert answer.plan is not None
    assert answer.plan.activities == driver.plan.activities
    assert answer.plan.moved == driver.plan.moved == ()


def test_what_ifs_on_generated_sessions_match_the_goals() -> None:
    """Tests, over a session of small goals at several times, that each
    what-if's plan equals the plan its goal then produces."""
    driver = _paper_at(0)
    for serial, now in enumerate((2, 5, 9, 14, 20)):
        driver.tick(now)
        doc = small_goal(f"g{serial}", f"P{serial}", f"Q{serial}")
        doc["tasks"][1]["schedule_cost"] = serial % 3
        answer = _ask(driver, doc)
        before = driver.plan.plan_id
        driver.goal(doc)
        if answer.verdict == "goal_accepted":
            assert answer.plan is not None
            assert driver.plan.plan_id == before + 1
            assert answer.plan.activities == driver.plan.activities
            assert answer.unscheduled == driver.plan.unscheduled
        else:
            assert driver.plan.plan_id == before
