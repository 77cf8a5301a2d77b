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
import logging
import threading
import time
from importlib import resources
from typing import TYPE_CHECKING, Any, TypeVar

import msgspec
import zenoh

from .bus.node import SchedulerNode
from .bus.session import (
    DEFAULT_TIMEOUT_S,
    listening_endpoints,
    open_peer_pair,
    wait_matching,
    wait_until,
)
from .model.problem import Problem, decode_problem
from .runtime.config import NodeConfig
from .runtime.policy import run_solve
from .wire import messages
from .wire import topics as keys

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator
    from pathlib import Path

    from .engine.events import StartSolve
    from .model.plan import Plan

__all__ = [
    "SchedulerClient",
    "SchedulerHarness",
    "harness_config",
    "paper_goal",
    "paper_problem",
    "pytest_configure",
]

log = logging.getLogger("fsw_scheduler.testing")

JSON = zenoh.Encoding.APPLICATION_JSON

T = TypeVar("T")

#: Default deadline of the harness's waits, in seconds. Generous: a busy
#: CI machine may take a few seconds for a solve.
WAIT_S = 10.0


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
    solves) and each solve may
    take up to 30 s so that a slow machine changes timings, not plans.

    Parameters
    ----------
    **changes
        Any :class:`~fsw_scheduler.config.NodeConfig` field.
    """
    base = NodeConfig(
        clock="bus",
        heartbeat=0,
        explain=False,
        time_limit=30.0,
        clock_stall=None,
    )
    return msgspec.structs.replace(base, **changes)


def _data(name: str) -> bytes:
    return resources.files("fsw_scheduler").joinpath("data", name).read_bytes()


def _payload(message: object) -> bytes:
    """JSON bytes of a dict, a Struct, a str or bytes (passed through)."""
    if isinstance(message, bytes):
        return message
    if isinstance(message, str):
        return message.encode()
    if isinstance(message, msgspec.Struct):
        return messages.encode(message)
    return json.dumps(message).encode()


class SchedulerClient:
    """The rest of the spacecraft, as the scheduler sees it, on a session.

    Publishes clock ticks, goals and telemetry; records every plan,
    dispatch, status and solve record the scheduler publishes; asks its
    queryables. Works with any scheduler reachable from ``session``: the
    in-process one of :class:`SchedulerHarness` or a separate process.
    Create it before the scheduler publishes anything: :meth:`settle`
    waits until every plan and dispatch the scheduler has counted since
    its start has been received.

    Parameters
    ----------
    session
        An open Zenoh session (the caller owns it).
    spacecraft
        The spacecraft id of the scheduler's keys.
    timeout
        Default deadline of every wait, in seconds.

    Attributes
    ----------
    plans, dispatches, statuses, solves
        Every message received on ``scheduler/plan``,
        ``scheduler/dispatch/*``, ``scheduler/status`` and
        ``scheduler/solves``, in arrival order (the lists only grow).
    samples
        Every ``(key, payload)`` received under ``fsw/<sc>/scheduler/**``.
    decode_errors
        Samples that could not be decoded, as ``(key, error)``.
    """

    def __init__(
        self,
        session: zenoh.Session,
        spacecraft: str = keys.DEFAULT_SPACECRAFT,
        *,
        timeout: float = WAIT_S,
    ) -> None:
        self.client = session
        self.topics = keys.Topics(spacecraft)
        self.timeout = timeout
        self._cond = threading.Condition()
        self.plans: list[messages.PlanMessage] = []
        self.dispatches: list[messages.Dispatch] = []
        self.statuses: list[messages.Status] = []
        self.solves: list[messages.SolveRecord] = []
        self.samples: list[tuple[str, bytes]] = []
        self.decode_errors: list[tuple[str, str]] = []
        self._subscriber: Any = session.declare_subscriber(
            self.topics.key("scheduler/**"), self._on_sample
        )

    def close(self) -> None:
        """Stop listening (idempotent); the session stays open."""
        subscriber, self._subscriber = self._subscriber, None
        if subscriber is not None:
            _undeclare(subscriber)

    def __enter__(self) -> SchedulerClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def wait_scheduler(self, timeout: float | None = None) -> None:
        """Wait until a scheduler's inputs and queryables are reachable.

        Raises
        ------
        TimeoutError
            If no scheduler shows up in time.
        """
        timeout = timeout or self.timeout
        for key in (
            self.topics.key(keys.CLOCK),
            self.topics.key(keys.GOALS),
            self.topics.activity_report("probe"),
            self.topics.resource_level("probe"),
        ):
            wait_matching(self.client, key, timeout)
        for suffix in (keys.STATUS, keys.PLAN):
            self._wait_queryable(self.topics.key(suffix), timeout)

    # -- publishing ----------------------------------------------------------

    def put(self, key: str, message: object) -> None:
        """Publish ``message`` as JSON on ``key``.

        Parameters
        ----------
        key
            A full key (``fsw/sat1/clock``) or a suffix (``clock``).
        message
            A dict, a msgspec Struct, or raw bytes / str sent as given.
        """
        if self.topics.suffix(key) is None:
            key = self.topics.key(key)
        # Blocking congestion control: a test's inputs must never be
        # dropped by Zenoh's transmit queue, only by the node itself.
        self.client.put(
            key,
            _payload(message),
            encoding=JSON,
            congestion_control=zenoh.CongestionControl.BLOCK,
        )

    def clock(self, now: int) -> None:
        """Publish ``{"now": now}`` on the clock key, without waiting."""
        self.put(keys.CLOCK, {"now": now})

    def tick(self, now: int, timeout: float | None = None) -> messages.Status:
        """Move the bus clock to ``now`` and wait until the node is idle.

        A clock going back is rejected by the scheduler, so ``tick`` would
        time out; send such a tick with :meth:`clock` and call
        :meth:`settle` without ``now``.

        Returns
        -------
        Status
            The node's status once it has processed the tick, no solve is
            running, and every plan and dispatch it reports has arrived.
        """
        self.clock(now)
        return self.settle(now, timeout)

    def publish_goal(self, goal: dict | bytes | str | msgspec.Struct) -> None:
        """Publish a goal document on ``scheduler/goals``."""
        self.put(keys.GOALS, goal)

    def report(
        self, task: str, state: str, at: int, *, key_task: str | None = None
    ) -> None:
        """Publish an execution report of ``task``.

        ``key_task`` publishes it on another task's key (a faulty
        executor).
        """
        self.put(
            self.topics.activity_report(key_task or task),
            {"task": task, "state": state, "at": at},
        )

    def level(
        self,
        resource: str,
        level: float,
        at: int,
        *,
        key_resource: str | None = None,
    ) -> None:
        """Publish a measured level of ``resource``."""
        self.put(
            self.topics.resource_level(key_resource or resource),
            {"resource": resource, "level": level, "at": at},
        )

    # -- queries -------------------------------------------------------------

    def query_status(self, timeout: float | None = None) -> messages.Status:
        """Ask the node for its status.

        Raises
        ------
        TimeoutError
            If the node does not answer.
        """
        payload = self._query(keys.STATUS, timeout)
        if payload is None:
            raise TimeoutError("the scheduler did not answer a status query")
        return msgspec.json.decode(payload, type=messages.Status)

    def query_plan(
        self, timeout: float | None = None
    ) -> messages.PlanMessage | None:
        """Ask the node for its plan (None before the first plan)."""
        payload = self._query(keys.PLAN, timeout)
        if payload is None:
            return None
        return msgspec.json.decode(payload, type=messages.PlanMessage)

    def _query(self, suffix: str, timeout: float | None) -> bytes | None:
        replies = self.client.get(
            self.topics.key(suffix), timeout=timeout or self.timeout
        )
        found = None
        for reply in replies:
            if reply.ok is not None and found is None:
                found = reply.ok.payload.to_bytes()
        return found

    # -- waiting -------------------------------------------------------------

    def settle(
        self, now: int | None = None, timeout: float | None = None
    ) -> messages.Status:
        """Wait until the node has caught up and is not solving.

        The status query travels on the same link as the client's earlier
        puts and lands in the node's inbox behind them, so its answer
        reflects every input sent before. If a solve is running, the
        harness waits for the node's next output and asks again.

        Parameters
        ----------
        now
            Also wait until the node's time is ``now``.
        timeout
            Deadline in seconds.

        Returns
        -------
        Status
            The settled status.
        """
        deadline = time.monotonic() + (timeout or self.timeout)
        while True:
            seen = len(self.samples)
            status = self.query_status(max(deadline - time.monotonic(), 0.1))
            if not status.busy and (now is None or status.now == now):
                break
            if time.monotonic() >= deadline:
                raise TimeoutError(
                    f"scheduler did not settle at now={now}: {status}"
                )
            # A solve finishing always publishes something: wake on it,
            # and re-ask at least every 50 ms anyway.
            with self._cond:
                self._cond.wait_for(
                    lambda seen=seen: len(self.samples) > seen,  # type: ignore[misc]
                    min(0.05, max(deadline - time.monotonic(), 0.0)),
                )
        self._await_outputs(status, deadline)
        return status

    def _await_outputs(self, status: messages.Status, deadline: float) -> None:
        """Wait until the client has every plan and dispatch counted."""

        def caught_up() -> bool:
            plans_ok = status.plan_id is None or any(
                p.plan_id >= status.plan_id for p in self.plans
            )
            return plans_ok and (
                len(self.dispatches) >= status.counters.dispatches
            )

        with self._cond:
            if not self._cond.wait_for(
                caught_up, max(deadline - time.monotonic(), 0.0)
            ):
                raise TimeoutError(
                    f"outputs missing: status says plan {status.plan_id} "
                    f"and {status.counters.dispatches} dispatches, client "
                    f"has {[p.plan_id for p in self.plans]} and "
                    f"{len(self.dispatches)}"
                )

    def wait_plan(
        self,
        predicate: Callable[[messages.PlanMessage], bool] | None = None,
        timeout: float | None = None,
        *,
        since: int = 0,
    ) -> messages.PlanMessage:
        """The newest received plan satisfying ``predicate``.

        Parameters
        ----------
        predicate
            Condition on the plan; None accepts any plan.
        timeout
            Deadline in seconds.
        since
            Ignore plans received before ``self.plans[since]``.
        """
        return self._wait_for(
            self.plans, predicate or (lambda _: True), timeout, since, "plan"
        )

    def wait_dispatch(
        self,
        task: str,
        timeout: float | None = None,
        *,
        plan_id: int | None = None,
        since: int = 0,
    ) -> messages.Dispatch:
        """The newest received dispatch of ``task`` (of ``plan_id``)."""
        return self._wait_for(
            self.dispatches,
            lambda d: (
                d.task == task and (plan_id is None or d.plan_id == plan_id)
            ),
            timeout,
            since,
            f"dispatch of {task}",
        )

    def wait_status(
        self,
        predicate: Callable[[messages.Status], bool],
        timeout: float | None = None,
        *,
        since: int = 0,
    ) -> messages.Status:
        """The newest received status message satisfying ``predicate``."""
        return self._wait_for(
            self.statuses, predicate, timeout, since, "status"
        )

    def _wait_for(
        self,
        items: list[T],
        predicate: Callable[[T], bool],
        timeout: float | None,
        since: int,
        what: str,
    ) -> T:
        found: list[T] = []

        def ready() -> bool:
            found[:] = [m for m in items[since:] if predicate(m)][-1:]
            return bool(found)

        with self._cond:
            if self._cond.wait_for(ready, timeout or self.timeout):
                return found[0]
        raise TimeoutError(
            f"no matching {what} within {timeout or self.timeout} s "
            f"(received {len(items) - since})"
        )

    def _wait_queryable(self, key: str, timeout: float) -> None:
        querier = self.client.declare_querier(key)
        try:
            wait_until(
                lambda: _matching(querier.matching_status),
                timeout,
                what=f"a queryable on {key}",
            )
        finally:
            querier.undeclare()

    # -- the client's subscriber (runs on a Zenoh thread) --------------------

    def _on_sample(self, sample: zenoh.Sample) -> None:
        # Zenoh only logs an exception raised here; keep it visible to the
        # test through decode_errors instead.
        key = str(sample.key_expr)
        try:
            payload = sample.payload.to_bytes()
            kind = self.topics.schema_kind(key)
            decoded: Any = None
            target: list[Any] | None = None
            if kind in _KINDS:
                target = getattr(self, _KINDS[kind][0])
                decoded = msgspec.json.decode(payload, type=_KINDS[kind][1])
        except Exception as error:
            log.exception("cannot decode a sample on %s", key)
            with self._cond:
                self.decode_errors.append((key, repr(error)))
                self._cond.notify_all()
            return
        with self._cond:
            if target is not None:
                target.append(decoded)
            self.samples.append((key, payload))
            self._cond.notify_all()


class SchedulerHarness(SchedulerClient):
    """A scheduler node and a client peer on an isolated loopback bus.

    The client side is a :class:`SchedulerClient` (all its helpers work
    here); the harness owns both sessions and the node.

    Parameters
    ----------
    problem
        The node's problem: a :class:`~fsw_scheduler.model.Problem`, its
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
    """

    def __init__(
        self,
        problem: Problem | bytes | str | Path | None = None,
        config: NodeConfig | None = None,
        *,
        solve_fn: Callable[[NodeConfig, StartSolve], Plan] | None = None,
        timeout: float = WAIT_S,
    ) -> None:
        # SchedulerClient.__init__ runs in open(), once the session exists.
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
                server, self.problem, self.config, solve_fn=self._solve_fn
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


_KINDS: dict[str, tuple[str, type]] = {
    "plan": ("plans", messages.PlanMessage),
    "dispatch": ("dispatches", messages.Dispatch),
    "status": ("statuses", messages.Status),
    "solve_record": ("solves", messages.SolveRecord),
}


def _matching(status: object) -> bool:
    # Zenoh releases differ: a bool, or an object with ``.matching``.
    return bool(getattr(status, "matching", status))


def _undeclare(entity: Any) -> None:
    try:
        entity.undeclare()
    except zenoh.ZError as error:  # the session is already closed
        log.debug("undeclare: %s", error)


def _load_problem(problem: Problem | bytes | str | Path | None) -> Problem:
    if problem is None:
        return paper_problem()
    if isinstance(problem, Problem):
        return problem
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


# -- pytest plugin -----------------------------------------------------------


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
            """The problem of ``scheduler_harness``: the paper's Table 1."""
            return paper_problem()

        @pytest.fixture
        def scheduler_config(self) -> NodeConfig:
            """The settings of ``scheduler_harness``: harness_config()."""
            return harness_config()

        @pytest.fixture
        def scheduler_harness(
            self, scheduler_problem: Problem, scheduler_config: NodeConfig
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
