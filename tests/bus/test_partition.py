"""Tests of fenced terms: a commander cut off longer than the Zenoh lease
must not win back when it returns.

Separate processes through a router: A (rank 0) commands, B (rank 1)
stands by. A is cut off for longer than the lease, in two ways: its
process is stopped (SIGSTOP, then SIGCONT), or its link falls silent
while it keeps running (:class:`~tests.bus.proxy.SilentLink`). B takes
over in a new term and accepts a goal; then A comes back. A receiver
that follows the README (:class:`fsw_scheduler.testing.Fence`) must
never act twice, the goal must stay in the plan, exactly one node
commands and both say who does.
"""

from __future__ import annotations

import collections
import os
import signal
import threading
import time
from typing import TYPE_CHECKING

import msgspec
import pytest
import zenoh

from fsw_scheduler.bus.session import loopback_config
from fsw_scheduler.journal.replay import verify
from fsw_scheduler.journal.state import journal_files
from fsw_scheduler.testing import SchedulerClient
from fsw_scheduler.wire import messages

from ..factories import ping_goal
from ..journal.test_resume import soak_resume
from .proxy import SilentLink

if TYPE_CHECKING:
    from pathlib import Path

#: A short Zenoh lease (ms), so that the test takes seconds: the gap that
#: ends a commander's own lease is half of it.
LEASE_MS = 2000
#: How long A stays stopped: well beyond the lease.
STOPPED_S = 4.0


def _nodes(
    soak: object, tmp_path: Path, ports: dict[str, int]
) -> dict[str, object]:
    lease = ("--cfg", f"transport/link/tx/lease:{LEASE_MS}")
    return {
        name: soak.node_process(  # type: ignore[attr-defined]
            tmp_path / f"state-{name}",
            ports[name],
            ("--node-id", name, "--rank", str(rank), "-m", "client", *lease),
        )
        for name, rank in (("A", 0), ("B", 1))
    }


def _plan_contents(plans: list[messages.PlanMessage]) -> dict[int, set]:
    """plan_id -> the distinct contents published under it."""
    seen: dict[int, set] = collections.defaultdict(set)
    for plan in plans:
        body = msgspec.structs.replace(plan, stats=None, why=())
        seen[plan.plan_id].add(messages.encode(body))
    return seen


@pytest.mark.slow
@pytest.mark.parametrize("cut", ["stopped", "silent"])
def test_cut_off_commander_does_not_win_back(tmp_path: Path, cut: str) -> None:
    """Tests A cut off beyond the lease (SIGSTOP, or a silent link), then
    back: B took over in a higher term; A stands down, says why and
    follows B; no activity runs twice at a fencing receiver; B's goal is
    in the final plan; one commander; every journal replays identical."""
    soak = soak_resume()
    router, port = soak.start_router()
    link = SilentLink(port)
    a_port = link.port if cut == "silent" else port
    nodes = _nodes(soak, tmp_path, {"A": a_port, "B": port})
    try:
        driver = loopback_config(
            listen=None, connect=[f"tcp/127.0.0.1:{port}"]
        )
        driver.insert_json5("mode", '"client"')
        with zenoh.open(driver) as session:
            client = SchedulerClient(session, timeout=30.0)
            assert nodes["A"].start() == "scheduler up on"  # type: ignore[attr-defined]
            assert nodes["B"].start() == "standing by"  # type: ignore[attr-defined]
            client.wait_scheduler(60)
            for now in range(3):
                client.tick(now)
            first_term = max(p.term for p in client.plans)
            assert first_term >= 1

            a = nodes["A"].process  # type: ignore[attr-defined]
            if cut == "stopped":
                os.kill(a.pid, signal.SIGSTOP)
            else:
                link.silence()
            stopped = time.monotonic()
            try:
                took = client.wait_status(
                    lambda s: s.event == "took_over" and s.node_id == "B", 30
                )
                assert took.term > first_term
                for now in range(3, 6):
                    client.tick(now)
                client.publish_goal(ping_goal("during", "Beacon"))
                accepted = client.wait_status(
                    lambda s: (
                        s.event == "goal_accepted" and s.goal_id == "during"
                    ),
                    30,
                )
                assert accepted.node_id == "B"
                time.sleep(max(0.0, STOPPED_S - (time.monotonic() - stopped)))
            finally:
                if cut == "stopped":
                    os.kill(a.pid, signal.SIGCONT)
                else:
                    link.heal()
            seen = 0  # A may stand down before this line runs
            down = client.wait_status(
                lambda s: s.node_id == "A" and s.event == "stood_down",
                30,
                since=seen,
            )
            assert ("did not run" if cut == "stopped" else "link") in (
                down.detail
            ), down
            client.wait_status(
                lambda s: (
                    s.node_id == "A"
                    and s.state == "standby"
                    and s.active == "B"
                ),
                30,
                since=seen,
            )
            for now in range(6, 45):
                client.tick(now)
            client.settle(44)

            runs = collections.Counter(d.task for d in client.executed)
            assert max(runs.values()) == 1, runs
            final = client.query_plan()
            assert final is not None
            assert "during" in final.goals, final.goals
            assert final.term == took.term
            contents = _plan_contents(client.plans)
            assert all(len(c) == 1 for c in contents.values()), {
                k: len(v) for k, v in contents.items() if len(v) > 1
            }
            status = client.query_status()
            assert status.node_id == "B" and status.state != "standby"
            last_a = [s for s in client.statuses if s.node_id == "A"][-1]
            assert last_a.state == "standby" and last_a.active == "B"
            client.close()
    finally:
        for node in nodes.values():
            node.kill()  # type: ignore[attr-defined]
        link.close()
        router.close()
    for name in ("A", "B"):
        for path in journal_files(tmp_path / f"state-{name}"):
            report = verify(path)
            assert report.identical, f"{name}/{path.name}: {report.summary()}"


@pytest.mark.slow
def test_flood_with_a_killed_commander_answers_every_goal(
    tmp_path: Path,
) -> None:
    """Tests a goal flood during which the commander gets SIGKILL: the
    standby takes over, the sender re-sends what got no verdict (the
    README's rule), and every goal ends with exactly one kind of verdict;
    nothing is executed twice at a fencing receiver."""
    soak = soak_resume()
    router, port = soak.start_router()
    nodes = _nodes(soak, tmp_path, {"A": port, "B": port})
    goals = [ping_goal(f"flood-{i:03d}", f"F{i:03d}") for i in range(48)]
    try:
        driver = loopback_config(
            listen=None, connect=[f"tcp/127.0.0.1:{port}"]
        )
        driver.insert_json5("mode", '"client"')
        with zenoh.open(driver) as session:
            client = SchedulerClient(session, timeout=120.0)
            assert nodes["A"].start() == "scheduler up on"  # type: ignore[attr-defined]
            assert nodes["B"].start() == "standing by"  # type: ignore[attr-defined]
            client.wait_scheduler(60)
            client.tick(0)

            def kill_when_busy() -> None:
                client.wait_status(lambda s: s.event == "goal_accepted", 60)
                nodes["A"].kill()  # type: ignore[attr-defined]

            killer = threading.Thread(target=kill_when_busy, daemon=True)
            killer.start()
            answers = client.send_goals(goals, resend_s=1.0, timeout=120)
            killer.join(60)
            assert client.wait_status(
                lambda s: s.event == "took_over" and s.node_id == "B", 60
            )
            unanswered = [g for g, v in answers.items() if not v]
            conflicting = {g: v for g, v in answers.items() if len(v) > 1}
            assert unanswered == [] and conflicting == {}
            accepted = {
                g for g, v in answers.items() if v == {"goal_accepted"}
            }
            final = client.query_plan()
            assert final is not None
            for now in range(1, 6):
                client.tick(now)
            runs = collections.Counter(d.task for d in client.executed)
            assert not runs or max(runs.values()) == 1, runs
            # Every accepted goal is in the surviving state's plans.
            adopted = {g for p in client.plans for g in p.goals}
            assert accepted <= adopted, accepted - adopted
            client.close()
    finally:
        for node in nodes.values():
            node.kill()  # type: ignore[attr-defined]
        router.close()
