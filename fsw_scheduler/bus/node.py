"""The scheduler as a Zenoh component: a thin shell around the engine.

One thread (the event loop) owns the :class:`~fsw_scheduler.engine.Engine`.
Zenoh callbacks only put raw samples and queries into a bounded inbox
(dropping, and counting, what does not fit) and never call Zenoh or the
engine. Solves run on a worker thread so that dispatches keep their timing;
their results come back through the same inbox. Every input the loop
processes and every output it publishes can be written, in processing
order, to an MCAP *journal*: that linear record is what makes
:mod:`fsw_scheduler.replay` exact.
"""

from __future__ import annotations

import concurrent.futures
import logging
import queue
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import zenoh

from .. import messages
from ..clock import UnitClock
from ..engine import (
    Command,
    Engine,
    EngineConfig,
    Event,
    Log,
    Publish,
    SolveDone,
    SolveFailed,
    StartSolve,
    Tick,
)
from ..foxglove import Annotator, engine_problem, session_records
from ..inputs import InputDecoder
from . import topics

if TYPE_CHECKING:
    import msgspec

    from ..config import NodeConfig
    from ..model import Problem
    from ..recording import Recorder
    from ..solution import Plan

log = logging.getLogger("fsw_scheduler.node")

JSON = zenoh.Encoding.APPLICATION_JSON

SolveFn = Callable[..., "Plan"]


def engine_config(config: NodeConfig) -> EngineConfig:
    """The engine settings carried by a node configuration."""
    return EngineConfig(
        report_timeout=config.report_timeout,
        tolerance=config.tolerance,
        heartbeat=config.heartbeat,
        replan_lead=config.lead,
    )


def node_info(config: NodeConfig, problem: Problem) -> messages.NodeInfo:
    """What a recording needs to replay this node's decisions."""
    from .. import __version__

    return messages.NodeInfo(
        spacecraft=config.spacecraft,
        solver=config.solver,
        time_limit_s=config.time_limit,
        seed=config.seed,
        explain=config.explain,
        explain_budget=config.explain_budget,
        clock=config.clock,
        report_timeout=config.report_timeout,
        drift_absolute=config.drift_absolute,
        drift_relative=config.drift_relative,
        heartbeat=config.heartbeat,
        replan_lead=config.lead,
        version=__version__,
        problem=problem,
    )


def run_solve(config: NodeConfig, command: StartSolve) -> Plan:
    """Solve as the node does (shared with deterministic replay)."""
    from ..solve import solve

    return solve(
        command.problem,
        config.solver,
        time_limit=config.time_limit,
        threads=config.threads,
        seed=config.seed,
        explain=config.explain,
        warm=command.warm,
        explain_budget=config.explain_budget,
    )


def _direct(callback: Callable[[Any], None]) -> zenoh.handlers.Callback:
    """Run ``callback`` on the Zenoh network thread itself.

    By default zenoh-python hands every callback to a thread of its own, so
    samples of different keys (a clock tick, then a goal, then a status
    query) could reach the inbox out of their arrival order, and the loop
    would see another order than the bus did. Our callbacks only enqueue,
    so running them directly is cheap and keeps the order.
    """
    return zenoh.handlers.Callback(callback, indirect=False)


class _Journal:
    """Writes inputs and outputs in processing order, log times rising."""

    def __init__(
        self, recorder: Recorder | None, wall_ns: Callable[[], int]
    ) -> None:
        self.recorder = recorder
        self._wall_ns = wall_ns
        self._last = 0

    def write(self, key: str, payload: bytes) -> None:
        if self.recorder is None:
            return
        stamp = max(self._wall_ns(), self._last + 1)
        self._last = stamp
        self.recorder.write(key, payload, log_time_ns=stamp)

    @property
    def last_ns(self) -> int:
        """Log time of the last message written."""
        return self._last


class SchedulerNode:
    """The scheduler on a Zenoh session.

    Parameters
    ----------
    session
        An open Zenoh session (the caller owns it).
    problem
        Resources, horizon length and initial tasks (may be empty).
    config
        Node settings.
    journal
        Optional MCAP recorder receiving every input and output in
        processing order (see :mod:`fsw_scheduler.replay`).
    seconds
        Monotonic clock in seconds for the wall time source.
    wall_ns
        Wall clock in nanoseconds for journal log times.

    Examples
    --------
    >>> with zenoh.open(config) as session:                # doctest: +SKIP
    ...     with SchedulerNode(session, problem, NodeConfig()) as node:
    ...         node.wait_closed()
    """

    def __init__(
        self,
        session: zenoh.Session,
        problem: Problem,
        config: NodeConfig,
        *,
        journal: Recorder | None = None,
        seconds: Callable[[], float] = time.monotonic,
        wall_ns: Callable[[], int] = time.time_ns,
        solve_fn: Callable[[NodeConfig, StartSolve], Plan] = run_solve,
    ) -> None:
        if config.horizon is not None:
            problem = problem.replace(horizon=config.horizon)
        self.session = session
        self.config = config
        self.topics = topics.Topics(config.spacecraft)
        self.engine = Engine(engine_config(config), problem)
        self._journal = _Journal(journal, wall_ns)
        self._wall_ns = wall_ns
        # Profiles (published), level checks and log entries (journaled)
        # derived from what the loop handles; replay derives the same.
        self._annotator = Annotator(
            self.topics, lambda: engine_problem(self.engine)
        )
        self._seconds = seconds
        self._solve_fn = solve_fn
        self._inbox: queue.Queue[tuple[str, Any]] = queue.Queue()
        self._dropped = 0
        self._stop = threading.Event()
        self._closed = threading.Event()
        self._thread: threading.Thread | None = None
        self._workers = concurrent.futures.ThreadPoolExecutor(
            max_workers=1, thread_name_prefix="fsw-solve"
        )
        self._clock: UnitClock | None = None
        self._decoder = InputDecoder(self.topics, config.clock)
        self._last_tick: int | None = None
        self._declared: list[Any] = []
        self._publishers: dict[str, zenoh.Publisher] = {}

    # -- lifecycle -----------------------------------------------------------

    def start(self) -> SchedulerNode:
        """Declare subscribers, publishers, queryables; start the loop."""
        key = self.topics.key
        session = self.session
        for suffix in (
            topics.PLAN,
            topics.STATUS,
            topics.SOLVES,
            topics.NODE_INFO,
            topics.PROFILES,
        ):
            self._publishers[suffix] = session.declare_publisher(
                key(suffix), encoding=JSON
            )
        inputs = [
            (topics.GOALS, "goal"),
            (topics.CLOCK, "clock"),
            (topics.ACTIVITY_REPORTS + "/*", "activity_report"),
            (topics.RESOURCE_LEVELS + "/*", "resource_level"),
        ]
        for suffix, kind in inputs:
            self._declared.append(
                session.declare_subscriber(
                    key(suffix), _direct(self._sample_callback(kind))
                )
            )
        for suffix in (topics.PLAN, topics.STATUS):
            self._declared.append(
                session.declare_queryable(
                    key(suffix), _direct(self._query_callback(suffix))
                )
            )
        self._declared.append(
            session.liveliness().declare_token(key(topics.ALIVE))
        )
        if self.config.clock == "wall":
            self._clock = UnitClock(self._seconds, self.config.time_unit)
        # Before the loop starts: the recorder is not shared across threads.
        self._describe_journal()
        self._thread = threading.Thread(
            target=self._spin, name="fsw-scheduler-loop", daemon=True
        )
        self._thread.start()
        self._publish_raw(
            topics.NODE_INFO,
            messages.encode(node_info(self.config, self.engine.initial)),
        )
        log.info(
            "scheduler up on %s (clock %s, solver %s)",
            self.topics.root,
            self.config.clock,
            self.config.solver,
        )
        return self

    def close(self, timeout: float = 10.0) -> None:
        """Stop the loop, wait for it, undeclare everything."""
        self._stop.set()
        self._inbox.put(("wake", None))
        if self._thread is not None:
            self._thread.join(timeout)
        self._workers.shutdown(wait=False, cancel_futures=True)
        for entity in [*self._declared, *self._publishers.values()]:
            try:
                entity.undeclare()
            except zenoh.ZError as error:  # session already closed
                log.debug("undeclare: %s", error)
        self._declared.clear()
        self._publishers.clear()
        if self._journal.recorder is not None:
            self._journal.recorder.close()
        self._closed.set()
        log.info("scheduler stopped")

    def __enter__(self) -> SchedulerNode:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def request_stop(self) -> None:
        """Ask the loop to stop (safe from signal handlers)."""
        self._stop.set()
        self._inbox.put(("wake", None))

    def wait_stopped(self, timeout: float | None = None) -> bool:
        """Block until the loop has been asked to stop."""
        return self._stop.wait(timeout)

    @property
    def dropped(self) -> int:
        """Inputs dropped because the inbox was full."""
        return self._dropped

    # -- Zenoh callbacks: enqueue only ---------------------------------------

    def _sample_callback(self, kind: str) -> Callable[[zenoh.Sample], None]:
        capacity = self.config.inbox_capacity

        def callback(sample: zenoh.Sample) -> None:
            try:
                if sample.kind != zenoh.SampleKind.PUT:
                    return
                if self._inbox.qsize() >= capacity:
                    self._dropped += 1
                    return
                self._inbox.put(
                    (kind, (str(sample.key_expr), sample.payload.to_bytes()))
                )
            except Exception:  # a raising callback fails silently in zenoh
                log.exception("dropping a %s sample", kind)

        return callback

    def _query_callback(self, suffix: str) -> Callable[[zenoh.Query], None]:
        def callback(query: zenoh.Query) -> None:
            try:
                self._inbox.put(("query", (suffix, query)))
            except Exception:
                log.exception("dropping a query")

        return callback

    # -- the loop ---------------------------------------------------------

    def _spin(self) -> None:
        while not self._stop.is_set():
            try:
                self.spin_once()
            except Exception:  # log and keep serving
                log.exception("event loop error; continuing")

    def spin_once(self, timeout: float | None = None) -> None:
        """Handle at most one inbox item, then any due clock tick."""
        self._tick_wall_clock()
        if timeout is None:
            timeout = self._clock.seconds_to_next() if self._clock else 0.5
        try:
            kind, item = self._inbox.get(timeout=max(timeout, 0.001))
        except queue.Empty:
            return
        if kind == "wake":
            return
        if kind == "query":
            self._answer(*item)
        elif kind == "solve":
            self._step(item)
        else:
            self._on_sample(kind, *item)

    def _tick_wall_clock(self) -> None:
        if self._clock is None:
            return
        now = self._clock.now()
        if now == self._last_tick:
            return
        self._last_tick = now
        self._journal.write(
            self.topics.key(topics.TICKS),
            messages.encode(messages.Clock(now)),
        )
        self._step(Tick(now))

    def _now(self) -> int:
        if self._clock is not None:
            return self._last_tick if self._last_tick is not None else 0
        bus_now = self._decoder.bus_now
        return bus_now if bus_now is not None else 0

    def _on_sample(self, kind: str, key: str, payload: bytes) -> None:
        self._journal.write(key, payload)
        self._annotate(key, payload)
        event = self._decoder.event(key, payload)
        if event is not None:
            self._step(event)

    def _step(self, event: Event) -> None:
        if self._dropped != self.engine._counters.inputs_dropped:
            self.engine.count_dropped(self._dropped)
        for command in self.engine.step(event, self._now()):
            self._execute(command)

    def _execute(self, command: Command) -> None:
        if isinstance(command, Publish):
            self._publish_raw(command.suffix, messages.encode(command.message))
        elif isinstance(command, StartSolve):
            future = self._workers.submit(self._solve_fn, self.config, command)
            future.add_done_callback(self._solve_callback(command.solve_id))
        elif isinstance(command, Log):
            log.log(logging.getLevelName(command.level.upper()), command.text)

    def _solve_callback(
        self, solve_id: int
    ) -> Callable[[concurrent.futures.Future], None]:
        def done(future: concurrent.futures.Future) -> None:
            if future.cancelled():
                return
            error = future.exception()
            if error is None:
                event: Event = SolveDone(solve_id, future.result())
            else:
                log.error("solve %d failed: %s", solve_id, error)
                event = SolveFailed(
                    solve_id, f"{type(error).__name__}: {error}"
                )
            self._inbox.put(("solve", event))

        return done

    def _publish_raw(self, suffix: str, payload: bytes) -> None:
        key = self.topics.key(suffix)
        self._journal.write(key, payload)
        publisher = self._publishers.get(suffix)
        try:
            if publisher is not None:
                publisher.put(payload)
            else:
                self.session.put(key, payload, encoding=JSON)
        except zenoh.ZError as error:  # keep serving; the bus may return
            log.error("publish on %s failed: %s", key, error)
        self._annotate(key, payload)

    def _annotate(self, key: str, payload: bytes) -> None:
        """Publish or journal what :class:`Annotator` derives from it."""
        try:
            derived = self._annotator.observe(
                key, payload, self._journal.last_ns
            )
        except Exception:  # a visualisation aid must never stop the loop
            log.exception("cannot derive profiles or log from %s", key)
            return
        for item in derived:
            if item.publish:
                self._publish_raw(item.suffix, item.payload)
            else:
                self._journal.write(self.topics.key(item.suffix), item.payload)

    def _describe_journal(self) -> None:
        """Session metadata and attachments at the head of the journal."""
        recorder = self._journal.recorder
        if recorder is None:
            return
        start_ns = self._wall_ns()
        metadata, attachments = session_records(
            self.config, self.engine.initial, start_ns
        )
        for name, pairs in metadata:
            recorder.add_metadata(name, pairs)
        for name, media_type, data in attachments:
            recorder.add_attachment(
                name, data, media_type=media_type, log_time_ns=start_ns
            )

    def _answer(self, suffix: str, query: zenoh.Query) -> None:
        message: msgspec.Struct | None = (
            self.engine.plan_message
            if suffix == topics.PLAN
            else self.engine.status("query")
        )
        try:
            if message is None:
                query.reply_err(b'{"error": "no plan yet"}', encoding=JSON)
            else:
                query.reply(
                    self.topics.key(suffix),
                    messages.encode(message),
                    encoding=JSON,
                )
        except zenoh.ZError as error:
            log.warning("query reply failed: %s", error)
        finally:
            query.drop()
