"""Test helpers: the scheduler on an isolated in-process Zenoh bus.

:class:`SchedulerHarness` opens two loopback peers (scouting off,
ephemeral port, see :func:`fsw_scheduler.bus.session.open_peer_pair`),
runs a :class:`~fsw_scheduler.bus.node.SchedulerNode` with the bus clock
on the first and gives the test the second as a *client*: the place where
a test, or a component under test, publishes clock ticks, goals and
telemetry and receives plans, dispatches and status messages.

:class:`SchedulerClient` is that client side on its own, for a scheduler
running elsewhere (another process, ``fsw-scheduler run``).

Every wait is on received samples or query answers, with a deadline; the
harness never sleeps for a fixed time. :meth:`SchedulerHarness.tick`
moves the bus clock in lockstep: it returns once the scheduler has
processed the tick, no solve is running and every plan and dispatch the
scheduler says it published has reached the client.

The module does not import pytest. Used as a pytest plugin
(``pytest_plugins = ["fsw_scheduler.testing"]``) it provides the fixtures
``scheduler_problem`` (the paper's Table 1), ``scheduler_config`` and
``scheduler_harness``; override the first two in a ``conftest.py`` to run
the harness on your own problem or settings. The marker
PYTEST_DONT_REWRITE keeps pytest from warning when a test module imports
this module before naming it in ``pytest_plugins``: it holds no assertions
for pytest to rewrite.

Examples
--------
>>> with SchedulerHarness() as h:                         # doctest: +SKIP
...     h.tick(0)
...     h.wait_plan(lambda p: p.plan_id == 1)
...     h.wait_dispatch("SetPositionX")
"""

from __future__ import annotations

import contextlib
import json
import threading
import time
from collections.abc import Mapping
from importlib import resources
from typing import TYPE_CHECKING, Any

import msgspec

from .bus.node import SchedulerNode
from .bus.session import (
    DEFAULT_TIMEOUT_S,
    listening_endpoints,
    open_peer_pair,
    wait_matching,
)
from .model.problem import Problem, decode_problem
from .runtime.config import NodeConfig
from .runtime.policy import run_solve
from .wire import topics as keys

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator
    from pathlib import Path

    #: What the harness takes as its problem.
    ProblemLike = Problem | Mapping[str, Any] | bytes | str | Path

    import zenoh

    from .engine.events import StartSolve
    from .model.plan import Plan
from .bus.client import WAIT_S, Fence, SchedulerClient

__all__ = [
    "Fence",
    "SchedulerClient",
    "SchedulerHarness",
    "harness_config",
    "paper_goal",
    "paper_problem",
    "pytest_configure",
]


def paper_problem() -> Problem:
    """The paper's Table 1 problem, as shipped with the package."""
    return decode_problem(_data("paper_table1.json"))


def paper_goal() -> dict[str, Any]:
    """The paper's Table 2 goal (``monitor-target-lf``) as a dict."""
    return json.loads(_data("paper_table2_goal.json"))


def harness_config(**changes: Any) -> NodeConfig:
    """Node settings suited to tests, with ``changes`` applied.

    The clock is the bus clock (the test drives time, so no stall
    detection), there is no heartbeat, ``explain`` is off (no extra
    solves), each solve may take up to 30 s and the explanation a
    shedding solve still gives up to 60 s, so that a slow machine changes
    timings, not plans.

    Parameters
    ----------
    **changes
        Any :class:`~fsw_scheduler.runtime.config.NodeConfig` field.
    """
    base = NodeConfig(
        clock="bus",
        heartbeat=0,
        explain=False,
        time_limit=30.0,
        explain_budget=60.0,
        clock_stall=None,
    )
    return msgspec.structs.replace(base, **changes)


def _data(name: str) -> bytes:
    return resources.files("fsw_scheduler").joinpath("data", name).read_bytes()


class SchedulerHarness(SchedulerClient):
    """A scheduler node and a client peer on an isolated loopback bus.

    The client side is a :class:`SchedulerClient` (all its helpers work
    here); the harness owns both sessions and the node.

    Parameters
    ----------
    problem
        The node's problem: a :class:`~fsw_scheduler.model.problem.Problem`,
        its
        JSON (bytes or str), a path to a JSON file, or None for the paper's
        Table 1.
    config
        Node settings; default :func:`harness_config`. The clock is forced
        to ``bus``.
    solve_fn
        Replaces the solver (``solve_fn(config, StartSolve) -> Plan``),
        e.g. to make solves slow or failing.
    timeout
        Default deadline of every wait, in seconds.
    node_options
        More :class:`~fsw_scheduler.bus.node.SchedulerNode` arguments
        (``journal``, ``durable``, ...).
    """

    def __init__(
        self,
        problem: Problem
        | Mapping[str, Any]
        | bytes
        | str
        | Path
        | None = None,
        config: NodeConfig | None = None,
        *,
        solve_fn: Callable[[NodeConfig, StartSolve], Plan] | None = None,
        timeout: float = WAIT_S,
        node_options: dict[str, Any] | None = None,
    ) -> None:
        # SchedulerClient.__init__ runs in open(), once the session exists.
        self._node_options = dict(node_options or {})
        self.problem = _load_problem(problem)
        self.config = (config or harness_config()).replace(clock="bus")
        self.timeout = timeout
        self._solve_fn = solve_fn or run_solve
        self._stack: contextlib.ExitStack | None = None
        self._node: SchedulerNode | None = None
        self._server: zenoh.Session | None = None
        self._node_closed = False

    def open(self) -> SchedulerHarness:
        """Open the peers, start the node and wait until all is wired.

        Returns once the client's subscriber is known to the node's
        session and the node's subscribers and queryables are known to the
        client, so nothing published from then on is lost.
        """
        stack = contextlib.ExitStack()
        try:
            server, client = stack.enter_context(
                open_peer_pair(DEFAULT_TIMEOUT_S)
            )
            self._server = server
            SchedulerClient.__init__(
                self, client, self.config.spacecraft, timeout=self.timeout
            )
            stack.callback(SchedulerClient.close, self)
            for key in (
                self.topics.key(keys.PLAN),
                self.topics.key(keys.STATUS),
                self.topics.dispatch("probe"),
            ):
                wait_matching(server, key, self.timeout)
            node = SchedulerNode(
                server,
                self.problem,
                self.config,
                solve_fn=self._solve_fn,
                **self._node_options,
            )
            node.start()
            self._node = node
            stack.callback(self.close_node)
            self.wait_scheduler()
        except BaseException:
            stack.close()
            raise
        self._stack = stack
        return self

    def close(self) -> None:
        """Stop the node and close both sessions (idempotent)."""
        stack, self._stack = self._stack, None
        if stack is not None:
            stack.close()

    def close_node(self) -> None:
        """Stop the node only; the sessions stay open (idempotent).

        Useful to watch, from the client, what happens when the scheduler
        goes away (its liveliness token disappears).
        """
        if self._node is not None and not self._node_closed:
            self._node_closed = True
            self._node.close()

    def __enter__(self) -> SchedulerHarness:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def node(self) -> SchedulerNode:
        """The scheduler node under test."""
        if self._node is None:
            raise RuntimeError("the harness is not open")
        return self._node

    @property
    def server(self) -> zenoh.Session:
        """The node's session (it listens on the loopback endpoint)."""
        if self._server is None:
            raise RuntimeError("the harness is not open")
        return self._server

    def endpoints(self) -> list[str]:
        """Locators other processes can connect to, e.g. ``tcp/...``."""
        return listening_endpoints(self.server)


def _load_problem(problem: ProblemLike | None) -> Problem:
    if problem is None:
        return paper_problem()
    if isinstance(problem, Problem):
        return problem
    if isinstance(problem, Mapping):  # a dict, as the API takes them
        import json

        return decode_problem(json.dumps(problem), allow_empty=True)
    if isinstance(problem, bytes | str) and str(problem).lstrip()[:1] in (
        "{",
        "[",
    ):
        return decode_problem(problem, allow_empty=True)
    from pathlib import Path

    return decode_problem(
        Path(problem).read_bytes(),  # type: ignore[arg-type]
        allow_empty=True,
    )


def pytest_configure(config: Any) -> None:
    """Register the fixtures (pytest hook; pytest is imported only here).

    Parameters
    ----------
    config
        The pytest configuration.
    """
    name = "fsw_scheduler.testing.fixtures"
    if not config.pluginmanager.has_plugin(name):
        config.pluginmanager.register(_fixtures(), name)


def _fixtures() -> object:
    """Build the fixture holder; pytest collects fixtures from it."""
    import pytest

    class Fixtures:
        @pytest.fixture
        def scheduler_problem(self) -> Problem:
            """The problem of ``scheduler_harness``: the paper's Table 1
            (override it to return a Problem, a dict, JSON or a path)."""
            return paper_problem()

        @pytest.fixture
        def scheduler_config(self) -> NodeConfig:
            """The settings of ``scheduler_harness``: harness_config()."""
            return harness_config()

        @pytest.fixture
        def scheduler_harness(
            self, scheduler_problem: Any, scheduler_config: NodeConfig
        ) -> Iterator[SchedulerHarness]:
            """An open :class:`SchedulerHarness`, closed after the test."""
            with SchedulerHarness(
                scheduler_problem, scheduler_config
            ) as harness:
                yield harness

    return Fixtures()


class SchedulerProcess:
    """``fsw-scheduler run`` in a separate OS process, its log read live.

    For tests that kill the scheduler (SIGKILL), run several of them, or
    talk to it only through the bus, as a deployment does.

    Parameters
    ----------
    args
        Arguments after ``fsw-scheduler run``.
    ready
        Log fragments that mean the node has made up its mind: it
        commands (``scheduler up on``) or stands by (``standing by``).
    """

    def __init__(
        self,
        args: list[str],
        ready: tuple[str, ...] = ("scheduler up on", "standing by"),
    ) -> None:
        self.args = list(args)
        self.ready = ready
        self.process: Any = None
        self.log: list[str] = []
        self.starts = 0
        self._reader: threading.Thread | None = None
        self._cond = threading.Condition()

    def start(self, timeout: float = 60.0) -> str:
        """Start it; returns the first ``ready`` fragment it logged."""
        import subprocess
        import sys
        from pathlib import Path

        script = Path(sys.executable).with_name("fsw-scheduler")
        command = (
            [str(script)]
            if script.exists()
            else [sys.executable, "-m", "fsw_scheduler.cli"]
        )
        self.process = subprocess.Popen(
            [*command, "run", *self.args],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.starts += 1
        mark = len(self.log)
        process = self.process

        def read() -> None:
            assert process.stderr is not None
            for line in process.stderr:
                with self._cond:
                    self.log.append(line)
                    self._cond.notify_all()
            with self._cond:
                self._cond.notify_all()

        self._reader = threading.Thread(target=read, daemon=True)
        self._reader.start()
        return self.wait_log(self.ready, timeout, since=mark)

    def wait_log(
        self, words: tuple[str, ...], timeout: float = 60.0, since: int = 0
    ) -> str:
        """Wait until a log line holds one of ``words``; returns it.

        Raises
        ------
        RuntimeError
            If the process ends or the time runs out first.
        """
        deadline = time.monotonic() + timeout
        found: list[str] = []

        def seen() -> bool:
            for line in self.log[since:]:
                for word in words:
                    if word in line:
                        found.append(word)
                        return True
            return self.process.poll() is not None

        with self._cond:
            while not seen():
                left = deadline - time.monotonic()
                if left <= 0:
                    break
                self._cond.wait(min(left, 0.2))
        if not found:
            raise RuntimeError(
                f"no {words} in the scheduler's log:\n" + "".join(self.log)
            )
        return found[0]

    def kill(self) -> None:
        """SIGKILL, as a watchdog or a power cut would."""
        if self.process is not None and self.process.poll() is None:
            self.process.kill()
            self.process.wait(10)
        self._release()

    def stop(self) -> int:
        """SIGTERM and wait; returns the exit code."""
        assert self.process is not None
        self.process.terminate()
        code = int(self.process.wait(30))
        self._release()
        return code

    def _release(self) -> None:
        if self.process is None or self._reader is None:
            return
        self._reader.join(10)
        if self.process.stderr is not None:
            self.process.stderr.close()
