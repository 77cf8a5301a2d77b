"""Tests of the one-commander protocol: separate scheduler processes on a
router, a hot standby taking over from a killed active node, and twins
started at the same moment."""

from __future__ import annotations

import random
import threading
from typing import TYPE_CHECKING

import zenoh

from fsw_scheduler.bus.session import loopback_config
from fsw_scheduler.testing import SchedulerClient
from fsw_scheduler.wire import topics as keys

from ..factories import CLI, ping_goal
from ..journal.test_resume import soak_resume

if TYPE_CHECKING:
    from pathlib import Path

    from ..conftest import Uninterrupted


def test_standby_takes_over_and_nothing_is_dispatched_twice(
    tmp_path: Path, uninterrupted: Uninterrupted
) -> None:
    """Tests failover: A commands, B stands by; A is killed (during a
    tick, while the goal is solved, after a report) and each time the
    other node takes over with the next plan id; the session ends with the
    plan of one uninterrupted node, each activity dispatched once, and
    every journal replaying identically."""
    soak = soak_resume()
    rng = random.Random(11)
    reference = uninterrupted.outcome
    kills = {(4, "tick"), (15, "goal"), (27, "report")}
    outcome = soak.run_failover(tmp_path, kills, rng)
    assert soak.compare(reference, outcome) == []
    assert outcome.kills == 3 and len(outcome.takeovers) == 3
    # Bounded: link loss is seen at once on loopback; far below the
    # Zenoh lease that bounds a silent failure.
    assert max(outcome.takeovers) < 10.0
    assert outcome.plan_ids == sorted(set(outcome.plan_ids))
    assert max(outcome.dispatches.values()) == 1
    assert outcome.standby_statuses >= 1
    assert outcome.journals >= 4


def test_twins_started_together_elect_one_commander(tmp_path: Path) -> None:
    """Tests two schedulers of one spacecraft started at the same moment:
    exactly one commands, the other stands by and says whom it follows;
    a goal gets one verdict, its plan one id."""
    soak = soak_resume()
    router, port = soak.start_router()
    nodes = [
        soak.node_process(
            tmp_path / name, port, ("--node-id", name, "-m", "client")
        )
        for name in ("twin-a", "twin-b")
    ]
    decisions: dict[str, str] = {}
    try:
        threads = [
            threading.Thread(
                target=lambda n=node, i=i: decisions.__setitem__(
                    f"twin-{'ab'[i]}", n.start()
                )
            )
            for i, node in enumerate(nodes)
        ]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join(90)
        assert sorted(decisions.values()) == [
            "scheduler up on",
            "standing by",
        ], decisions
        commander = next(k for k, v in decisions.items() if v != "standing by")
        config = loopback_config(
            listen=None, connect=[f"tcp/127.0.0.1:{port}"]
        )
        config.insert_json5("mode", '"client"')
        with zenoh.open(config) as session:
            client = SchedulerClient(session, timeout=30.0)
            try:
                client.wait_scheduler(60)
                active = [
                    str(r.ok.key_expr)
                    for r in session.liveliness().get(
                        client.topics.key(f"{keys.ACTIVE}/**"), timeout=5
                    )
                    if r.ok is not None
                ]
                assert len(active) == 1 and active[0].endswith(commander)
                client.tick(0)
                client.publish_goal(ping_goal("once", "Beacon"))
                client.wait_status(lambda s: s.goal_id == "once", 30)
                client.settle(0)
                verdicts = [s for s in client.statuses if s.goal_id == "once"]
                assert [s.event for s in verdicts] == ["goal_accepted"]
                assert {s.node_id for s in verdicts} == {commander}
                assert [p.plan_id for p in client.plans] == [1, 2]
            finally:
                client.close()
        for node in nodes:
            assert node.stop() == 0
    finally:
        for node in nodes:
            node.kill()
        router.close()


def test_failover_demo_resumes_takes_over_and_replays(tmp_path: Path) -> None:
    """Tests `demo --scenario failover`: two takeovers and a resume shown
    on the timeline, every journal of both nodes replaying identically."""
    import subprocess

    result = subprocess.run(
        [
            *CLI,
            "demo",
            "--scenario",
            "failover",
            "--out",
            str(tmp_path / "demo"),
            "--time-unit",
            "0",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    out = result.stdout
    assert out.count("took_over by") == 2
    assert "resumed by obc-a" in out
    assert "stands by" in out
    verified = [line for line in out.splitlines() if "replay --verify" in line]
    assert len(verified) >= 4
    assert all("IDENTICAL" in line for line in verified)
    assert "PLAN 2 (goal" in out
