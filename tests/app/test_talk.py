"""Tests of ``fsw-scheduler send``, ``status`` and ``plan`` against a real
node in its own process, each command a process of its own, as a user
types them."""

from __future__ import annotations

import json
import queue
import signal
import subprocess
import threading
import time
from typing import TYPE_CHECKING

import pytest

from fsw_scheduler.testing import SchedulerProcess

from ..factories import DATA, cli_command, free_port

if TYPE_CHECKING:
    from collections.abc import Iterator
    from pathlib import Path


@pytest.fixture
def node() -> Iterator[int]:
    """A scheduler on Table 1 listening on a loopback port (yielded)."""
    port = free_port()
    process = SchedulerProcess(
        [
            "--problem",
            str(DATA / "paper_table1.json"),
            "--clock",
            "bus",
            "--listen",
            f"tcp/127.0.0.1:{port}",
            "--no-multicast-scouting",
            "--insecure",
        ]
    )
    assert process.start() == "scheduler up on"
    try:
        yield port
    finally:
        process.stop()


def _cli(
    port: int, *args: str, mode: str = "client"
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        cli_command(
            *args,
            "-m",
            mode,
            "-e",
            f"tcp/127.0.0.1:{port}",
            "--no-multicast-scouting",
        ),
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def test_a_session_driven_from_the_command_line(
    node: int, tmp_path: Path
) -> None:
    """Tests a newcomer's session: the clock, the paper's goal with its
    verdict, the status and the plan that holds the goal, a report."""
    port = node
    done = _cli(port, "send", "clock", '{"now": 0}', "--wait")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["now"] == 0
    done = _cli(
        port, "send", "goal", str(DATA / "paper_table2_goal.json"), "--wait"
    )
    assert done.returncode == 0, done.stderr
    verdict = json.loads(done.stdout)
    assert (verdict["event"], verdict["goal_id"]) == (
        "goal_accepted",
        "monitor-target-lf",
    )
    plan = _cli(port, "plan")
    assert plan.returncode == 0, plan.stderr
    assert "monitor-target-lf" in json.loads(plan.stdout)["goals"]
    status = _cli(port, "status")
    assert json.loads(status.stdout)["plan_id"] == 2
    report = _cli(
        port,
        "send",
        "report",
        '{"task": "NoSuchTask", "state": "completed", "at": 0}',
        "--wait",
    )
    assert report.returncode == 1
    rejected = json.loads(report.stdout)
    assert rejected["event"] == "input_rejected"
    assert "no live task 'NoSuchTask'" in rejected["errors"][0]["reason"]


def test_a_misspelt_goal_is_refused_before_it_is_sent(
    node: int, tmp_path: Path
) -> None:
    """Tests that ``send`` checks the document as the node would: a
    misspelt field exits 2 naming it, and the node never sees it."""
    goal = json.loads((DATA / "paper_table2_goal.json").read_text())
    goal["tasks"][0]["feasable_interval"] = [10, 20]
    path = tmp_path / "goal.json"
    path.write_text(json.dumps(goal))
    done = _cli(node, "send", "goal", str(path), "--wait")
    assert done.returncode == 2
    assert "tasks[0].feasable_interval" in done.stderr
    assert "did you mean 'feasible_interval'?" in done.stderr
    status = json.loads(_cli(node, "status").stdout)
    assert status["counters"].get("goals_rejected", 0) == 0


def test_no_scheduler_means_nothing_sent() -> None:
    """Tests that ``send`` on a bus without a scheduler says so, exit 1
    (a peer: its session opens alone)."""
    done = _cli(
        free_port(),
        "send",
        "clock",
        '{"now": 1}',
        "--timeout",
        "1",
        mode="peer",
    )
    assert done.returncode == 1
    assert "nothing sent" in done.stderr


def test_status_follow_prints_each_new_status(node: int) -> None:
    """Tests ``status --follow``: the current status first, then each new
    one as a line of its own (the clock's), until SIGINT, exit 0."""
    follow = subprocess.Popen(
        cli_command(
            "status",
            "--follow",
            "-m",
            "client",
            "-e",
            f"tcp/127.0.0.1:{node}",
            "--no-multicast-scouting",
        ),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    lines: queue.Queue[str] = queue.Queue()
    assert follow.stdout is not None
    reader = threading.Thread(
        target=lambda out: [lines.put(line) for line in out],
        args=(follow.stdout,),
        daemon=True,
    )
    reader.start()
    try:
        first = json.loads(lines.get(timeout=60))
        assert first["event"] == "query"
        done = _cli(node, "send", "clock", '{"now": 3}', "--wait")
        assert done.returncode == 0, done.stderr
        # Each status the node publishes from here is printed: the one
        # that says the clock moved arrives among them.
        deadline = time.monotonic() + 60
        while json.loads(lines.get(timeout=60))["now"] != 3:
            assert time.monotonic() < deadline, "no status at now=3"
        follow.send_signal(signal.SIGINT)
        assert follow.wait(30) == 0
    finally:
        if follow.poll() is None:
            follow.kill()
            follow.wait()
        reader.join(10)
        for stream in (follow.stdout, follow.stderr):
            if stream is not None:
                stream.close()


def test_what_if_from_the_command_line(node: int) -> None:
    """Tests ``fsw-scheduler what-if``: one JSON line with the verdict and
    the plan it would produce (exit 0); a goal the node would reject exits
    1 with the reasons; a malformed one exits 2, nothing asked; the node's
    plan stays plan 1 throughout."""
    port = node
    done = _cli(port, "send", "clock", '{"now": 0}', "--wait")
    assert done.returncode == 0, done.stderr
    goal = str(DATA / "paper_table2_goal.json")
    asked = _cli(port, "what-if", goal, "--timeout", "60")
    assert asked.returncode == 0, asked.stderr
    (line,) = asked.stdout.splitlines()
    answer = json.loads(line)
    assert answer["verdict"] == "goal_accepted"
    assert answer["plan"]["plan_id"] is None
    assert {"moved", "unscheduled", "why", "reasons"} <= set(answer)
    unknown = json.dumps(
        {
            "goal_id": "g2",
            "tasks": [],
            "precedences": [{"before": "A", "after": "B", "kind": "lax"}],
        }
    )
    refused = _cli(port, "what-if", unknown)
    assert refused.returncode == 1, refused.stderr
    rejected = json.loads(refused.stdout)
    assert rejected["verdict"] == "goal_rejected"
    assert rejected["plan"] is None and rejected["reasons"]
    bad = _cli(port, "what-if", '{"goal_id": "g3", "taskz": []}')
    assert bad.returncode == 2
    assert "taskz" in bad.stderr and not bad.stdout
    status = json.loads(_cli(port, "status").stdout)
    assert status["plan_id"] == 1
    assert status["counters"]["what_ifs"] == 2
