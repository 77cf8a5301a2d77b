"""Tests of the deployment users run: several spacecraft, each with an
active scheduler and a standby, and a ground monitor, through two Zenoh
router processes; a node killed, a router killed and restarted.

No cross-talk between spacecraft (each plan holds its own goals only, each
commander stays in its own terms), one commander per spacecraft, nothing
executed twice at a fencing receiver, every journal replays identical.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from typing import TYPE_CHECKING

import pytest
import zenoh

from fsw_scheduler.bus.session import loopback_config
from fsw_scheduler.journal.replay import verify
from fsw_scheduler.journal.state import journal_files
from fsw_scheduler.testing import SchedulerClient

from ..factories import ping_goal
from ..journal.test_resume import soak_resume
from .test_partition import soak_partition

if TYPE_CHECKING:
    from pathlib import Path

SPACECRAFT = ("sat1", "sat2", "sat3")

ROUTER = """
import json, sys, threading, zenoh
port, connect = int(sys.argv[1]), json.loads(sys.argv[2])
config = zenoh.Config()
config.insert_json5("mode", '"router"')
config.insert_json5("listen/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
config.insert_json5("connect/endpoints", json.dumps(connect))
config.insert_json5("scouting/multicast/enabled", "false")
# Retry a missing router often: the tests decide when the mesh forms.
config.insert_json5(
    "connect/retry",
    "{period_init_ms: 100, period_max_ms: 100, period_increase_factor: 1}",
)
session = zenoh.open(config)
print("router up", flush=True)
threading.Event().wait()
"""


def _router(port: int, connect: list[str]) -> subprocess.Popen:
    """A Zenoh router in its own OS process, up when it says so."""
    process = subprocess.Popen(
        [sys.executable, "-c", ROUTER, str(port), json.dumps(connect)],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None
    assert process.stdout.readline().strip() == "router up"
    return process


#: Seconds the restarted router stays apart from the other after the first
#: standby is back on it: longer than re-verifying takes (discovery 0.2 s
#: and a query), well within the settle time (the 2 s lease) after it.
MESH_LATE_S = 1.0


def _wait_members_on(port: int, names: tuple[str, ...]) -> float:
    """Wait until the schedulers ``names`` are on the router at ``port``
    (their member tokens answer a liveliness query through it); the
    monotonic time the first of them was seen there.

    Each standby reconnects on its own retry clock, seconds apart at
    worst: the mesh delay is measured from the first one back.
    """
    config = loopback_config(listen=None, connect=[f"tcp/127.0.0.1:{port}"])
    config.insert_json5("mode", '"client"')
    deadline = time.monotonic() + 60
    first: float | None = None
    with zenoh.open(config) as session:
        while time.monotonic() < deadline:
            seen = {
                str(reply.ok.key_expr).rsplit("/", 1)[-1]
                for reply in session.liveliness().get(
                    "fsw/*/scheduler/nodes/**"
                )
                if reply.ok is not None
            }
            if first is None and seen & set(names):
                first = time.monotonic()
            if first is not None and set(names) <= seen:
                return first
    raise AssertionError(f"{names} never came back on the router ({seen})")


@pytest.mark.slow
def test_three_spacecraft_through_two_routers(tmp_path: Path) -> None:
    """Tests 3 spacecraft x (active + standby) and a ground monitor on two
    routers: goals land on their spacecraft only; a killed commander is
    replaced by its standby, in a higher term, the others keep theirs; a
    router killed and restarted changes no commander."""
    partition = soak_partition()
    free = soak_resume().free_port
    p1, p2 = free(), free()
    routers = {
        "R1": _router(p1, []),
        "R2": _router(p2, [f"tcp/127.0.0.1:{p1}"]),
    }
    nodes = {
        (sc, name): partition.node(
            tmp_path / sc / name,
            p1 if name == "A" else p2,
            f"{sc}-{name}",
            rank,
            sc,
        )
        for sc in SPACECRAFT
        for name, rank in (("A", 0), ("B", 1))
    }
    try:
        config = loopback_config(listen=None, connect=[f"tcp/127.0.0.1:{p1}"])
        config.insert_json5("mode", '"client"')
        with zenoh.open(config) as session:
            ground = {
                sc: SchedulerClient(session, sc, timeout=60.0)
                for sc in SPACECRAFT
            }
            for sc in SPACECRAFT:
                assert nodes[(sc, "A")].start() == "scheduler up on"
                assert nodes[(sc, "B")].start() == "standing by"
            for sc in SPACECRAFT:
                ground[sc].wait_scheduler(60)
                ground[sc].tick(0)
                answers = ground[sc].send_goals(
                    [ping_goal(f"{sc}-goal", f"{sc.upper()}Ping")], timeout=60
                )
                assert answers == {f"{sc}-goal": {"goal_accepted"}}
            # A commander dies: only its spacecraft changes hands.
            nodes[("sat2", "A")].kill()
            took = ground["sat2"].wait_status(
                lambda s: s.event == "took_over" and s.node_id == "sat2-B", 60
            )
            assert took.term > 1
            # A router dies with every standby but sat2's commander behind
            # it, and comes back; it meshes with R1 only a while after the
            # standbys are back on it, seeing no commander (a router that
            # restarts before the link to the other computer is up).
            routers["R2"].kill()
            routers["R2"].wait(10)
            if routers["R2"].stdout is not None:
                routers["R2"].stdout.close()
            for sc in ("sat1", "sat3"):
                ground[sc].tick(1)
            mesh = free()
            routers["R2"] = _router(p2, [f"tcp/127.0.0.1:{mesh}"])
            first = _wait_members_on(p2, ("sat1-B", "sat3-B"))
            # Longer than a standby back on the bus takes to re-verify.
            time.sleep(max(0.0, first + MESH_LATE_S - time.monotonic()))
            relay = partition.SilentLink(p1, port=mesh)
            ground["sat2"].wait_scheduler(60)
            deadline = time.monotonic() + 60
            for sc in SPACECRAFT:
                for now in range(1, 8):
                    # Just after the mesh a clock put may be lost while
                    # a query gets through: a bus clock publishes again.
                    _tick_resending(ground[sc], now, deadline)
            for sc in SPACECRAFT:
                client = ground[sc]
                goals = {g for p in client.plans for g in p.goals}
                assert goals == {f"{sc}-goal"}, (sc, goals)
                runs = [d.task for d in client.executed]
                assert len(runs) == len(set(runs)), (sc, runs)
                assert all(
                    d.task.startswith(
                        ("Set", "Down", "Bat", "Acq", sc.upper())
                    )
                    for d in client.executed
                )
                status = client.query_status()
                expected = "sat2-B" if sc == "sat2" else f"{sc}-A"
                assert (status.node_id, status.state) == (expected, "ok"), (
                    status
                )
            assert ground["sat1"].query_status().term == 1
            assert ground["sat3"].query_status().term == 1
            for client in ground.values():
                client.close()
            relay.close()
    finally:
        for process in nodes.values():
            process.kill()
        for router in routers.values():
            router.kill()
            router.wait(10)
            if router.stdout is not None:
                router.stdout.close()
    for path in sorted(tmp_path.glob("*/*")):
        for journal in journal_files(path):
            report = verify(journal)
            assert report.identical, f"{journal}: {report.summary()}"


def _tick_resending(
    client: SchedulerClient, now: int, deadline: float, every_s: float = 2.0
) -> None:
    """Publish ``now`` again every ``every_s`` until the node has it, as a
    bus clock does: a put sent while routers still exchange a new link's
    declarations can be lost while a query after it gets through (the
    same time twice is no clock going back)."""
    while True:
        client.clock(now)
        left = deadline - time.monotonic()
        try:
            client.settle(now, max(0.1, min(every_s, left)))
            return
        except TimeoutError:
            if time.monotonic() + 0.1 >= deadline:
                raise


@pytest.mark.slow
def test_both_sides_of_a_router_split_keep_their_goals(tmp_path: Path) -> None:
    """Tests a split between two routers, each side with a scheduler and a
    sender: both command (B takes over in a higher term) and both accept a
    goal. At the heal A stands down and hands the goal the winner lacks
    over (nothing of it was commanded: its window is still to come), with
    no second verdict: its sender heard ``goal_accepted`` and sends it no
    more. Both goals end in the surviving plan; sent again anyway, it is
    ``goal_accepted`` again."""
    partition = soak_partition()
    free = soak_resume().free_port
    p1, p2 = free(), free()
    r1 = _router(p1, [])
    link = partition.SilentLink(p1)
    r2 = _router(p2, [f"tcp/127.0.0.1:{link.port}"])
    nodes = {
        "A": partition.node(tmp_path / "A", p1, "A", 0),
        "B": partition.node(tmp_path / "B", p2, "B", 1),
    }
    sessions = []
    try:
        clients = {}
        for side, port in (("A", p1), ("B", p2)):
            config = loopback_config(
                listen=None, connect=[f"tcp/127.0.0.1:{port}"]
            )
            config.insert_json5("mode", '"client"')
            sessions.append(zenoh.open(config))
            clients[side] = SchedulerClient(sessions[-1], timeout=60.0)
        assert nodes["A"].start() == "scheduler up on"
        assert nodes["B"].start() == "standing by"
        clients["A"].wait_scheduler(60)
        clients["A"].tick(0)
        link.silence()
        clients["B"].wait_status(
            lambda s: s.event == "took_over" and s.node_id == "B", 60
        )
        west = ping_goal("west", "West")
        west["tasks"][0]["feasible_interval"] = [20, 40]
        assert clients["A"].send_goals([west]) == {"west": {"goal_accepted"}}
        assert clients["B"].send_goals([ping_goal("east", "East")]) == {
            "east": {"goal_accepted"}
        }
        link.heal()
        merged = clients["B"].wait_status(
            lambda s: s.event == "facts_merged" and "west" in s.detail, 60
        )
        assert merged.node_id == "B", merged
        # The replan that follows the merge (trigger "merged") holds both.
        merged_plan = clients["B"].wait_plan(lambda p: p.trigger == "merged")
        assert {"West", "East"} <= {a.task for a in merged_plan.activities}
        assert not [
            s
            for c in clients.values()
            for s in c.statuses
            if s.event == "goal_rejected"
        ]
        clients["A"].statuses.clear()  # a sender sending it again anyway
        again = clients["A"].send_goals([west])
        assert again == {"west": {"goal_accepted"}}
        # A clock message first: on a loaded machine the test outlasts the
        # clock stall limit (30 s without one: degraded until the next).
        clients["B"].tick(1)
        status = clients["B"].query_status()
        assert (status.node_id, status.state) == ("B", "ok"), status
        for client in clients.values():
            client.close()
    finally:
        for session in sessions:
            session.close()
        for process in nodes.values():
            process.kill()
        link.close()
        for router in (r1, r2):
            router.kill()
            router.wait(10)
            if router.stdout is not None:
                router.stdout.close()
