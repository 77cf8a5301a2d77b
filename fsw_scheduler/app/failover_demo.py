"""The paper scenario on two redundant schedulers that keep being killed.

``fsw-scheduler demo --scenario failover`` shows what a spacecraft with
two computers sees. A Zenoh router stands for the spacecraft's network;
schedulers ``obc-a`` (rank 0) and ``obc-b`` (rank 1) run as separate OS
processes connected to it, each with its own state folder; the demo's own
session plays the clock, the executor and the goal source as in the
paper demo (:mod:`fsw_scheduler.demo`). Then:

* at t=5 the commanding ``obc-a`` is killed (SIGKILL): ``obc-b`` takes
  over from the state ``obc-a`` shared, and ``obc-a`` comes back as its
  standby;
* at t=20, after the Table 2 goal, ``obc-b`` is killed: ``obc-a`` takes
  over;
* at t=35 both are killed; ``obc-a`` restarts alone, resumes from its own
  journal, and ``obc-b`` comes back as the standby.

The timeline shows plans, dispatches, reports and the ``took_over`` /
``resumed`` / ``standby`` statuses. At the end every journal file of both
state folders is replayed with ``replay --verify``.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, TextIO

import zenoh

from ..bus.session import listening_endpoints, loopback_config, wait_matching
from ..model.problem import decode_problem
from ..testing import SchedulerProcess
from ..wire import topics as keys
from .demo import Executor, Printer, World, paper_scenario, scenario_file

if TYPE_CHECKING:
    from pathlib import Path

    from ..wire import messages

#: Scenario times of the faults (see the module docstring).
KILL_ACTIVE_1, KILL_ACTIVE_2, KILL_BOTH = 5, 20, 35
NODES = ("obc-a", "obc-b")


@dataclass
class FailoverResult:
    """What the failover demo produced."""

    journals: list[Path] = field(default_factory=list)
    identical: list[bool] = field(default_factory=list)
    plans: list[messages.PlanMessage] = field(default_factory=list)
    takeovers: list[float] = field(default_factory=list)

    @property
    def verified(self) -> bool:
        """Every journal replayed identically."""
        return bool(self.identical) and all(self.identical)


def _node(out_dir: Path, name: str, rank: int, port: int) -> SchedulerProcess:
    return SchedulerProcess(
        [
            "--problem",
            str(out_dir / "problem.json"),
            "--clock",
            "bus",
            "--state",
            str(out_dir / name),
            "--node-id",
            name,
            "--rank",
            str(rank),
            "--discovery",
            "0.3",
            "-m",
            "client",
            "--connect",
            f"tcp/127.0.0.1:{port}",
            "--no-multicast-scouting",
            "--insecure",
        ],
        ready=("scheduler up on", "standing by", "commanding", "resumed"),
    )


def run_failover_demo(
    out_dir: Path,
    *,
    stream: TextIO = sys.stdout,
    time_unit: float = 0.0,
    quiet: bool = False,
) -> FailoverResult:
    """Run the failover scenario; see the module docstring.

    Parameters
    ----------
    out_dir
        Holds the state folders ``obc-a/`` and ``obc-b/``.
    stream
        Where the live timeline goes.
    time_unit
        Shortest wall time of one time unit, in seconds.
    quiet
        No live timeline.
    """
    import shutil

    from ..journal.replay import verify
    from ..journal.state import journal_files

    scenario = paper_scenario()
    out_dir.mkdir(parents=True, exist_ok=True)
    for name in NODES:
        shutil.rmtree(out_dir / name, ignore_errors=True)
    (out_dir / "problem.json").write_bytes(scenario_file("paper_table1.json"))
    problem = decode_problem(scenario_file("paper_table1.json"))
    topics = keys.Topics()
    printer = Printer(stream, quiet)
    executor = Executor(problem, scenario)
    result = FailoverResult()
    router_config = loopback_config(listen="tcp/127.0.0.1:0")
    router_config.insert_json5("mode", '"router"')
    router = zenoh.open(router_config)
    nodes: dict[str, SchedulerProcess] = {}
    try:
        (endpoint,) = listening_endpoints(router)
        port = int(endpoint.rsplit(":", 1)[1])
        driver = loopback_config(listen=None, connect=[endpoint])
        driver.insert_json5("mode", '"client"')
        with zenoh.open(driver) as session:
            world = World(session, topics, executor, printer)
            try:
                for rank, name in enumerate(NODES):
                    nodes[name] = _node(out_dir, name, rank, port)
                    said = nodes[name].start()
                    printer.line(f"node      {name} started: {said}")
                wait_matching(session, topics.key(keys.CLOCK), 60)
                wait_matching(session, topics.key(keys.GOALS), 60)
                active = NODES[0]
                for now in range(scenario.until + 1):
                    began = time.monotonic()
                    printer.now = now
                    if now in (KILL_ACTIVE_1, KILL_ACTIVE_2):
                        active = _fail_over(
                            world, nodes, active, printer, result
                        )
                    elif now == KILL_BOTH:
                        _kill_both(world, nodes, printer)
                        active = NODES[0]
                    world.advance(now, scenario)
                    time.sleep(max(time_unit - (time.monotonic() - began), 0))
                result.plans = list(world.plans)
            finally:
                world.close()
        for node in nodes.values():
            node.stop()
    finally:
        for node in nodes.values():
            node.kill()
        router.close()
    print(file=stream)
    for name in NODES:
        for path in journal_files(out_dir / name):
            report = verify(path)
            result.journals.append(path)
            result.identical.append(report.identical)
            print(
                f"replay --verify {name}/{path.name}: "
                + report.summary().splitlines()[0],
                file=stream,
                flush=True,
            )
    return result


def _fail_over(
    world: World,
    nodes: dict[str, SchedulerProcess],
    active: str,
    printer: Printer,
    result: FailoverResult,
) -> str:
    """Kill the commander; wait for the standby; restart the killed one."""
    other = NODES[1] if active == NODES[0] else NODES[0]
    printer.line(f"FAULT     SIGKILL {active} (it commands)")
    began = time.monotonic()
    nodes[active].kill()
    _wait_commanding(world, other)
    result.takeovers.append(time.monotonic() - began)
    printer.line(
        f"node      {other} commands after "
        f"{result.takeovers[-1] * 1000:.0f} ms"
    )
    said = nodes[active].start()
    printer.line(f"node      {active} restarted: {said}")
    return other


def _kill_both(
    world: World, nodes: dict[str, SchedulerProcess], printer: Printer
) -> None:
    """Both computers reset; the first comes back from its own journal."""
    printer.line(f"FAULT     SIGKILL {NODES[0]} and {NODES[1]}")
    for node in nodes.values():
        node.kill()
    said = nodes[NODES[0]].start()
    printer.line(f"node      {NODES[0]} restarted: {said}")
    _wait_commanding(world, NODES[0])
    said = nodes[NODES[1]].start()
    printer.line(f"node      {NODES[1]} restarted: {said}")


def _wait_commanding(world: World, name: str, timeout: float = 60.0) -> None:
    """Until ``name`` answers the status query as the commanding node."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        status = world.status()
        world.drain(world.printer.now)
        if status is not None and status.node_id == name:
            return
        time.sleep(0.01)
    raise TimeoutError(f"{name} did not take command")
