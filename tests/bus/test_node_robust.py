"""Robustness of the scheduler node on a real Zenoh bus (issue 12).

Each test drives the real node on loopback peers (scouting off,
ephemeral ports) with the real CBC, and waits on received samples,
liveliness or query answers, never on fixed sleeps.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest
import zenoh

from fsw_scheduler.model.problem import MAX_ID_LENGTH
from fsw_scheduler.testing import harness_config
from fsw_scheduler.wire import messages
from fsw_scheduler.wire import topics as keys

from ..factories import CLI, DATA, bench_lib, ping_goal

if TYPE_CHECKING:
    from collections.abc import Callable

    import msgspec

    from fsw_scheduler.engine.events import StartSolve
    from fsw_scheduler.model.plan import Plan
    from fsw_scheduler.runtime.config import NodeConfig
    from fsw_scheduler.testing import SchedulerHarness

pytest_plugins = ["fsw_scheduler.testing"]


def goal_of(goal_id: str, *tasks: dict, **extra: object) -> dict:
    """A goal document with ``tasks``."""
    return {"goal_id": goal_id, "tasks": list(tasks), **extra}


def task(task_id: str, **extra: object) -> dict:
    """A short, cheap task that fits at once."""
    return {
        "id": task_id,
        "length": 1,
        "delay_cost": 5,
        "schedule_cost": 3,
        "uses": {"power": 5},
        **extra,
    }


def rejection(
    h: SchedulerHarness,
    goal: dict | bytes | str | msgspec.Struct,
    goal_id: str | None,
) -> messages.Status:
    """Publish ``goal`` and return the goal_rejected status naming it."""
    seen = len(h.statuses)
    h.publish_goal(goal)
    return h.wait_status(
        lambda s: s.event == "goal_rejected" and s.goal_id == goal_id,
        since=seen,
    )


# -- finding 2: key-safe ids -------------------------------------------------

UNSAFE_IDS = ["a/b", "x*", "$*", "q?", "h#", "a//b", "**", "@x", "", "é"]


def test_unsafe_task_ids_are_rejected_on_the_bus(
    started: SchedulerHarness,
) -> None:
    """Tests that key-unsafe or too long ids are rejected with path+reason."""
    h = started
    for n, bad in enumerate([*UNSAFE_IDS, "L" * 65_536]):
        status = rejection(h, goal_of(f"g{n}", task(bad)), f"g{n}")
        assert [e.path for e in status.errors] == ["tasks[0].id"], bad
        reason = status.errors[0].reason
        assert "ids are 1 to 64 characters" in reason
        assert len(reason) < 200  # a huge id is not echoed back
    # A bad goal id, a bad resource name and a bad obsoletes entry.
    status = rejection(h, goal_of("a/b", task("Fine")), "a/b")
    assert [e.path for e in status.errors] == ["goal_id"]
    long_id = "g" * (MAX_ID_LENGTH + 1)
    status = rejection(h, goal_of(long_id, task("Fine")), long_id)
    assert "at most 64" in status.errors[0].reason
    status = rejection(
        h, goal_of("res", task("Fine", uses={"po*wer": 1})), "res"
    )
    assert [e.path for e in status.errors] == ["tasks[0].uses['po*wer']"]
    status = rejection(
        h, goal_of("obs", task("Fine", obsoletes=["a/b"])), "obs"
    )
    assert [e.path for e in status.errors] == ["tasks[0].obsoletes[0]"]
    # Nothing was dispatched on a key built from a bad id, and the node
    # still serves.
    assert all(
        key.count("/") == 4 and "*" not in key
        for key, _ in h.samples
        if "/dispatch/" in key
    )
    status = h.tick(1)
    assert status.plan_id == 1
    assert status.counters.goals_rejected == len(UNSAFE_IDS) + 5


def test_unsafe_ids_are_rejected_by_solve_and_replan(
    tmp_path: Path, table1_doc: dict
) -> None:
    """Tests that solve and replan reject unsafe ids with path and reason."""
    doc = json.loads(json.dumps(table1_doc))
    doc["tasks"][0]["id"] = "Set/HF"
    doc["resources"]["binary"][0] = "cam*"
    problem = tmp_path / "p.json"
    problem.write_text(json.dumps(doc))
    done = subprocess.run(
        [*CLI, "solve", str(problem)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2
    assert "tasks[0].id: 'Set/HF' does not match the pattern" in done.stderr
    assert "resources.binary[0]: 'cam*' does not match" in done.stderr
    plan = tmp_path / "plan.json"
    solved = subprocess.run(
        [
            *CLI,
            "solve",
            str(DATA / "paper_table1.json"),
            "--out",
            str(plan),
        ],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert solved.returncode == 0, solved.stderr
    goal = tmp_path / "goal.json"
    goal.write_text(json.dumps(goal_of("g", task("**"))))
    replan = subprocess.run(
        [
            *CLI,
            "replan",
            str(DATA / "paper_table1.json"),
            str(plan),
            str(goal),
            "--now",
            "1",
        ],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert replan.returncode == 2
    assert "tasks[0].id: '**' does not match" in replan.stderr


# -- finding 9: hostile structure --------------------------------------------


def test_deep_nesting_and_dict_paths_on_the_bus(
    started: SchedulerHarness,
) -> None:
    """Tests that a deeply nested goal is rejected by name, paths name keys."""
    h = started
    deep = (
        b'{"goal_id": "deep", "pad": '
        + b"[" * 100_000
        + b"]" * 100_000
        + b', "tasks": []}'
    )
    status = rejection(h, deep, "deep")
    assert "nested too deeply" in status.errors[0].reason
    deep_first = b'{"tasks": ' + b"[" * 100_000 + b"]" * 100_000
    deep_first += b', "goal_id": "deep2"}'
    status = rejection(h, deep_first, "deep2")
    assert status.errors
    status = rejection(
        h, goal_of("typed", task("T", uses={"power": "lots"})), "typed"
    )
    assert [e.path for e in status.errors] == ["tasks[0].uses.power"]
    assert "must be a number" in status.errors[0].reason
    assert h.tick(1).plan_id == 1


def test_spacecraft_id_is_checked() -> None:
    """Tests that `run --spacecraft` refuses a key-unsafe id."""
    done = subprocess.run(
        [
            *CLI,
            "run",
            "--problem",
            str(DATA / "paper_table1.json"),
            "--spacecraft",
            "sat/*",
        ],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2
    assert "spacecraft id 'sat/*'" in done.stderr
    assert keys.DEFAULT_SPACECRAFT == "sat1"


# -- finding 1: a native fault does not kill the loop ------------------------


def _panic_type() -> type[BaseException]:
    """The exception type of a real Rust panic in zenoh-python.

    A put on a 70 kB key fails to write and panics; the pair of sessions
    used for it is thrown away (the panic poisons its transmit pipeline).
    """
    from fsw_scheduler.bus.session import open_peer_pair, wait_matching

    with open_peer_pair() as (a, b):
        sub = b.declare_subscriber("probe/**", lambda _s: None)
        wait_matching(a, "probe/x")
        try:
            a.put("probe/" + "x" * 70_000, b"")
        except BaseException as error:
            assert not isinstance(error, Exception)
            return type(error)
        finally:
            sub.undeclare()
    raise AssertionError("no panic")


class _FaultySession:
    """The node's session, with ``put`` panicking on some keys."""

    def __init__(
        self, real: zenoh.Session, poison: str, panic: type[BaseException]
    ) -> None:
        self._real = real
        self._poison = poison
        self._panic = panic
        self.raised = 0

    def put(self, key: str, *args: Any, **kwargs: Any) -> None:
        if self._poison in key:
            self.raised += 1
            raise self._panic("called `Result::unwrap()` on an `Err` value")
        self._real.put(key, *args, **kwargs)

    def __getattr__(self, name: str) -> object:
        return getattr(self._real, name)


def test_a_panic_in_a_publish_does_not_kill_the_loop(
    started: SchedulerHarness,
) -> None:
    """Tests that a BaseException from zenoh's put is survived per input."""
    h = started
    panic = _panic_type()
    outputs = h.node._outputs
    faulty = _FaultySession(outputs.session, "dispatch/SetPositionK", panic)
    outputs.session = faulty  # type: ignore[assignment]  # a stand-in
    plan = h.wait_plan()
    k = next(a for a in plan.activities if a.task == "SetPositionK")
    # Not tick(): it waits for every counted dispatch, and one never goes.
    h.clock(k.start)
    status = h.query_status()
    while status.now != k.start:
        status = h.query_status()
    assert faulty.raised == 1
    assert h.node.alive and h.node.failed is None
    assert status.counters.publish_failures == 1
    # Still serving: a later goal gets its verdict, queries are answered.
    h.publish_goal(goal_of("after-panic", task("Late")))
    h.wait_status(
        lambda s: s.event == "goal_accepted" and s.goal_id == "after-panic"
    )
    assert h.query_status().counters.publish_failures == 1


class _PanickingPublisher:
    def __init__(self, panic: type) -> None:
        self._panic = panic

    def put(self, *_args: object, **_kwargs: object) -> None:
        raise self._panic("called `Result::unwrap()` on an `Err` value")

    def undeclare(self) -> None:
        pass


def test_a_bus_refusing_every_publish_stops_the_node(
    started: SchedulerHarness,
) -> None:
    """Tests that a poisoned transmit pipeline ends in a withdrawn token."""
    from .peers import Liveliness

    h = started
    panic = _panic_type()
    node = h.node
    outputs = node._outputs
    # Stand-ins for the session and the publishers, raising as zenoh does.
    outputs.session = _FaultySession(outputs.session, "fsw/", panic)  # type: ignore[assignment]
    for suffix in list(outputs.publishers):
        outputs.publishers[suffix] = _PanickingPublisher(panic)  # type: ignore[assignment]
    watch = Liveliness(h.client)
    try:
        watch.expect(zenoh.SampleKind.PUT)
        for n in range(25):  # each rejection is a status publish
            h.publish_goal(goal_of(f"bad{n}", task("a/b")))
        watch.expect(zenoh.SampleKind.DELETE)
    finally:
        watch.close()
    assert node.wait_stopped(5)
    assert node.failed is not None
    assert "publishes failed in a row" in node.failed


POISONED_RUN = """
import sys
from fsw_scheduler import engine

real_step = engine.Engine.step


def step(self, event, now):
    goal = getattr(event, "goal", None)
    if goal is not None and goal.goal_id == "poison":
        raise SystemExit("a fault the loop's guard lets through")
    return real_step(self, event, now)


engine.Engine.step = step
from fsw_scheduler.cli import main

sys.exit(main(sys.argv[1:]))
"""


def test_a_dead_loop_withdraws_its_token_and_exits_non_zero(
    tmp_path: Path,
) -> None:
    """Tests that a loop that dies says error, drops its token, exits 1."""
    import zenoh

    from fsw_scheduler.bus.session import (
        listening_endpoints,
        loopback_config,
    )
    from fsw_scheduler.testing import SchedulerClient

    from .peers import Liveliness

    script = tmp_path / "poisoned.py"
    script.write_text(POISONED_RUN)
    # The test listens; the node connects to it (no port race).
    with zenoh.open(loopback_config()) as session:
        (endpoint,) = [
            e for e in listening_endpoints(session) if e.startswith("tcp/")
        ]
        watch = Liveliness(session)
        client = SchedulerClient(session)
        process = subprocess.Popen(
            [
                sys.executable,
                str(script),
                "run",
                "--problem",
                str(DATA / "paper_table1.json"),
                "--clock",
                "bus",
                "--mode",
                "peer",
                "--connect",
                endpoint,
                "--listen",
                "tcp/127.0.0.1:0",
                "--no-multicast-scouting",
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            watch.expect(zenoh.SampleKind.PUT, timeout=30)
            client.wait_scheduler(30)
            client.tick(0, timeout=30)
            client.publish_goal(goal_of("poison", task("P")))
            error = client.wait_status(lambda s: s.state == "error")
            assert "event loop stopped" in error.detail
            assert error.event == "loop_stopped"
            watch.expect(zenoh.SampleKind.DELETE)
            assert process.wait(20) == 1
            assert process.stderr is not None
            assert "error: SystemExit" in process.stderr.read()
        finally:
            if process.poll() is None:
                process.kill()
                process.wait(10)
            if process.stderr is not None:
                process.stderr.close()
            client.close()
            watch.close()


# -- finding 3: no silent input loss -----------------------------------------


@pytest.mark.parametrize(
    "scheduler_config",
    [
        harness_config(
            inbox_capacity=2, goals_waiting=3, goals_per_solve=2, live_tasks=14
        )
    ],
)
def test_a_goal_flood_gets_a_verdict_for_every_goal(
    started: SchedulerHarness, scheduler_config: NodeConfig
) -> None:
    """Tests that every flooded goal is accepted or rejected by name."""
    h = started
    sent = [f"flood{n}" for n in range(150)]
    publisher = h.client.declare_publisher(
        h.topics.key(keys.GOALS),
        congestion_control=zenoh.CongestionControl.BLOCK,
    )
    try:
        for goal_id in sent:
            publisher.put(json.dumps(goal_of(goal_id, task(f"T{goal_id}"))))
    finally:
        publisher.undeclare()
    verdicts: dict[str, list[str]] = {}

    def all_decided() -> bool:
        verdicts.clear()
        for s in list(h.statuses):
            if s.event in ("goal_accepted", "goal_rejected") and s.goal_id:
                verdicts.setdefault(s.goal_id, []).append(
                    s.errors[0].reason if s.errors else "accepted"
                )
        return set(verdicts) >= set(sent)

    with h._cond:
        assert h._cond.wait_for(all_decided, 60), set(sent) - set(verdicts)
    assert all(len(v) == 1 for v in verdicts.values())  # one verdict each
    reasons = [v[0] for v in verdicts.values()]
    busy = [r for r in reasons if r.startswith("busy: ")]
    assert busy, reasons
    assert all(r.endswith(" goals waiting") for r in busy)
    accepted = {g for g, v in verdicts.items() if v == ["accepted"]}
    status = h.settle()
    assert status.counters.goals_accepted == len(accepted)
    assert status.counters.goals_rejected == len(sent) - len(accepted)
    plan = h.query_plan()
    assert plan is not None
    planned = {a.task for a in plan.activities} | set(plan.unscheduled)
    assert {f"T{g}" for g in accepted} <= planned


def test_telemetry_is_coalesced_never_lost(
    started: SchedulerHarness,
) -> None:
    """Tests that a telemetry flood is processed or superseded, not lost."""
    h = started
    battery = h.problem.resources.consumable["battery"]
    before = h.settle(0)
    seen = h.node.engine.inputs_seen
    publisher = h.client.declare_publisher(
        h.topics.resource_level("battery"),
        congestion_control=zenoh.CongestionControl.BLOCK,
    )
    sent = 3000
    try:
        for _ in range(sent):
            publisher.put(
                json.dumps({"resource": "battery", "level": battery, "at": 0})
            )
    finally:
        publisher.undeclare()
    after = h.settle(0)
    processed = h.node.engine.inputs_seen - seen
    superseded = (
        after.counters.telemetry_superseded
        - before.counters.telemetry_superseded
    )
    assert processed + superseded == sent
    assert after.counters.inputs_dropped == 0
    assert after.plan_id == before.plan_id


def test_telemetry_dropped_for_spent_bytes_is_answered(
    tmp_path: Path,
) -> None:
    """Tests that a telemetry flood that spends inbox-bytes has every
    dropped sample answered (input_rejected, counted, at most one per key
    and second), while the node answers queries, the plan runs on and the
    journal replays identically."""
    import itertools
    import re

    from fsw_scheduler.bus.inbox import DROP_NOTICE_S
    from fsw_scheduler.journal.annotate import schema_lookup
    from fsw_scheduler.journal.reader import iter_messages
    from fsw_scheduler.journal.replay import verify
    from fsw_scheduler.journal.writer import Recorder
    from fsw_scheduler.testing import SchedulerHarness

    path = tmp_path / "journal.mcap"
    limit = 1 << 20  # the smallest inbox-bytes: two samples do not fit
    harness = SchedulerHarness(
        config=harness_config(inbox_bytes=limit),
        node_options={
            "journal": Recorder(path, schemas=schema_lookup("sat1"))
        },
    )
    with harness as h:
        h.tick(0)
        h.publish_goal(goal_of("g", task("Work", feasible_interval=[3, 40])))
        plan = h.wait_plan(lambda p: "g" in p.goals)
        start = next(a.start for a in plan.activities if a.task == "Work")
        consumable = h.problem.resources.consumable
        before = h.settle(0)
        publishers = {
            name: h.client.declare_publisher(
                h.topics.resource_level(name),
                congestion_control=zenoh.CongestionControl.BLOCK,
            )
            for name in consumable
        }
        pad = b" " * (limit * 6 // 10)
        sent = 0
        seen = len(h.statuses)
        try:
            for n in range(40):
                name = sorted(consumable)[n % 2]
                level = {"resource": name, "level": consumable[name], "at": 0}
                publishers[name].put(json.dumps(level).encode() + pad)
                sent += 1
            # One larger than the whole inbox: dropped whatever the timing.
            publishers["battery"].put(b"{}" + pad + pad)
            sent += 1
            answered = h.query_status(5.0)  # responsive amid the flood
            assert answered.plan_id == plan.plan_id
        finally:
            for publisher in publishers.values():
                publisher.undeclare()
        after = h.settle(0)
        dropped = after.counters.inputs_dropped
        assert dropped > 0
        counted = re.compile(r"dropped: (\d+) samples? unread, ")

        def answers() -> list[messages.Status]:
            return [
                s
                for s in h.statuses[seen:]
                if s.event == "input_rejected"
                and s.errors
                and counted.match(s.errors[0].reason)
            ]

        def count(status: messages.Status) -> int:
            found = counted.match(status.errors[0].reason)
            assert found is not None  # answers() keeps only matches
            return int(found[1])

        def all_answered() -> bool:
            return sum(count(s) for s in answers()) >= dropped

        with h._cond:  # the held answers come within DROP_NOTICE_S
            assert h._cond.wait_for(all_answered, 10 + DROP_NOTICE_S)
        rejections = answers()
        # Every dropped sample once, none twice.
        assert sum(count(s) for s in rejections) == dropped
        keys = {s.detail for s in rejections}
        assert keys <= {
            f"resource_level on {h.topics.resource_level(n)} ignored"
            for n in consumable
        }
        assert all(
            f"{limit} bytes" in s.errors[0].reason
            and "inbox-bytes" in s.errors[0].reason
            for s in rejections
        )
        assert any(
            "larger than the whole inbox" in s.errors[0].reason
            for s in rejections
        )
        superseded = (
            after.counters.telemetry_superseded
            - before.counters.telemetry_superseded
        )
        # The plan runs on: the flood made no replan, and the activity
        # is dispatched when its time comes.
        assert after.plan_id == plan.plan_id
        h.tick(start)
        h.wait_dispatch("Work")
    levels = {h.topics.resource_level(n) for n in consumable}
    processed = sum(1 for m in iter_messages(path) if m.topic in levels)
    assert processed + superseded + dropped == sent
    report = verify(path)
    assert report.identical, report.summary()
    records = [
        m
        for m in iter_messages(path)
        if m.topic.endswith("/scheduler/dropped")
    ]
    assert len(records) == len(rejections)
    # Bounded: the answers on one key are DROP_NOTICE_S apart at least.
    notice_times: dict[str, list[int]] = {}
    for record in records:
        key = json.loads(record.payload)["key"]
        notice_times.setdefault(key, []).append(record.log_time_ns)
    for times in notice_times.values():
        gaps = [b - a for a, b in itertools.pairwise(times)]
        assert all(gap >= 0.9e9 * DROP_NOTICE_S for gap in gaps), gaps


# -- finding 5: goals waiting behind a solve, limits -------------------------


def test_goals_behind_a_solve_are_queued_at_once(
    scheduler_problem: object,
) -> None:
    """Tests goal_queued for a goal waiting behind a running solve."""
    from fsw_scheduler.runtime.policy import run_solve
    from fsw_scheduler.testing import SchedulerHarness

    release = threading.Event()

    def held(config: NodeConfig, command: StartSolve) -> Plan:
        if command.trigger == "goal":
            release.wait(30)
        return run_solve(config, command)

    with SchedulerHarness(
        config=harness_config(tasks_per_goal=2, live_tasks=11),
        solve_fn=held,
    ) as h:
        h.tick(0)
        h.publish_goal(goal_of("first", task("A")))
        while not h.query_status().busy:  # each query waits on the node
            pass
        h.publish_goal(goal_of("second", task("B")))
        queued = h.wait_status(lambda s: s.event == "goal_queued")
        assert queued.goal_id == "second"
        assert "waiting behind solve" in queued.detail
        status = rejection(
            h, goal_of("big", task("C"), task("D"), task("E")), "big"
        )
        assert [e.path for e in status.errors] == ["tasks"]
        assert "limit is 2 per goal" in status.errors[0].reason
        release.set()
        for goal_id in ("first", "second"):
            h.wait_status(
                lambda s: s.event == "goal_accepted" and s.goal_id == goal_id
            )
        # 9 tasks of Table 1, A and B: the limit of 11 live tasks is full.
        status = rejection(h, goal_of("third", task("F")), "third")
        assert [e.path for e in status.errors] == ["tasks"]
        assert "12 live tasks; the limit is 11" in status.errors[0].reason


# -- finding 7: verdicts carry what changed -----------------------------------


@pytest.mark.parametrize("scheduler_config", [harness_config(heartbeat=5)])
def test_verdicts_carry_changes_heartbeats_the_map(
    started: SchedulerHarness, scheduler_config: NodeConfig
) -> None:
    """Tests that only heartbeats and queries carry the lifecycle map."""
    h = started
    for n in range(3):
        h.publish_goal(goal_of(f"v{n}", task(f"V{n}")))
        goal_id = f"v{n}"
        h.wait_status(
            lambda s: s.event == "goal_accepted" and s.goal_id == goal_id
        )
    h.settle(0)
    raw = [
        json.loads(p) for k, p in h.samples if k == h.topics.key(keys.STATUS)
    ]
    verdicts = [r for r in raw if r["event"] != "heartbeat"]
    assert verdicts and all("activities" not in r for r in verdicts)
    # The changes, applied in order, rebuild the full map.
    rebuilt: dict[str, str] = {}
    for r in raw:
        rebuilt.update(r.get("activities", {}))
        rebuilt.update(r.get("changed", {}))
    # Dispatches after the last status are seen on the dispatch keys.
    for d in h.dispatches:
        if rebuilt.get(d.task) == "planned":
            rebuilt[d.task] = "dispatched"
    assert rebuilt == h.query_status().activities
    plan_status = next(r for r in reversed(raw) if r["event"] == "plan")
    assert set(plan_status.get("changed", {})) <= set(rebuilt)
    h.tick(5)
    beat = h.wait_status(lambda s: s.event == "heartbeat")
    assert set(beat.activities) == set(h.query_status().activities)


# -- finding 8: one dispatch per plan change ----------------------------------


def test_replans_do_not_dispatch_again(started: SchedulerHarness) -> None:
    """Tests that a dispatched, unreported activity is not re-dispatched."""
    h = started
    first = h.wait_dispatch("SetPositionX")
    for n in range(6):
        h.publish_goal(goal_of(f"r{n}", task(f"R{n}")))
        goal_id = f"r{n}"
        h.wait_plan(lambda p: goal_id in p.goals)
    h.settle(0)
    again = [d for d in h.dispatches if d.task == "SetPositionX"]
    assert again == [first]
    assert first.dispatch_id == f"SetPositionX:{first.start}-{first.end}"
    assert h.query_status().activities["SetPositionX"] == "dispatched"


# -- finding 4: clock bounds and a stalled bus clock --------------------------


def test_clock_jumps_are_rejected_and_time_stays(
    started: SchedulerHarness,
) -> None:
    """Tests that huge or out-of-range clock values are rejected."""
    h = started
    plan = h.wait_plan()
    dispatched = len(h.dispatches)
    for now, words in (
        (2**62, "outside [0, 2147483647]"),
        (2**20, "more than 100 units"),
        (10**6, "more than 100 units"),
        (2**31, "outside [0, 2147483647]"),
        (10**23, "outside [0, 2147483647]"),
        (-1, "outside"),
    ):
        seen = len(h.statuses)
        h.clock(now)
        status = h.wait_status(
            lambda s: s.event == "input_rejected", since=seen
        )
        assert [e.path for e in status.errors] == ["now"]
        assert words in status.errors[0].reason, status.errors[0].reason
    status = h.settle(0)
    assert len(h.dispatches) == dispatched  # nothing fired
    status = h.tick(1)
    assert status.plan_id == plan.plan_id
    first = {a.task for a in plan.activities if a.start <= 1}
    assert {d.task for d in h.dispatches} == first


@pytest.mark.parametrize("scheduler_config", [harness_config(clock_stall=0.3)])
def test_a_stalled_bus_clock_degrades_the_status(
    started: SchedulerHarness, scheduler_config: NodeConfig
) -> None:
    """Tests that no tick for clock-stall seconds gives degraded, why."""
    h = started
    stalled = h.wait_status(lambda s: s.event == "clock_stalled")
    assert stalled.state == "degraded"
    assert "bus clock stalled" in stalled.detail
    assert "since unit 0" in stalled.detail
    seen = len(h.statuses)
    h.clock(1)
    resumed = h.wait_status(lambda s: s.event == "clock_resumed", since=seen)
    assert resumed.state == "ok"


@pytest.mark.parametrize("scheduler_config", [harness_config(clock_stall=0.2)])
def test_the_stall_alarm_waits_for_a_first_clock(
    scheduler_harness: SchedulerHarness, scheduler_config: NodeConfig
) -> None:
    """Tests a node that has never seen a clock (a session typed by hand):
    no ``clock_stalled`` for five times the limit, then one once a clock
    has come and stopped."""
    h = scheduler_harness
    with pytest.raises(TimeoutError):
        h.wait_status(lambda s: s.event == "clock_stalled", timeout=1.0)
    assert h.query_status().state == "ok"
    h.tick(0)
    stalled = h.wait_status(lambda s: s.event == "clock_stalled")
    assert "since unit 0" in stalled.detail


# -- finding 6: the solver dies with the node; a stop interrupts a solve ------


def _children(pid: int) -> list[int]:
    """Pids of the direct children of ``pid`` (Linux /proc)."""
    found = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        with_children = task / "children"
        if with_children.exists():
            found += [int(c) for c in with_children.read_text().split()]
    return found


def _cmdline(pid: int) -> str:
    try:
        raw = Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return ""
    return raw.decode(errors="replace")


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().split()[2]
    except OSError:
        return False
    return state != "Z"


def _wait_for(
    predicate: Callable[[], bool], timeout: float, what: str
) -> None:
    from fsw_scheduler.bus.session import wait_until

    wait_until(
        predicate,
        timeout,
        interval_s=0.02,
        what=what,
    )


def _long_solve_node(tmp_path: Path, *extra: str) -> tuple:
    """A `run` subprocess busy in a long CBC solve, and the CBC pid."""
    import zenoh

    from fsw_scheduler.bus.session import (
        listening_endpoints,
        loopback_config,
    )

    generate_problem = bench_lib("generator").generate_problem

    problem = tmp_path / "big.json"
    problem.write_text(json.dumps(generate_problem(60, "mixed", 336, 7)))
    session = zenoh.open(loopback_config())
    (endpoint,) = [
        e for e in listening_endpoints(session) if e.startswith("tcp/")
    ]
    process = subprocess.Popen(
        [
            *CLI,
            "run",
            "--problem",
            str(problem),
            "--clock",
            "bus",
            "--time-limit",
            "120",
            "--connect",
            endpoint,
            "--listen",
            "tcp/127.0.0.1:0",
            "--no-multicast-scouting",
            *extra,
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    return session, process


def _start_cbc(session: zenoh.Session, process: subprocess.Popen) -> int:
    from fsw_scheduler.testing import SchedulerClient

    client = SchedulerClient(session)
    try:
        client.wait_scheduler(30)
        client.clock(0)  # the initial solve starts
    finally:
        client.close()
    cbc: list[int] = []

    def cbc_running() -> bool:
        cbc[:] = [
            c for c in _children(process.pid) if "fsw-cbc-" in _cmdline(c)
        ]
        return bool(cbc)

    _wait_for(cbc_running, 60, "CBC started by the node")
    return cbc[0]


def test_cbc_dies_with_a_killed_node(tmp_path: Path) -> None:
    """Tests that SIGKILL of the node during a solve also ends CBC."""
    session, process = _long_solve_node(tmp_path)
    try:
        cbc = _start_cbc(session, process)
        model = next(
            part for part in _cmdline(cbc).split("\0") if "fsw-cbc-" in part
        )
        process.kill()
        process.wait(10)
        _wait_for(lambda: not _alive(cbc), 5, "CBC gone with its parent")
        # Its temporary directory is left; the next node removes it.
        from fsw_scheduler.solving.ilp.child import sweep_stale_dirs

        folder = str(Path(model).parent)
        assert Path(folder).exists()
        assert folder in sweep_stale_dirs()
        assert not Path(folder).exists()
    finally:
        if process.poll() is None:
            process.kill()
            process.wait(10)
        if process.stderr is not None:
            process.stderr.close()
        session.close()


def test_sigterm_interrupts_a_solve_and_exits_0(tmp_path: Path) -> None:
    """Tests that SIGTERM during a solve stops within a second, exit 0."""
    import time

    from fsw_scheduler.journal.reader import iter_messages

    journal = tmp_path / "journal.mcap"
    session, process = _long_solve_node(tmp_path, "--record", str(journal))
    try:
        cbc = _start_cbc(session, process)
        asked = time.monotonic()
        process.send_signal(signal.SIGTERM)
        assert process.wait(10) == 0
        took = time.monotonic() - asked
        assert not _alive(cbc)
        assert took < 2.0, f"stopped {took:.2f} s after SIGTERM"
        topics = {m.topic for m in iter_messages(journal)}
        assert "fsw/sat1/clock" in topics  # a finished, readable journal
    finally:
        if process.poll() is None:
            process.kill()
            process.wait(10)
        if process.stderr is not None:
            process.stderr.close()
        session.close()


# -- finding 5: a deadline over the whole goal -> plan path -------------------


def _generated(num_tasks: int, seed: int) -> dict:
    generate_problem = bench_lib("generator").generate_problem

    return generate_problem(num_tasks, "mixed", 336, seed)


def test_the_response_deadline_bounds_goal_to_plan() -> None:
    """Tests that a hard goal gets its plan within the response deadline."""
    import time

    from fsw_scheduler.testing import SchedulerHarness

    doc = _generated(60, 7)
    empty = json.dumps({**doc, "tasks": [], "precedences": []})
    config = harness_config(response_deadline=2.0, time_limit=60.0)
    with SchedulerHarness(empty, config) as h:
        h.tick(0)
        goal = {
            "goal_id": "hard",
            "tasks": doc["tasks"],
            "precedences": doc["precedences"],
        }
        sent = time.monotonic()
        h.publish_goal(goal)
        plan = h.wait_plan(lambda p: "hard" in p.goals, timeout=30)
        took = time.monotonic() - sent
        # Without the deadline the solve runs to its 60 s limit.
        assert took < 5.0, f"goal -> plan took {took:.2f} s"
        assert plan.stats is not None
        assert plan.stats.time_limit_s is not None
        assert plan.stats.time_limit_s < 2.0


@pytest.mark.parametrize(
    "scheduler_config", [harness_config(explain=True, explain_budget=5.0)]
)
def test_explanations_follow_the_plan(
    started: SchedulerHarness, scheduler_config: NodeConfig
) -> None:
    """Tests that a plan is published unexplained, then `explained`."""
    h = started
    huge = task("Huge", uses={"power": 1000}, schedule_cost=1)
    h.publish_goal(goal_of("too-long", huge))
    plan = h.wait_plan(lambda p: "too-long" in p.goals)
    assert "Huge" in plan.unscheduled
    assert plan.why == ()  # not waited for
    explained = h.wait_status(lambda s: s.event == "explained")
    assert explained.plan_id == plan.plan_id
    assert [b.task for b in explained.why] == ["Huge"]
    queried = h.query_plan()
    assert queried is not None
    assert [b.task for b in queried.why] == ["Huge"]


# -- the new journal channels replay exactly ----------------------------------


def test_a_journal_with_busy_and_explained_replays(tmp_path: Path) -> None:
    """Tests that busy rejections and late explanations replay identically."""
    from fsw_scheduler.bus.node import SchedulerNode
    from fsw_scheduler.bus.session import open_peer_pair, wait_matching
    from fsw_scheduler.journal.annotate import schema_lookup
    from fsw_scheduler.journal.replay import verify
    from fsw_scheduler.journal.writer import Recorder
    from fsw_scheduler.testing import SchedulerClient, paper_problem

    path = tmp_path / "journal.mcap"
    config = harness_config(
        explain=True, goals_waiting=1, goals_per_solve=1, inbox_capacity=1
    )
    with open_peer_pair() as (server, client_session):
        client = SchedulerClient(client_session)
        for key in ("plan", "status"):
            wait_matching(server, client.topics.key(f"scheduler/{key}"))
        journal = Recorder(path, schemas=schema_lookup("sat1"))
        node = SchedulerNode(server, paper_problem(), config, journal=journal)
        node.start()
        try:
            client.wait_scheduler()
            client.tick(0)
            huge = task("Huge", uses={"power": 1000}, schedule_cost=1)
            client.publish_goal(goal_of("too-big", huge))
            for n in range(80):
                client.publish_goal(goal_of(f"b{n}", task(f"B{n}")))
            client.wait_status(lambda s: s.event == "explained")
            client.wait_status(
                lambda s: (
                    s.event == "goal_rejected"
                    and s.errors[0].reason.startswith("busy")
                )
            )
            client.settle(0)
            client.tick(1)
        finally:
            node.close()
            client.close()
    report = verify(path)
    assert report.identical, report.summary()
    assert report.solves >= 2
    from fsw_scheduler.journal.reader import iter_messages

    topics = {m.topic for m in iter_messages(path)}
    assert "fsw/sat1/scheduler/explained" in topics
    assert "fsw/sat1/scheduler/busy" in topics


def test_inbox_bounds_without_blocking() -> None:
    """Tests the inbox's coalescing, goal limits and key bound directly."""
    from fsw_scheduler.bus import inbox as inbox_module
    from fsw_scheduler.bus.inbox import Inbox

    inbox = Inbox(max_goals=2, max_bytes=100)
    assert inbox.put_goal("g", b"x" * 40, 0.0)
    assert inbox.put_goal("g", b"x" * 40, 0.0)
    assert not inbox.put_goal("g", b"x", 0.0)  # count limit
    inbox.put_latest("resource_level", "k1", b"a" * 10)
    inbox.put_latest("resource_level", "k1", b"b" * 15)  # replaces
    assert (inbox.superseded, inbox.bytes) == (1, 95)
    inbox.put_latest("resource_level", "k2", b"c" * 10)  # bytes spent
    assert inbox.lost == 1
    kinds = [inbox.get(0.01) for _ in range(5)]
    assert [k[0] if k else None for k in kinds] == [
        "dropped",  # its answer goes first
        "goal",
        "goal",
        "resource_level",
        None,
    ]
    assert kinds[3] is not None and kinds[3][2] == b"b" * 15
    assert (inbox.goals, inbox.bytes, len(inbox)) == (0, 0, 0)
    big = Inbox(max_goals=1, max_bytes=1 << 30)
    for n in range(inbox_module.MAX_PENDING_KEYS + 5):
        big.put_latest("resource_level", f"k{n}", b"1")
    assert big.lost == 5


def test_a_full_disk_degrades_and_durability_returns(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Tests ENOSPC on the journal: the node says ``journal_failed``
    (degraded, durable false) at once, keeps answering every input, and
    when space returns continues in a new part, ``journal_resumed``; every
    part it wrote verifies or is finished as a crash's would be."""
    import errno

    from fsw_scheduler.bus import outputs
    from fsw_scheduler.journal.annotate import schema_lookup
    from fsw_scheduler.journal.integrity import check_file
    from fsw_scheduler.journal.writer import Recorder

    full = {"on": False}
    write, open_part = Recorder.write, Recorder._open_part

    def failing(real: Any) -> Any:
        def call(self: Recorder, *args: Any, **kwargs: Any) -> Any:
            if full["on"]:
                raise OSError(errno.ENOSPC, "No space left on device")
            return real(self, *args, **kwargs)

        return call

    monkeypatch.setattr(Recorder, "write", failing(write))
    monkeypatch.setattr(Recorder, "_open_part", failing(open_part))
    monkeypatch.setattr(outputs, "JOURNAL_RETRY_S", 0.2)
    recorder = Recorder(
        tmp_path / "journal-0001.mcap", schemas=schema_lookup("sat1")
    )
    options = {"journal": recorder, "durable": True}
    from fsw_scheduler.testing import SchedulerHarness as Harness

    with Harness(node_options=options) as h:
        h.tick(0)
        h.wait_plan(lambda p: p.plan_id == 1)
        full["on"] = True
        h.tick(1)
        failed = h.wait_status(lambda s: s.event == "journal_failed")
        assert failed.state == "degraded" and not failed.durable
        assert "No space left" in failed.detail
        # Asked later, the node still says it (not the engine's "ok").
        asked = h.query_status()
        assert asked.state == "degraded" and not asked.durable
        assert "journal: " in asked.detail and "No space left" in asked.detail
        h.publish_goal(ping_goal("while-full", "Full"))
        verdict = h.wait_status(
            lambda s: s.goal_id == "while-full" and s.event == "goal_accepted"
        )
        assert not verdict.durable
        full["on"] = False
        back = h.wait_status(lambda s: s.event == "journal_resumed", 10)
        assert back.durable
        asked = h.query_status()
        assert asked.state == "ok" and asked.durable and not asked.detail
        h.tick(2)
    for path in recorder.paths:
        assert check_file(path).ok, check_file(path).describe()
    assert len(recorder.paths) == 2


def test_a_state_folder_deleted_under_the_node_is_said_and_rebuilt(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Tests a state folder removed while the node runs: the next step
    says ``journal_failed`` naming the deleted part (it used to write on
    into an unlinked file, durable in name only), goals are still
    answered, and the journal comes back in a new part of a recreated
    folder that holds the settings and a snapshot and verifies."""
    import shutil

    from fsw_scheduler.bus import outputs
    from fsw_scheduler.journal.annotate import schema_lookup
    from fsw_scheduler.journal.integrity import check_file
    from fsw_scheduler.journal.reader import iter_messages
    from fsw_scheduler.journal.writer import Recorder

    monkeypatch.setattr(outputs, "JOURNAL_RETRY_S", 0.2)
    folder = tmp_path / "state"
    recorder = Recorder(
        folder / "journal-0001.mcap", schemas=schema_lookup("sat1")
    )
    options = {"journal": recorder, "durable": True}
    from fsw_scheduler.testing import SchedulerHarness as Harness

    with Harness(node_options=options) as h:
        h.tick(0)
        h.wait_plan(lambda p: p.plan_id == 1)
        shutil.rmtree(folder)
        h.tick(1)
        failed = h.wait_status(lambda s: s.event == "journal_failed")
        assert failed.state == "degraded" and not failed.durable
        assert "deleted while open" in failed.detail, failed.detail
        h.publish_goal(ping_goal("while-gone", "Gone"))
        h.wait_status(
            lambda s: s.goal_id == "while-gone" and s.event == "goal_accepted"
        )
        back = h.wait_status(lambda s: s.event == "journal_resumed", 10)
        assert back.durable
        h.tick(2)
    assert not recorder.paths[0].exists()
    rebuilt = recorder.paths[-1]
    assert rebuilt.parent == folder and rebuilt.exists()
    assert check_file(rebuilt).ok, check_file(rebuilt).describe()
    keys = {message.topic for message in iter_messages(rebuilt)}
    assert any(key.endswith("scheduler/snapshot") for key in keys), keys


def test_a_start_on_a_full_disk_commands_and_says_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Tests a node whose journal could not be opened at start: it
    commands, says ``journal_failed`` (durable false) at once, answers
    goals, and opens its journal when it can."""
    from fsw_scheduler.bus import outputs
    from fsw_scheduler.journal.annotate import schema_lookup
    from fsw_scheduler.journal.integrity import check_file
    from fsw_scheduler.journal.writer import Recorder
    from fsw_scheduler.testing import SchedulerHarness as Harness

    monkeypatch.setattr(outputs, "JOURNAL_RETRY_S", 0.5)
    recorder = Recorder(
        tmp_path / "journal-0001.mcap",
        schemas=schema_lookup("sat1"),
        open_now=False,
    )
    options = {
        "journal": recorder,
        "durable": True,
        "journal_fault": "OSError: [Errno 28] No space left on device",
    }
    with Harness(node_options=options) as h:
        failed = h.wait_status(lambda s: s.event == "journal_failed")
        assert failed.state == "degraded" and not failed.durable
        h.tick(0)
        h.wait_plan(lambda p: p.plan_id == 1)
        h.wait_status(lambda s: s.event == "journal_resumed", 10)
        h.tick(1)
    (path,) = recorder.paths
    assert check_file(path).ok
