"""Tests of ``scheduler/what-if`` on a real node over real Zenoh peers:
the answer is what the goal then does, nothing changes, a solve in flight
makes it wait or answer busy, it never delays a goal, and the journal
replays it."""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING

from fsw_scheduler.bus.session import wait_until
from fsw_scheduler.journal.annotate import schema_lookup
from fsw_scheduler.journal.replay import verify
from fsw_scheduler.journal.writer import Recorder
from fsw_scheduler.runtime.policy import run_solve
from fsw_scheduler.testing import (
    SchedulerHarness,
    harness_config,
    paper_goal,
)

from ..factories import ping_goal

if TYPE_CHECKING:
    from pathlib import Path

    from fsw_scheduler.engine.events import StartSolve
    from fsw_scheduler.model.plan import Plan
    from fsw_scheduler.runtime.config import NodeConfig
    from fsw_scheduler.wire import messages


def test_what_if_answers_and_changes_nothing(tmp_path: Path) -> None:
    """Tests the Table 2 goal asked at t=15 over the bus: accepted, its
    plan (plan_id null) is the plan the goal then produces, the node's
    plan_id and ledger are untouched (the real goal is accepted as new),
    the status counts it, and replay --verify answers it again."""
    journal = tmp_path / "journal.mcap"
    recorder = Recorder(journal, schemas=schema_lookup("sat1"))
    with SchedulerHarness(node_options={"journal": recorder}) as h:
        for now in range(16):
            h.tick(now)
        before = h.query_status()
        answer = h.what_if(paper_goal(), timeout=30)
        assert answer is not None and answer.verdict == "goal_accepted"
        assert answer.plan is not None and answer.plan.plan_id is None
        after = h.query_status()
        assert after.plan_id == before.plan_id
        assert after.activities == before.activities
        assert after.counters.what_ifs == before.counters.what_ifs + 1
        assert after.counters.goals_accepted == before.counters.goals_accepted
        verdicts = h.send_goals([paper_goal()])
        assert verdicts["monitor-target-lf"] == {"goal_accepted"}
        plan = h.wait_plan(lambda p: "monitor-target-lf" in p.goals)
        assert plan.activities == answer.plan.activities
        assert plan.unscheduled == answer.unscheduled
    report = verify(journal)
    assert report.identical, report.summary()
    assert report.what_ifs == 1


def test_a_what_if_waits_for_a_solve_then_answers_busy() -> None:
    """Tests a what-if asked while a goal's solve is held: with a 2 s
    timeout it waits about half of it, then answers busy with the reason;
    asked again with a long timeout, it is answered once the solve ends."""
    gate = threading.Event()

    def slow(config: NodeConfig, command: StartSolve) -> Plan:
        if command.trigger == "goal":
            gate.wait(60)
        return run_solve(config, command)

    with SchedulerHarness(config=harness_config(), solve_fn=slow) as h:
        h.tick(0)
        h.wait_plan(lambda p: p.plan_id == 1)
        h.publish_goal(ping_goal("first"))
        wait_until(lambda: h.query_status().busy, 10, what="a solve")
        answer = h.what_if(ping_goal("second", "Pong"), timeout=2)
        assert answer is not None and answer.verdict == "busy"
        assert "a solve is in flight" in answer.reasons[0].reason
        answers: list[messages.WhatIfAnswer | None] = []
        asking = threading.Thread(
            target=lambda: answers.append(
                h.what_if(ping_goal("second", "Pong"), timeout=40)
            )
        )
        asking.start()
        gate.set()
        asking.join(60)
        (late,) = answers
        assert late is not None
        assert late.verdict == "goal_accepted"
        h.wait_status(
            lambda s: s.goal_id == "first" and s.event == "goal_accepted"
        )


def test_a_what_if_never_delays_a_goal() -> None:
    """Tests a what-if whose solve is held on its own thread: a goal sent
    meanwhile gets its verdict and plan at once; the what-if is answered
    when its solve ends."""
    gate = threading.Event()

    def held_aside(config: NodeConfig, command: StartSolve) -> Plan:
        if threading.current_thread().name == "fsw-what-if":
            gate.wait(60)
        return run_solve(config, command)

    with SchedulerHarness(config=harness_config(), solve_fn=held_aside) as h:
        h.tick(0)
        h.wait_plan(lambda p: p.plan_id == 1)
        answers: list[messages.WhatIfAnswer | None] = []
        asking = threading.Thread(
            target=lambda: answers.append(
                h.what_if(ping_goal("asked", "Ask"), timeout=60)
            )
        )
        asking.start()
        try:
            verdicts = h.send_goals([ping_goal("sent", "Sent")], timeout=20)
            assert verdicts["sent"] == {"goal_accepted"}
            assert not answers  # the what-if is still being solved
        finally:
            gate.set()
            asking.join(60)
        (answer,) = answers
        assert answer is not None
        # Asked before "sent" was planned: its plan has no Sent.
        assert answer.verdict == "goal_accepted"


def test_a_bad_what_if_is_rejected_with_reasons() -> None:
    """Tests that a document that is not a valid goal is answered
    goal_rejected with each mistake, and nothing is planned."""
    with SchedulerHarness() as h:
        h.tick(0)
        h.wait_plan(lambda p: p.plan_id == 1)
        answer = h.what_if({"goal_id": "x", "taskz": []}, timeout=10)
        assert answer is not None and answer.verdict == "goal_rejected"
        assert answer.goal_id == "x"
        assert any("taskz" in r.path for r in answer.reasons)
        assert h.query_status().plan_id == 1


def test_a_predictable_session_replays_identical(tmp_path: Path) -> None:
    """Tests a recorded session with every predictable-replan setting on
    (commit window, lexicographic stability, early completions, a
    what-if): the settings come back from the journal's metadata and
    replay --verify reproduces every plan, move and answer."""
    from fsw_scheduler.testing import paper_problem

    journal = tmp_path / "predictable.mcap"
    config = harness_config(
        commit_window=25,
        stability="lexicographic",
        early_completion_gain=2,
    )
    recorder = Recorder(journal, schemas=schema_lookup("sat1"))
    with SchedulerHarness(
        paper_problem(), config, node_options={"journal": recorder}
    ) as h:
        running: dict[str, int] = {}
        for now in range(16):
            h.tick(now)
            for task, end in sorted(running.items()):
                if now >= end - 3:  # each activity ends 3 units early
                    h.report(task, "completed", now)
                    del running[task]
            for d in h.dispatches:
                if d.task not in running and d.end > now >= d.start:
                    h.report(d.task, "running", now)
                    running[d.task] = d.end
            h.settle(now)
        answer = h.what_if(paper_goal(), timeout=30)
        assert answer is not None and answer.verdict == "goal_accepted"
        verdicts = h.send_goals([paper_goal()])
        assert verdicts["monitor-target-lf"] == {"goal_accepted"}
        plan = h.wait_plan(lambda p: "monitor-target-lf" in p.goals)
        assert answer.plan is not None
        assert plan.activities == answer.plan.activities
        assert plan.moved == answer.moved
        triggers = {p.trigger for p in h.plans}
        assert "early_completion" in triggers
    report = verify(journal)
    assert report.identical, report.summary()
    assert report.what_ifs == 1
