"""Tests of the scheduler node on a real Zenoh bus (loopback peers)."""

from __future__ import annotations

import json
import queue
import signal
import subprocess
import sys
import textwrap
import threading
import time
from typing import TYPE_CHECKING

import msgspec
import pytest
import zenoh

from fsw_scheduler.bus.session import loopback_config, wait_matching
from fsw_scheduler.testing import (
    SchedulerClient,
    SchedulerHarness,
    harness_config,
)
from fsw_scheduler.wire import messages
from fsw_scheduler.wire import topics as keys

from ..factories import DATA, ROOT, cli_command, free_port, ping_goal
from .peers import ALIVE, Liveliness

if TYPE_CHECKING:
    from pathlib import Path

    pass

pytest_plugins = ["fsw_scheduler.testing"]


def plan_bytes(plan: messages.PlanMessage | None) -> bytes:
    """A plan's encoding without solver statistics, for comparisons."""
    assert plan is not None
    return messages.encode(msgspec.structs.replace(plan, stats=None))


# -- the normal flow ---------------------------------------------------------


def test_goal_plan_dispatch(started: SchedulerHarness) -> None:
    """Tests that plans and dispatches arrive at the right ticks."""
    h = started
    plan = h.wait_plan()
    starts = {a.task: a.start for a in plan.activities}
    assert {d.task for d in h.dispatches} == {
        t for t, s in starts.items() if s == 0
    }
    h.tick(1)
    assert {d.task for d in h.dispatches} == {
        t for t, s in starts.items() if s <= 1
    }
    h.publish_goal(ping_goal("beacon", "Beacon"))
    new = h.wait_plan(lambda p: "beacon" in p.goals)
    assert (new.plan_id, new.trigger, new.issued_at) == (2, "goal", 1)
    h.settle(1)
    beacon = next(a for a in new.activities if a.task == "Beacon")
    if beacon.start > 1:
        h.tick(beacon.start)
    dispatch = h.wait_dispatch("Beacon")
    assert (dispatch.plan_id, dispatch.start, dispatch.end) == (
        2,
        beacon.start,
        beacon.end,
    )
    # The contract's payload fields, read from the raw JSON.
    raw = [
        json.loads(payload)
        for key, payload in h.samples
        if key == h.topics.dispatch("Beacon")
    ]
    assert raw == [
        {
            "task": "Beacon",
            "plan_id": 2,
            "start": beacon.start,
            "end": beacon.end,
            "uses": {"power": 5.0},
            "dispatched_at": beacon.start,
            "dispatch_id": f"Beacon:{beacon.start}-{beacon.end}",
            "term": 1,
        }
    ]
    first = json.loads(
        next(p for k, p in h.samples if k == h.topics.dispatch("SetPositionX"))
    )
    assert {"task", "plan_id", "start", "end", "uses"} <= set(first)
    assert first["uses"]["reaction_wheel"] == 1
    accepted = h.wait_status(lambda s: s.event == "goal_accepted")
    assert accepted.goal_id == "beacon"


def test_queryables_answer(scheduler_harness: SchedulerHarness) -> None:
    """Tests that the plan and status queryables answer the current state."""
    h = scheduler_harness
    assert h.query_plan() is None
    status = h.query_status()
    assert (status.state, status.plan_id, status.event) == (
        "ok",
        None,
        "query",
    )
    h.tick(0)
    plan = h.query_plan()
    assert plan is not None
    assert plan.plan_id == 1
    assert plan_bytes(plan) == plan_bytes(h.wait_plan())
    status = h.query_status()
    assert (status.plan_id, status.now, status.busy) == (1, 0, False)
    assert status.activities["SetPositionX"] == "dispatched"
    assert status.counters.dispatches == len(h.dispatches) == 2


def test_liveliness_token_follows_the_node(
    scheduler_harness: SchedulerHarness,
) -> None:
    """Tests that the alive token exists while the node runs, not after."""
    h = scheduler_harness
    # The token may reach this peer a moment after the node says it is up.
    deadline = time.monotonic() + 10.0
    seen: list[str] = []
    while not seen and time.monotonic() < deadline:
        replies = h.client.liveliness().get(ALIVE, timeout=2.0)
        seen = [str(r.ok.key_expr) for r in replies if r.ok is not None]
    assert seen == [ALIVE]
    watch = Liveliness(h.client)
    try:
        watch.expect(zenoh.SampleKind.PUT)
        h.close_node()
        watch.expect(zenoh.SampleKind.DELETE)
    finally:
        watch.close()
    tokens = [r.ok for r in h.client.liveliness().get(ALIVE, timeout=1.0)]
    assert [s for s in tokens if s is not None] == []


def test_unknown_fields_are_rejected_and_named(
    started: SchedulerHarness,
) -> None:
    """Tests that a goal, a report and a level with fields the scheduler
    does not understand are each rejected, every unknown field named with
    the closest known one, and the current plan keeps running."""
    h = started
    before = h.query_plan()
    goal = ping_goal("future", "Later", priority="high")
    goal["tasks"][0]["feasable_interval"] = [10, 20]
    h.publish_goal(goal)
    status = h.wait_status(lambda s: s.event == "goal_rejected")
    reasons = {issue.path: issue.reason for issue in status.errors}
    assert status.goal_id == "future"
    assert "priority" in reasons
    assert (
        "did you mean 'feasible_interval'?"
        in (reasons["tasks[0].feasable_interval"])
    )
    h.tick(1)
    h.put(
        h.topics.activity_report("SetPositionX"),
        {"task": "SetPositionX", "state": "completed", "at": 1, "colour": 1},
    )
    h.put(
        h.topics.resource_level("battery"),
        {"resource": "battery", "level": 18.0, "at": 1, "unit": "Ah"},
    )
    h.settle(1)
    counters = h.query_status().counters
    assert (counters.goals_rejected, counters.inputs_rejected) == (1, 2)
    after = h.query_plan()
    assert after is not None and before is not None
    assert after.plan_id == before.plan_id


# -- bad input never crashes and never loses the plan -------------------------

BIG = (
    b'{"goal_id": "huge", "tasks": [], "pad": "'
    + b"x" * (messages.MAX_PAYLOAD_BYTES + 10)
    + b'"}'
)

BAD_INPUTS = {
    # name: (key suffix, payload, event, field path, words in the reason)
    "malformed_json_goal": (
        keys.GOALS,
        b'{"goal_id": "broken", "tasks": [',
        "goal_rejected",
        "",
        "",
    ),
    "wrong_type_goal": (
        keys.GOALS,
        json.dumps(
            {
                "goal_id": "typo",
                "tasks": [
                    {
                        "id": "T",
                        "length": "ten",
                        "delay_cost": 1,
                        "schedule_cost": 1,
                    }
                ],
            }
        ).encode(),
        "goal_rejected",
        "tasks[0].length",
        "int",
    ),
    "id_collision_goal": (
        keys.GOALS,
        json.dumps(ping_goal("clash", "BatteryCharge")).encode(),
        "goal_rejected",
        "tasks[0].id",
        "BatteryCharge",
    ),
    "oversized_goal": (
        keys.GOALS,
        BIG,
        "goal_rejected",
        "",
        "exceeds",
    ),
    "malformed_json_report": (
        "telemetry/activities/SetPositionX",
        b"not json",
        "input_rejected",
        "",
        "",
    ),
    "wrong_type_clock": (
        keys.CLOCK,
        b'{"now": "soon"}',
        "input_rejected",
        "now",
        "int",
    ),
    "unknown_resource_level": (
        "telemetry/resources/fuel",
        b'{"resource": "fuel", "level": 3.0, "at": 0}',
        "input_rejected",
        "resource",
        "fuel",
    ),
    "unknown_task_report": (
        "telemetry/activities/Nope",
        b'{"task": "Nope", "state": "running", "at": 0}',
        "input_rejected",
        "task",
        "Nope",
    ),
    "report_on_another_key": (
        "telemetry/activities/SetHFOption",
        b'{"task": "SetPositionX", "state": "completed", "at": 0}',
        "input_rejected",
        "task",
        "on the key of",
    ),
    "bad_report_state": (
        "telemetry/activities/SetPositionX",
        b'{"task": "SetPositionX", "state": "exploded", "at": 0}',
        "input_rejected",
        "state",
        "",
    ),
    "clock_going_back": (
        keys.CLOCK,
        b'{"now": 0}',  # after the clock reached 2
        "input_rejected",
        "now",
        "went back",
    ),
}


#: The goal id a rejection names (best effort for undecodable goals).
GOAL_IDS = {
    "malformed_json_goal": "broken",  # found in the text
    "wrong_type_goal": "typo",
    "id_collision_goal": "clash",
    "oversized_goal": "huge",
}


@pytest.mark.parametrize("case", sorted(BAD_INPUTS))
def test_bad_input_is_reported_and_plan_kept(
    started: SchedulerHarness, case: str
) -> None:
    """Tests that a bad input gives a status naming it and keeps the plan."""
    h = started
    suffix, payload, event, path, words = BAD_INPUTS[case]
    h.tick(1)
    h.tick(2)
    before = h.query_plan()
    assert before is not None
    seen = len(h.statuses)
    h.put(suffix, payload)
    status = h.wait_status(lambda s: s.event == event, since=seen)
    assert [e.path for e in status.errors] == [path]
    assert words in status.errors[0].reason
    assert status.goal_id == GOAL_IDS.get(case)
    settled = h.settle(2)
    assert settled.plan_id == before.plan_id
    assert plan_bytes(h.query_plan()) == plan_bytes(before)
    # The node still serves: the next tick dispatches as planned.
    h.tick(3)
    assert h.node._thread is not None and h.node._thread.is_alive()
    assert h.query_status().now == 3


@pytest.mark.parametrize(
    "scheduler_config", [harness_config(inbox_capacity=1)]
)
def test_inbox_overflow_is_counted(
    started: SchedulerHarness, scheduler_config: object
) -> None:
    """Tests that a clock flood is coalesced, counted and survived."""
    h = started
    before = h.query_plan()
    assert before is not None
    publisher = h.client.declare_publisher(
        h.topics.key(keys.CLOCK),
        encoding=zenoh.Encoding.APPLICATION_JSON,
        congestion_control=zenoh.CongestionControl.BLOCK,
    )
    try:
        for _ in range(3000):
            publisher.put(b'{"now": 0}')
    finally:
        publisher.undeclare()
    h.settle(0)  # the query queues behind the flood: all of it is handled
    status = h.tick(1)
    # Clock samples are coalesced (latest wins), never dropped.
    assert status.counters.clock_superseded > 0
    assert status.counters.inputs_dropped == h.node.inbox.lost == 0
    assert status.plan_id == before.plan_id
    assert plan_bytes(h.query_plan()) == plan_bytes(before)


# -- other processes ----------------------------------------------------------

RAW_CLIENT = textwrap.dedent(
    """
    import json
    import queue
    import sys
    import time

    import zenoh

    endpoint = sys.argv[1]
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("listen/endpoints", "[]")
    config.insert_json5("connect/endpoints", json.dumps([endpoint]))
    config.insert_json5("scouting/multicast/enabled", "false")
    root = "fsw/sat1"
    deadline = time.monotonic() + 30
    inbox = queue.Queue()

    def settle(session, now):
        # Ask the scheduler until it has seen `now` and is not solving.
        while time.monotonic() < deadline:
            for reply in session.get(root + "/scheduler/status", timeout=5):
                if reply.ok is not None:
                    status = json.loads(reply.ok.payload.to_bytes())
                    if status.get("now") == now and not status.get("busy"):
                        return
            time.sleep(0.01)
        sys.exit(f"scheduler did not settle at {now}")

    with zenoh.open(config) as session:
        sub = session.declare_subscriber(
            root + "/scheduler/dispatch/*",
            lambda s: inbox.put(s.payload.to_bytes()),
        )
        clock = session.declare_publisher(root + "/clock")
        goals = session.declare_publisher(root + "/scheduler/goals")
        while not (
            clock.matching_status.matching and goals.matching_status.matching
        ):
            if time.monotonic() > deadline:
                sys.exit("no scheduler")
            time.sleep(0.01)
        expected = {"SetHFOption", "SetPositionX", "DownlinkSat2Sat", "Beacon"}
        for now in range(3):
            clock.put(json.dumps({"now": now}))
            settle(session, now)
            if now == 1:
                goals.put(json.dumps({
                    "goal_id": "outside",
                    "tasks": [{"id": "Beacon", "length": 1, "delay_cost": 5,
                               "schedule_cost": 3, "uses": {"power": 5}}],
                }))
                settle(session, now)
        seen = set()
        while not expected <= seen:
            try:
                dispatch = json.loads(inbox.get(timeout=10))
            except queue.Empty:
                break
            seen.add(dispatch["task"])
            print("DISPATCH", json.dumps(dispatch, sort_keys=True), flush=True)
        print("FSW_SCHEDULER_IMPORTED", "fsw_scheduler" in sys.modules)
        sub.undeclare()
    """
)


def test_separate_process_client(
    scheduler_harness: SchedulerHarness, tmp_path: Path
) -> None:
    """Tests that a plain zenoh process drives the scheduler and gets work."""
    h = scheduler_harness
    script = tmp_path / "raw_client.py"
    script.write_text(RAW_CLIENT)
    (endpoint,) = [e for e in h.endpoints() if e.startswith("tcp/")]
    done = subprocess.run(
        [sys.executable, str(script), endpoint],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[-1] == "FSW_SCHEDULER_IMPORTED False"
    dispatches = {
        d["task"]: d
        for d in (
            json.loads(line.split(" ", 1)[1])
            for line in lines
            if line.startswith("DISPATCH ")
        )
    }
    assert set(dispatches) == {
        "SetHFOption",
        "SetPositionX",
        "DownlinkSat2Sat",
        "Beacon",
    }
    assert dispatches["DownlinkSat2Sat"]["dispatched_at"] == 1
    assert dispatches["Beacon"]["plan_id"] == 2
    assert dispatches["Beacon"]["start"] == 1
    # The in-process client saw the same dispatches.
    h.settle(2)
    assert {d.task for d in h.dispatches} >= set(dispatches)


class RunProcess:
    """``fsw-scheduler run`` in a subprocess, with its log read live."""

    def __init__(self, port: int) -> None:
        self.process = subprocess.Popen(
            [
                *cli_command(),
                "run",
                "--problem",
                str(DATA / "paper_table1.json"),
                "--clock",
                "bus",
                "--listen",
                f"tcp/127.0.0.1:{port}",
                "--no-multicast-scouting",
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.lines: queue.Queue[str | None] = queue.Queue()
        self.log: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.process.stderr is not None
        for line in self.process.stderr:
            self.log.append(line)
            self.lines.put(line)
        self.lines.put(None)

    def wait_up(self, timeout: float = 30.0) -> bool:
        """True once the node logs it is up; False if the process ended."""
        deadline = time.monotonic() + timeout
        while True:
            line = self.lines.get(timeout=max(deadline - time.monotonic(), 0))
            if line is None:
                return False
            if "scheduler up on" in line:
                return True

    def stop(self) -> None:
        """Kill the process if it still runs (cleanup only)."""
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait(10)
        self._reader.join(10)
        if self.process.stderr is not None:
            self.process.stderr.close()


def test_cli_run_serves_and_stops_on_sigterm() -> None:
    """Tests `fsw-scheduler run` on the bus and its clean SIGTERM exit."""
    for _attempt in range(3):
        port = free_port()
        run = RunProcess(port)
        if run.wait_up():
            break
        run.stop()
    else:
        pytest.fail("fsw-scheduler run did not start:\n" + "".join(run.log))
    try:
        config = loopback_config(
            listen=None, connect=[f"tcp/127.0.0.1:{port}"]
        )
        with zenoh.open(config) as session:
            watch = Liveliness(session)
            client = SchedulerClient(session)
            try:
                watch.expect(zenoh.SampleKind.PUT)
                client.wait_scheduler()
                wait_matching(session, client.topics.key(keys.CLOCK))
                status = client.tick(0, timeout=30.0)
                assert status.plan_id == 1
                plan = client.query_plan()
                assert plan is not None
                assert plan.plan_id == 1
                first = {a.task for a in plan.activities if a.start == 0}
                assert {d.task for d in client.dispatches} == first
                client.publish_goal(ping_goal("via-cli", "Beacon"))
                client.wait_plan(lambda p: "via-cli" in p.goals, 30.0)
                run.process.send_signal(signal.SIGTERM)
                assert run.process.wait(20) == 0, "".join(run.log)
                watch.expect(zenoh.SampleKind.DELETE)
            finally:
                client.close()
                watch.close()
    finally:
        run.stop()
    assert "scheduler stopped" in "".join(run.log)


def test_a_forecast_on_the_bus_replans_and_replays(tmp_path: Path) -> None:
    """Tests forecasts end to end on a real loopback bus: one the plan
    meets changes nothing, one that closes the planned pass replans
    (trigger ``forecast``) into the new window, a malformed one is
    answered ``input_rejected``, and the journal replays IDENTICAL."""
    from fsw_scheduler.journal.annotate import schema_lookup
    from fsw_scheduler.journal.replay import verify
    from fsw_scheduler.journal.writer import Recorder

    problem = {
        "horizon": 30,
        "resources": {"binary": {"antenna": {"available": [[0, 30]]}}},
        "tasks": [
            {
                "id": "Down",
                "length": 4,
                "delay_cost": 1,
                "schedule_cost": 2,
                "feasible_interval": [5, 30],
                "uses": {"antenna": 1},
            },
        ],
    }
    path = tmp_path / "forecast.mcap"
    journal = Recorder(path, schemas=schema_lookup("sat1"))
    with SchedulerHarness(problem, node_options={"journal": journal}) as h:
        h.tick(0)
        first = h.wait_plan(lambda p: p.plan_id == 1)
        assert first.activities[0].start == 5
        h.forecast("antenna", 1, available=[[3, 12]])
        h.tick(1)
        h.forecast("antenna", 2, available=[[12, 20]])
        h.tick(2)
        plan = h.wait_plan(lambda p: p.trigger == "forecast")
        assert plan.plan_id == 2
        assert plan.activities[0].start == 12
        h.forecast("antenna", 3, available=[[20, 10]])
        status = h.wait_status(lambda s: s.event == "input_rejected")
        assert status.errors[0].path == "available[0]"
        h.tick(3)
        last_solve = h.query_status().last_solve
        assert last_solve is not None and last_solve.trigger == "forecast"
    report = verify(path)
    assert report.identical, report.summary()
    assert report.solves == 2


def test_the_orbit_day_replans_out_of_a_new_eclipse(tmp_path: Path) -> None:
    """Tests the Earth-observation day of examples/orbit.json on the bus:
    the first plan images T3 in high resolution in daylight; a forecast
    of a longer eclipse over it replans (trigger ``forecast``) so that
    nothing needing more power than the eclipse gives runs in it; the
    journal replays IDENTICAL."""
    from fsw_scheduler.journal.annotate import schema_lookup
    from fsw_scheduler.journal.replay import verify
    from fsw_scheduler.journal.writer import Recorder
    from fsw_scheduler.model.problem import decode_problem

    text = (ROOT / "examples" / "orbit.json").read_text()
    problem = decode_problem(text)
    path = tmp_path / "orbit.mcap"
    journal = Recorder(path, schemas=schema_lookup("sat1"))
    with SchedulerHarness(problem, node_options={"journal": journal}) as h:
        h.tick(0)
        first = h.wait_plan(lambda p: p.plan_id == 1)
        assert first.chosen == {
            "image-T1": 0,
            "image-T2": 1,
            "image-T3": 0,
            "image-T4": 0,
        }
        starts = {a.task: a.start for a in first.activities}
        assert starts["T3-HF"] == 121
        _fly(h, first, 100)
        # A longer eclipse in the second orbit: 60 of power in [118, 140).
        eclipse: list[list[float]] = [
            [100, 100],
            [118, 60],
            [140, 100],
            [157, 60],
            [190, 100],
        ]
        h.forecast("power", 100, steps=[*eclipse, [252, 60]])
        h.tick(101)
        plan = h.wait_plan(lambda p: p.trigger == "forecast")
        assert plan.status.value == "optimal"
        moved = {a.task: a for a in plan.activities}
        assert "T3-HF" in moved or "T3-LF" in moved
        for activity in plan.activities:
            needs = problem.task(activity.task).uses.get("power", 0)
            if activity.start < 140 and activity.end > 118:
                assert needs <= 60, activity
        assert not isinstance(plan.chosen, msgspec.UnsetType)
        assert set(plan.chosen) == {"image-T3", "image-T4"}
    report = verify(path)
    assert report.identical, report.summary()


def _fly(h: SchedulerHarness, plan: messages.PlanMessage, until: int) -> None:
    """Tick to ``until``, reporting each activity of ``plan`` running at its
    start and completed at its end, as an executor would."""
    events = sorted(
        [(a.start, 0, a.task, "running") for a in plan.activities]
        + [(a.end, 1, a.task, "completed") for a in plan.activities]
    )
    now = 0
    for at, _, task, state in events:
        if at > until:
            break
        if at > now:
            h.tick(at)
            now = at
        if state == "running":
            h.wait_dispatch(task)
        h.report(task, state, at)
    h.tick(until)
