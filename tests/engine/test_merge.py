"""Tests of a heal that merges facts: what a commander that stood down
commanded is never commanded again by the winner, and a goal it took and
partly executed is carried over, not sent again."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

from fsw_scheduler.engine.config import EngineConfig
from fsw_scheduler.engine.core import Engine
from fsw_scheduler.engine.dispatch import WAS_COMMANDED
from fsw_scheduler.engine.events import FactsArrived, ReportArrived, TermBegan
from fsw_scheduler.engine.merge import facts_of, lost_goals
from fsw_scheduler.model.problem import decode_problem
from fsw_scheduler.runtime.inputs import InputDecoder
from fsw_scheduler.wire import messages, topics

from ..factories import make_doc, make_task
from .driver import Driver, published, statuses

if TYPE_CHECKING:
    from .driver import ReportState

CAMERA = {"binary": ["camera"], "multiple": {"power": 100}}
EMPTY = decode_problem(json.dumps(make_doc([], 30, CAMERA)), allow_empty=True)
FACTS = EngineConfig(report_ahead=1, cancel_timeout=3)


def _goal(goal_id: str, task: str, length: int, **over: object) -> dict:
    return {
        "goal_id": goal_id,
        "tasks": [make_task(task, length, uses={"camera": 1}, **over)],
    }


def _report(driver: Driver, task: str, state: ReportState, at: int) -> None:
    sent = driver.engine.snapshot().sent.get(task)
    dispatch_id = f"{task}:{sent[0]}-{sent[1]}" if sent else ""
    driver.step(
        ReportArrived(
            messages.ActivityReport(
                task,
                state,
                at,
                dispatch_id=dispatch_id,
            )
        )
    )


def _split() -> tuple[Driver, Driver]:
    """A commands P (0-2) at 0; the bus splits; B, from A's state,
    hears P completed, takes goal gB and commands its task T; A, cut
    off from the executor, hears nothing."""
    a = Driver(EMPTY, FACTS)
    a.tick(0)
    a.goal(
        _goal(
            "g0",
            "P",
            2,
            feasible_interval=[0, 0],
            feasible_interval_applies_to="start",
        )
    )
    assert [
        d.dispatch_id for d in published(a.history, messages.Dispatch)
    ] == ["P:0-2"]
    b = Driver(EMPTY, FACTS)
    b.engine = Engine.restore(FACTS, a.engine.snapshot())
    b.now = 0
    b.tick(1)
    b.goal(
        _goal(
            "gB",
            "T",
            3,
            feasible_interval=[2, 2],
            feasible_interval_applies_to="start",
        )
    )
    b.tick(2)
    _report(b, "P", "completed", 2)
    _report(b, "T", "running", 2)
    assert b.engine.status().activities["T"] == "running"
    a.tick(1)
    a.tick(2)
    return a, b


def test_the_winner_never_commands_what_the_loser_commanded() -> None:
    """Tests that facts handed over at a heal make the winner hold a task
    the loser commanded as running (pinned, never dispatched again), a
    completion it never heard of as completed, and the loser's goal as
    accepted (not to be sent again)."""
    a, b = _split()
    facts = facts_of(b.engine.snapshot(), a.engine.snapshot(), "B")
    assert {f.task: f.state for f in facts.facts} == {
        "P": "completed",
        "T": "running",
    }
    assert [g.goal_id for g in facts.goals] == ["gB"]
    before = len(published(a.history, messages.Dispatch))
    out = a.step(FactsArrived(facts))
    (said,) = statuses(out, "facts_merged")
    assert "gB" in said.detail
    assert a.plan.trigger == "merged"
    assert "T" in a.plan.continuing
    for now in range(3, 12):
        a.tick(now)
    again = published(a.history, messages.Dispatch)[before:]
    assert [d.task for d in again if d.action == "run"] == []
    activities = a.engine.status().activities
    assert activities["P"] == "completed"
    assert activities["T"] == "running"
    record = a.engine.snapshot().ledger["gB"]
    assert record.verdict == "accepted" and record.tasks == ("T",)
    # The sender re-sending gB hears it is accepted, and nothing changes.
    out = a.goal(
        _goal(
            "gB",
            "T",
            3,
            feasible_interval=[2, 2],
            feasible_interval_applies_to="start",
        )
    )
    assert statuses(out, "goal_accepted")


def test_every_goal_the_winner_lacks_is_carried_over() -> None:
    """Tests that a goal the loser took, commanded or not, is carried
    over (its sender had ``goal_accepted``: a second verdict saying "send
    it again" would contradict it), and the winner accepts it into its
    plan; only a goal whose task id is another task at the winner is
    told to be sent again, and one whose task the winner holds, the same,
    under another goal id (its sender sent it on both sides) is held there
    already: neither carried nor told."""
    a, b = _split()
    b.goal(_goal("gLate", "U", 1, feasible_interval=[20, 25]))
    b.goal(_goal("gClash", "Q", 1, feasible_interval=[20, 25]))
    a.goal(_goal("gOther", "Q", 1, feasible_interval=[30, 35]))
    b.goal(_goal("gSame", "R", 1, feasible_interval=[40, 45]))
    a.goal(_goal("gTwin", "R", 1, feasible_interval=[40, 45]))
    own, theirs = b.engine.snapshot(), a.engine.snapshot()
    assert own.lifecycle.get("U") not in WAS_COMMANDED and "U" not in own.sent
    assert own.lifecycle["T"] in WAS_COMMANDED
    facts = facts_of(own, theirs)
    assert [g.goal_id for g in facts.goals] == ["gB", "gLate"]
    assert lost_goals(own, theirs) == ["gClash"]
    out = a.step(FactsArrived(facts))
    (said,) = statuses(out, "facts_merged")
    assert "gLate" in said.detail
    assert "U" in {t.task for t in a.plan.activities}
    assert a.engine.snapshot().ledger["gLate"].verdict == "accepted"


def test_facts_are_a_journaled_input() -> None:
    """Tests that ``scheduler/facts`` decodes into the event replay feeds
    the engine, so a replay merges them on the same step."""
    _, b = _split()
    facts = facts_of(b.engine.snapshot(), None, "B")
    keys = topics.Topics()
    event = InputDecoder(keys, "bus").event(
        keys.key(topics.FACTS), messages.encode(facts)
    )
    assert event == FactsArrived(facts)


def test_a_blind_command_answered_with_an_earlier_run_is_void() -> None:
    """Tests that a commander that took over from an older state and
    commanded a task blind takes the executor's report on the earlier
    commander's run (a lower term, another dispatch_id) as the fact, and
    never commands the task again."""
    a = Driver(EMPTY, FACTS)
    a.step(TermBegan(1))
    a.tick(0)
    a.goal(
        _goal(
            "g",
            "X",
            2,
            feasible_interval=[3, 6],
            feasible_interval_applies_to="start",
        )
    )
    b = Driver(EMPTY, FACTS)
    b.engine = Engine.restore(FACTS, a.engine.snapshot())
    b.step(TermBegan(2))
    a.tick(3)
    assert ("run", "X:3-5") in [
        (d.action, d.dispatch_id)
        for d in published(a.history, messages.Dispatch)
    ]
    b.tick(4)  # from its older state: X missed at 3, commanded at 4
    blind = [d for d in published(b.history, messages.Dispatch)]
    assert [d.dispatch_id for d in blind] == ["X:4-6"]
    out = b.step(
        ReportArrived(
            messages.ActivityReport(
                "X", "running", 3, dispatch_id="X:3-5", term=1
            )
        )
    )
    assert not statuses(out, "input_rejected")
    assert b.engine.status().activities["X"] == "running"
    for now in range(5, 12):
        b.tick(now)
        if now == 5:
            b.step(
                ReportArrived(
                    messages.ActivityReport(
                        "X", "completed", 5, dispatch_id="X:3-5", term=1
                    )
                )
            )
    runs = [
        d.dispatch_id
        for d in published(b.history, messages.Dispatch)
        if d.action == "run"
    ]
    assert runs == ["X:4-6"]
    assert b.engine.status().activities["X"] == "completed"


def test_a_command_with_no_word_back_is_asked_about() -> None:
    """Tests that a task the loser commanded with no report (a fence may
    have kept it from the executor) is asked about with a cancel of that
    dispatch in the winner's term, unless it may not be interrupted: then
    it is held running where it was commanded."""
    a, _ = _split()
    a.step(TermBegan(2))
    for task, preemption in (("Q", "from_start"), ("R", "none")):
        a.goal(
            _goal(
                f"g{task}",
                task,
                2,
                preemption=preemption,
                feasible_interval=[10, 20],
                feasible_interval_applies_to="start",
            )
        )
    facts = messages.Facts(
        term=1,
        node_id="B",
        facts=(
            messages.Fact("Q", "dispatched", at=3, start=3, end=5),
            messages.Fact("R", "dispatched", at=3, start=3, end=5),
        ),
    )
    out = a.step(FactsArrived(facts))
    (cancel,) = [
        d for d in published(out, messages.Dispatch) if d.action == "cancel"
    ]
    assert (cancel.dispatch_id, cancel.term) == ("Q:3-5", 2)
    activities = a.engine.status().activities
    assert (activities["Q"], activities["R"]) == ("cancelling", "running")


def test_a_fact_keeps_the_number_of_its_command() -> None:
    """Tests that a fact hands over its command's number and that the
    winner's cancel names that command's id (``#3``): a cancel naming
    another id would leave the loser's command running."""
    a, _ = _split()
    a.step(TermBegan(2))
    a.goal(
        _goal(
            "gQ",
            "Q",
            2,
            preemption="from_start",
            feasible_interval=[10, 20],
            feasible_interval_applies_to="start",
        )
    )
    fact = messages.Fact("Q", "dispatched", at=3, start=3, end=5, number=3)
    out = a.step(FactsArrived(messages.Facts(term=1, facts=(fact,))))
    (cancel,) = [
        d for d in published(out, messages.Dispatch) if d.action == "cancel"
    ]
    assert cancel.dispatch_id == "Q:3-5#3"
    handed = facts_of(a.engine.snapshot(), None)
    assert [(f.task, f.number) for f in handed.facts if f.task == "Q"] == [
        ("Q", 3)
    ]
