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
    from typing import IO


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
    # A forecast of the wrong kind for a multiple resource: the reasons.
    forecast = _cli(
        port,
        "send",
        "forecast",
        '{"resource": "power", "at": 0, "available": [[0, 5]]}',
        "--wait",
    )
    assert forecast.returncode == 1
    rejected = json.loads(forecast.stdout)
    assert rejected["event"] == "input_rejected"
    assert {e["path"] for e in rejected["errors"]} == {"available", "steps"}
    misspelt = _cli(
        port, "send", "forecast", '{"resource": "power", "at": 0, "stesp": []}'
    )
    assert misspelt.returncode == 2
    assert "did you mean 'steps'" in misspelt.stderr


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

    def read(out: IO[str]) -> None:
        for line in out:
            lines.put(line)

    reader = threading.Thread(target=read, args=(follow.stdout,), daemon=True)
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


def test_send_checks_a_goal_against_the_node_s_resources(
    node: int, tmp_path: Path
) -> None:
    """Tests the issue's goal (a bad id, a type error, an unknown
    resource): ``send`` asks the node's settings for its resources and
    names all three at once, exit 2, nothing sent."""
    goal = {
        "goal_id": "bad/id",
        "tasks": [
            {
                "id": "T",
                "length": "3",
                "delay_cost": 1,
                "schedule_cost": 1,
                "uses": {"laser": 1},
            }
        ],
    }
    done = _cli(node, "send", "goal", json.dumps(goal), "--wait")
    assert done.returncode == 2, done.stderr
    for path in ("goal_id", "tasks[0].length", "tasks[0].uses.laser"):
        assert f"  {path}: " in done.stderr, done.stderr
    assert "unknown resource (known: " in done.stderr
    assert "Traceback" not in done.stderr
    level = _cli(
        node, "send", "level", '{"resource": "power", "level": 3, "at": 0}'
    )
    assert level.returncode == 2
    assert "'power' is not a consumable" in level.stderr
    status = json.loads(_cli(node, "status").stdout)
    assert status["counters"].get("goals_rejected", 0) == 0
    assert status["counters"].get("inputs_rejected", 0) == 0


def test_send_says_what_it_published_and_the_verdict_of_a_level(
    node: int,
) -> None:
    """Tests ``send`` without ``--wait`` (one line: what, on which key;
    ``-q``: nothing), a negative level refused before it leaves (exit 2)
    and a level the node refuses (exit 1, its reason)."""
    done = _cli(node, "send", "clock", '{"now": 0}')
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("published clock on fsw/sat1/clock")
    quiet = _cli(node, "send", "clock", '{"now": 0}', "-q")
    assert (quiet.returncode, quiet.stdout) == (0, "")
    negative = _cli(
        node,
        "send",
        "level",
        '{"resource": "battery", "level": -3, "at": 0}',
        "--wait",
    )
    assert negative.returncode == 2
    assert "level: must be >= 0, got -3" in negative.stderr
    ahead = _cli(
        node,
        "send",
        "level",
        '{"resource": "battery", "level": 3, "at": 40}',
        "--wait",
    )
    assert ahead.returncode == 1, ahead.stderr
    verdict = json.loads(ahead.stdout)
    assert verdict["event"] == "input_rejected"
    assert verdict["errors"][0]["path"] == "at"


_KEYS = {
    "goal": "scheduler/goals",
    "clock": "clock",
    "activity_report": "telemetry/activities/A",
    "resource_level": "telemetry/resources/battery",
}
_SEND = {
    "goal": "goal",
    "clock": "clock",
    "activity_report": "report",
    "resource_level": "level",
}


def test_every_invalid_input_is_refused_by_send_the_node_and_the_schema(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Tests each invalid input of the suite three ways: ``send`` exits 2
    naming its path (nothing sent), the node on the bus answers it with a
    rejection naming the path, the shipped schema refuses it (where JSON
    Schema can say it)."""
    import jsonschema

    from fsw_scheduler.app.cli.main import main
    from fsw_scheduler.testing import SchedulerHarness

    from ..factories import INVALID_INPUTS, ROOT

    schemas = {
        kind: jsonschema.Draft202012Validator(
            json.loads((ROOT / "schemas" / f"{kind}.schema.json").read_text())
        )
        for kind in _KEYS
    }
    wrong: list[str] = []
    with SchedulerHarness() as h:
        h.tick(0)
        (endpoint,) = h.endpoints()[:1]
        flags = ["-m", "client", "-e", endpoint, "--no-multicast-scouting"]
        for case in INVALID_INPUTS:
            code = main(["send", _SEND[case.kind], case.text, *flags])
            err = capsys.readouterr().err
            if code != 2 or f"  {case.path}: " not in err:
                wrong.append(f"send: {case.name}: exit {code}: {err}")
            seen = len(h.statuses)
            h.put(_KEYS[case.kind], case.text.encode())
            status = h.wait_status(
                lambda s: s.event in ("input_rejected", "goal_rejected"),
                since=seen,
            )
            if case.path not in {e.path for e in status.errors}:
                wrong.append(f"node: {case.name}: {status.errors}")
            doc = json.loads(case.text)
            if case.schema and not list(schemas[case.kind].iter_errors(doc)):
                wrong.append(f"schema: {case.name}: accepted")
        counters = h.query_status().counters
    assert not wrong, "\n".join(wrong)
    assert counters.inputs_rejected + counters.goals_rejected == len(
        INVALID_INPUTS
    )


def test_a_wrong_spacecraft_is_answered_with_the_ones_on_the_bus(
    node: int,
) -> None:
    """Tests ``status`` and ``send`` for ``sat2`` on a bus where ``sat1``
    runs: they say so (and suggest ``--spacecraft sat1``) well before
    their 10 s timeout, nothing sent."""
    start = time.monotonic()
    status = _cli(node, "status", "--spacecraft", "sat2")
    send = _cli(node, "send", "clock", '{"now": 1}', "--spacecraft", "sat2")
    took = time.monotonic() - start
    for done in (status, send):
        assert done.returncode == 1
        assert "no scheduler of sat2 on the bus" in done.stderr
        assert "schedulers alive: sat1 (--spacecraft sat1?)" in done.stderr
    assert "nothing sent" in send.stderr
    assert took < 15, took


#: What ``status`` must not load: the solver, the journal, the plots and
#: the layers that use them. These made the first touch cost 0.5 s of
#: process time when every import was eager (about 0.3 s without them).
HEAVY = (
    "pulp",
    "mcap",
    "matplotlib",
    "numpy",
    "fsw_scheduler.solving",
    "fsw_scheduler.analysis",
    "fsw_scheduler.engine",
    "fsw_scheduler.journal",
    "fsw_scheduler.replan",
)


def test_status_of_a_live_node_loads_none_of_the_solver_or_journal(
    node: int,
) -> None:
    """Tests the first touch of a running node stays light: ``fsw-scheduler
    status`` answers without importing the solver, the journal, the plots
    or the engine (read from the command's ``-X importtime`` trace, which
    does not depend on the machine's load as a CPU-time bound would)."""
    import os

    done = subprocess.run(
        cli_command(
            "status",
            "-m",
            "client",
            "-e",
            f"tcp/127.0.0.1:{node}",
            "--no-multicast-scouting",
        ),
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        env={**os.environ, "PYTHONPROFILEIMPORTTIME": "1"},
    )
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["state"] == "ok"
    loaded = {
        line.rsplit("|", 1)[-1].strip()
        for line in done.stderr.splitlines()
        if line.startswith("import time:")
    }
    assert "fsw_scheduler.bus.client" in loaded  # the trace is read
    heavy = sorted(
        name
        for name in loaded
        if any(name == top or name.startswith(top + ".") for top in HEAVY)
    )
    assert heavy == []


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
    # Well formed, so sent; a precedence on a task the node does not
    # have: the node's verdict is a rejection.
    unknown = json.dumps(
        {
            "goal_id": "g2",
            "tasks": [
                {"id": "T2", "length": 1, "delay_cost": 1, "schedule_cost": 1}
            ],
            "precedences": [{"before": "A", "after": "T2", "kind": "lax"}],
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
