"""The scheduler as a Zenoh component: a thin shell around the engine.

One thread (the event loop) owns the :class:`~fsw_scheduler.engine.Engine`.
Zenoh callbacks only put raw samples and queries into the :class:`Inbox`
and never call Zenoh or the engine, and never block: telemetry and clock
samples are coalesced (the latest per key wins; the others are counted
as superseded), goals wait up to a count and byte limit and beyond it are
refused by name (``goal_rejected``, ``busy: N goals waiting``), never
dropped silently. Solves run on a worker thread so that dispatches keep
their timing; their results come back through the same inbox. Every input
the loop processes and every output it publishes can be written, in
processing order, to an MCAP *journal*: that linear record is what makes
:mod:`fsw_scheduler.replay` exact.

The loop survives what native code raises (a Rust panic in zenoh-python is
a ``BaseException``): each input is handled under its own guard. If the
loop stops anyway (a fault escaping the guard, or
:data:`MAX_CONSECUTIVE_FAULTS` inputs failing in a row), it does not leave
a live-looking node behind: it publishes ``state: error``, withdraws its
liveliness token and marks the node :attr:`SchedulerNode.failed`, which
makes ``fsw-scheduler run`` exit non-zero so a supervisor restarts it.
"""

from __future__ import annotations

import concurrent.futures
import logging
import queue
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import msgspec
import zenoh

from ..engine.config import EngineConfig
from ..engine.core import Engine
from ..engine.events import (
    Command,
    Event,
    Explained,
    GoalArrived,
    Log,
    Publish,
    SolveDone,
    SolveFailed,
    StartExplain,
    StartSolve,
    Tick,
)
from ..errors import BusError
from ..journal.annotate import Annotator, engine_problem, session_records
from ..runtime.clock import UnitClock
from ..runtime.inputs import InputDecoder, goal_id_of
from ..solving.ilp.cbc import Cancel, cancel_scope, sweep_stale_dirs
from ..wire import messages, topics
from .provenance import Origin, Provenance, capture

if TYPE_CHECKING:
    from ..journal.writer import Recorder
    from ..model.plan import Blocker, Plan
    from ..model.problem import Problem
    from ..runtime.config import NodeConfig

log = logging.getLogger("fsw_scheduler.node")

JSON = zenoh.Encoding.APPLICATION_JSON

SolveFn = Callable[..., "Plan"]

#: Inputs failing in a row (or publishes failing in a row) after which
#: the loop counts as unable to go on: it stops, says ``state: error``
#: and withdraws its token.
MAX_CONSECUTIVE_FAULTS = 20

#: Seconds of the response deadline kept for what a solve's limit does
#: not cover: the start plan of a large merged problem, reading CBC's
#: answer back, publishing (the soak's p99 overran 0.2 s by 0.3 s).
PUBLISH_MARGIN_S = 1.0

#: A solve gets at least this long, deadline or not (the start plan).
MIN_SOLVE_S = 0.05

#: Queries waiting for the loop; more are dropped (the querier gets no
#: reply) and counted.
MAX_WAITING_QUERIES = 256

#: Telemetry and clock keys with a sample waiting; a sample on one more
#: key is dropped and counted (``inputs_dropped``). Far above the keys a
#: node has (one per live task and consumable), it bounds the memory a
#: flood of made-up keys can take.
MAX_PENDING_KEYS = 4096

#: Goals refused unread whose rejection waits to be published; more are
#: counted as lost (never seen in practice: publishing one takes far less
#: time than receiving one).
MAX_BUSY_NOTICES = 65536

#: Inbox kinds that are samples from the bus (the others are the node's
#: own notices: busy, stalled, explained...): only these have a source.
_BUS_INPUTS = frozenset({"goal", "clock", "activity_report", "resource_level"})

# Faults that end the loop at once instead of being survived.
_FATAL = (KeyboardInterrupt, SystemExit)


class _Worker:
    """One daemon thread running jobs in order (the solves).

    Daemon, unlike ``ThreadPoolExecutor``'s threads, which the interpreter
    joins at exit: a stopping node must not wait for a solve to finish.
    """

    def __init__(self, name: str) -> None:
        self._jobs: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._thread = threading.Thread(
            target=self._run, name=name, daemon=True
        )
        self._thread.start()

    def submit(
        self, fn: Callable[..., Any], *args: Any
    ) -> concurrent.futures.Future:
        future: concurrent.futures.Future = concurrent.futures.Future()
        self._jobs.put((future, fn, args))
        return future

    def shutdown(self) -> None:
        self._jobs.put(None)

    def _run(self) -> None:
        while (job := self._jobs.get()) is not None:
            future, fn, args = job
            if not future.set_running_or_notify_cancel():
                continue
            try:
                future.set_result(fn(*args))
            except BaseException as error:  # reported as SolveFailed
                future.set_exception(error)


def _ends_activity(kind: str, payload: bytes) -> bool:
    """Whether a waiting sample is a report that ends an activity."""
    return kind == "activity_report" and (
        b'"failed"' in payload or b'"completed"' in payload
    )


class Inbox:
    """What the Zenoh callbacks hand to the loop: bounded, never blocking.

    Parameters
    ----------
    max_goals
        Undecoded goals that may wait.
    max_bytes
        Payload bytes that may wait (goals and telemetry together).

    Every method is safe from any thread and returns at once; the loop
    takes items with :meth:`get`. Items are lists ``[kind, key, payload,
    arrived, origin]`` (``payload`` is any object for internal kinds;
    ``origin`` what a bus sample says of its sender, see
    :mod:`~fsw_scheduler.bus.provenance`).
    """

    def __init__(self, max_goals: int, max_bytes: int) -> None:
        self.max_goals = max_goals
        self.max_bytes = max_bytes
        self._cond = threading.Condition(threading.Lock())
        self._items: deque[list[Any]] = deque()
        self._latest: dict[str, list[Any]] = {}
        self.goals = 0
        self.bytes = 0
        self.queries = 0
        self.busy_notices = 0
        self.superseded = 0
        self.clock_superseded = 0
        self.lost = 0
        self.busy = 0
        self.goals_lost = 0
        self.queries_dropped = 0

    def __len__(self) -> int:
        return len(self._items)

    def put_goal(
        self,
        key: str,
        payload: bytes,
        arrived: float,
        origin: Origin | None = None,
    ) -> bool:
        """Queue a goal; False when the limits are reached (not queued)."""
        with self._cond:
            if (
                self.goals >= self.max_goals
                or self.bytes + len(payload) > self.max_bytes
            ):
                return False
            self.goals += 1
            self.bytes += len(payload)
            self._items.append(["goal", key, payload, arrived, origin])
            self._cond.notify()
            return True

    def put_busy(self, goal_id: str | None, waiting: int) -> None:
        """Queue the rejection of a goal refused by :meth:`put_goal`."""
        with self._cond:
            self.busy += 1
            if self.busy_notices >= MAX_BUSY_NOTICES:
                self.goals_lost += 1
                return
            self.busy_notices += 1
            self._items.append(["busy", goal_id, waiting, 0.0, None])
            self._cond.notify()

    def put_latest(
        self,
        kind: str,
        key: str,
        payload: bytes,
        origin: Origin | None = None,
    ) -> None:
        """Queue a sample; a newer one on the same key replaces it.

        Except an execution report that ends an activity (``failed``,
        ``completed``): it is never replaced, the newer sample queues
        behind it, so that a failure followed at once by a new ``running``
        still triggers its replan. (The test is on the raw bytes, to stay
        cheap in the callback; a false match only means less coalescing.)
        """
        with self._cond:
            pending = self._latest.get(key)
            if pending is not None and _ends_activity(kind, pending[2]):
                pending = None
                del self._latest[key]
            if pending is not None:
                self.bytes += len(payload) - len(pending[2])
                pending[2] = payload
                pending[4] = origin
                if kind == "clock":
                    self.clock_superseded += 1
                else:
                    self.superseded += 1
                return
            if (
                self.bytes + len(payload) > self.max_bytes
                or len(self._latest) >= MAX_PENDING_KEYS
            ):
                self.lost += 1
                return
            self.bytes += len(payload)
            item = [kind, key, payload, 0.0, origin]
            self._latest[key] = item
            self._items.append(item)
            self._cond.notify()

    def put_query(self, item: Any) -> bool:
        """Queue a query; False when too many wait (caller drops it)."""
        with self._cond:
            if self.queries >= MAX_WAITING_QUERIES:
                self.queries_dropped += 1
                return False
            self.queries += 1
            self._items.append(["query", "", item, 0.0, None])
            self._cond.notify()
            return True

    def put(self, kind: str, item: Any) -> None:
        """Queue an internal item (solve results, wake-ups): unbounded."""
        with self._cond:
            self._items.append([kind, "", item, 0.0, None])
            self._cond.notify()

    def get(self, timeout: float) -> list[Any] | None:
        """The oldest item, waiting up to ``timeout`` s (None: nothing)."""
        with self._cond:
            if not self._items and not self._cond.wait_for(
                lambda: bool(self._items), timeout
            ):
                return None
            item = self._items.popleft()
            kind = item[0]
            if kind == "goal":
                self.goals -= 1
                self.bytes -= len(item[2])
            elif kind == "busy":
                self.busy_notices -= 1
            elif kind == "query":
                self.queries -= 1
            elif self._latest.get(item[1]) is item:
                del self._latest[item[1]]
                self.bytes -= len(item[2])
            return item


def engine_config(config: NodeConfig) -> EngineConfig:
    """The engine settings carried by a node configuration."""
    return EngineConfig(
        report_timeout=config.report_timeout,
        tolerance=config.tolerance,
        heartbeat=config.heartbeat,
        replan_lead=config.lead,
        max_tasks_per_goal=config.tasks_per_goal,
        max_live_tasks=config.live_tasks,
        max_goals_waiting=config.goals_waiting,
        max_goals_per_solve=config.goals_per_solve,
        node_id=config.node_id,
        explain_after_plan=config.explain and config.explain_after_plan,
    )


def node_info(
    config: NodeConfig,
    problem: Problem,
    security: messages.SecurityInfo | None = None,
    *,
    resumed: str = "",
) -> messages.NodeInfo:
    """What a recording needs to replay this node's decisions.

    ``resumed``: the status event (``resumed``, ``took_over``) a node
    whose state was rebuilt starts with (replay then expects it first).
    """
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
        tasks_per_goal=config.tasks_per_goal,
        live_tasks=config.live_tasks,
        goals_waiting=config.goals_waiting,
        goals_per_solve=config.goals_per_solve,
        max_clock_step=config.max_clock_step,
        explain_after_plan=config.explain_after_plan,
        response_deadline=config.response_deadline,
        version=__version__,
        problem=problem,
        resumed=resumed,
        node_id=config.node_id,
        security=security,
    )


def run_solve(config: NodeConfig, command: StartSolve) -> Plan:
    """Solve as the node does (shared with deterministic replay).

    With ``explain_after_plan`` a plan comes back unexplained (the node
    explains it once published); a solve that gives no plan is explained
    here, since the rejection it causes names the blockers.
    """
    from ..solving.solve import solve

    later = config.explain_after_plan
    plan = solve(
        command.problem,
        config.solver,
        time_limit=config.time_limit,
        threads=config.threads,
        seed=config.seed,
        # The shedding solve explains at once: its alarm must say why.
        explain=(config.explain and not later) or command.explain,
        warm=command.warm,
        explain_budget=config.explain_budget,
    )
    if config.explain and later and not plan.status.has_plan:
        plan = plan.replace(
            why=run_explain(config, command.problem, plan)
        )
    return plan


def run_explain(
    config: NodeConfig, problem: Problem, plan: Plan
) -> tuple[Blocker, ...]:
    """Why tasks of ``plan`` are out, within ``config.explain_budget``."""
    from ..analysis.explain import explain
    from ..model.plan import Plan as PlanType
    from ..model.plan import SolveStatus
    from ..solving.ilp import solve_ilp

    deadline = time.monotonic() + config.explain_budget

    def attempt(relaxed: Problem) -> Plan:
        left = deadline - time.monotonic()
        if left <= 0.05:  # budget spent: the task is not analysed
            return PlanType(
                status=SolveStatus.UNKNOWN,
                objective=None,
                unscheduled=tuple(t.id for t in relaxed.tasks),
            )
        return solve_ilp(
            relaxed,
            config.solver,
            time_limit=left,
            threads=config.threads,
            seed=config.seed,
        )

    return explain(problem, plan, attempt)


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

    def flush(self) -> None:
        if self.recorder is not None:
            self.recorder.flush()

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
    security
        How the bus is protected (:func:`~fsw_scheduler.bus.security.
        assess`), published in ``scheduler/config``.
    publishers
        Who the access-control policy lets publish on a key
        (:func:`~fsw_scheduler.bus.security.policy_publishers`), to tell
        the sender of each input (:mod:`~fsw_scheduler.bus.provenance`).

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
        security: messages.SecurityInfo | None = None,
        engine: Engine | None = None,
        resumed_event: str = "resumed",
        share_state: bool | Callable[[], bool] = False,
        durable: bool = False,
        journal_max_bytes: int | None = None,
        clock_start: int = 0,
        publishers: Callable[[str], frozenset[str] | None] | None = None,
    ) -> None:
        if config.horizon is not None:
            problem = problem.replace(horizon=config.horizon)
        self.session = session
        self.config = config
        self.topics = topics.Topics(config.spacecraft)
        # A rebuilt engine (resume from the journal) or a fresh one.
        self.resumed = resumed_event if engine is not None else ""
        # Whether to share the engine's state for a hot standby: a flag,
        # or a question asked before each step (is a standby there?), so
        # that a node with nobody to share with pays nothing.
        self._sharing = share_state is not False
        self._share_state: Callable[[], bool] = (
            share_state if callable(share_state) else lambda: share_state
        )
        self.engine = engine or Engine(engine_config(config), problem)
        self._durable = durable and journal is not None
        self._journal_max_bytes = journal_max_bytes
        self._clock_start = clock_start
        self._journal = _Journal(journal, wall_ns)
        self._wall_ns = wall_ns
        # Profiles (published), level checks and log entries (journaled)
        # derived from what the loop handles; replay derives the same.
        self._annotator = Annotator(
            self.topics, lambda: engine_problem(self.engine)
        )
        self._seconds = seconds
        self._solve_fn = solve_fn
        self._inbox = Inbox(config.inbox_capacity, config.inbox_bytes)
        self._stop = threading.Event()
        self._token: Any = None
        self.failed: str | None = None
        self._faults = 0
        self._publish_failures = 0
        self._publish_failures_in_a_row = 0
        self._closed = threading.Event()
        self._thread: threading.Thread | None = None
        self._workers = _Worker("fsw-solve")
        # Explanations on their own thread: they never hold a solve back.
        self._explainer = _Worker("fsw-explain")
        # Goal id -> monotonic arrival (s), for the response deadline.
        self._arrivals: dict[str, float] = {}
        # Goals queued in the engine, as of the loop's last step (read by
        # the callbacks, which must not touch the engine).
        self._engine_waiting = 0
        self._cancel = Cancel()
        self._clock: UnitClock | None = None
        self._decoder = InputDecoder(
            self.topics, config.clock, config.max_clock_step
        )
        self._last_clock_s = seconds()
        self._stall_reported = False
        self._last_tick: int | None = None
        self._declared: list[Any] = []
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._security = security
        self._provenance = Provenance(publishers)

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
        self._declared.append(self._provenance.declare(session))
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
        queryables = [topics.PLAN, topics.STATUS]
        if self._sharing:
            # A standby that joins later asks for the state at once.
            queryables.append(topics.SNAPSHOT)
        for suffix in queryables:
            self._declared.append(
                session.declare_queryable(
                    key(suffix), _direct(self._query_callback(suffix))
                )
            )
        self._token = session.liveliness().declare_token(key(topics.ALIVE))
        if self.config.clock == "wall":
            self._clock = UnitClock(
                self._seconds, self.config.time_unit, self._clock_start
            )
        sweep_stale_dirs()
        if self._sharing:
            self._publishers[topics.SNAPSHOT] = session.declare_publisher(
                key(topics.SNAPSHOT), encoding=JSON
            )
        # Settings and state go first into the journal, from this thread,
        # before the loop (the journal's only other writer) starts.
        self._describe_journal()
        self._publish_raw(
            topics.NODE_INFO,
            messages.encode(
                node_info(
                    self.config,
                    self.engine.initial,
                    self._security,
                    resumed=self.resumed,
                )
            ),
        )
        if self._durable:
            self._write_snapshot()
        if self._sharing and self._share_state():
            self._share_snapshot()
        if self.resumed:
            self._inbox.put("resume", None)
        self._thread = threading.Thread(
            target=self._spin, name="fsw-scheduler-loop", daemon=True
        )
        self._thread.start()
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
        self._cancel.cancel()  # a solve in flight stops now
        self._inbox.put("wake", None)
        if self._thread is not None:
            self._thread.join(timeout)
        self._workers.shutdown()
        self._explainer.shutdown()
        self._withdraw_token()
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
        self._inbox.put("wake", None)

    def wait_stopped(self, timeout: float | None = None) -> bool:
        """Block until the loop has been asked to stop (or has died)."""
        return self._stop.wait(timeout)

    @property
    def dropped(self) -> int:
        """Telemetry samples lost because the inbox's bytes were spent."""
        return self._inbox.lost

    @property
    def inbox(self) -> Inbox:
        """The queue between the Zenoh callbacks and the loop."""
        return self._inbox

    @property
    def alive(self) -> bool:
        """True while the event loop thread runs."""
        return self._thread is not None and self._thread.is_alive()

    # -- Zenoh callbacks: enqueue only, never block --------------------------

    def _sample_callback(self, kind: str) -> Callable[[zenoh.Sample], None]:
        inbox = self._inbox

        def callback(sample: zenoh.Sample) -> None:
            try:
                if sample.kind != zenoh.SampleKind.PUT:
                    return
                key = str(sample.key_expr)
                payload = sample.payload.to_bytes()
                origin = capture(sample)
                if kind != "goal":
                    inbox.put_latest(kind, key, payload, origin)
                elif not inbox.put_goal(
                    key, payload, self._seconds(), origin
                ):
                    # Refused unread, but never silently: the loop
                    # publishes a goal_rejected naming it.
                    waiting = inbox.goals + self._engine_waiting
                    inbox.put_busy(goal_id_of(payload), waiting)
            except BaseException:  # zenoh only logs what a callback raises
                log.exception("could not queue a %s sample", kind)

        return callback

    def _query_callback(self, suffix: str) -> Callable[[zenoh.Query], None]:
        def callback(query: zenoh.Query) -> None:
            try:
                if not self._inbox.put_query((suffix, query)):
                    query.drop()
            except BaseException:
                log.exception("dropping a query")

        return callback

    # -- the loop ---------------------------------------------------------

    def _spin(self) -> None:
        in_a_row = 0
        try:
            while not self._stop.is_set():
                try:
                    self.spin_once()
                    in_a_row = 0
                except _FATAL:
                    raise
                except BaseException:
                    # Native code (zenoh's Rust panics) raises
                    # BaseExceptions: survive them like any other fault.
                    self._faults += 1
                    in_a_row += 1
                    log.exception("event loop error; continuing")
                    if in_a_row >= MAX_CONSECUTIVE_FAULTS:
                        raise
                if self._publish_failures_in_a_row >= MAX_CONSECUTIVE_FAULTS:
                    # A panic poisons zenoh's transmit pipeline: every
                    # later put fails too. Nothing reaches the bus.
                    raise BusError(
                        f"{self._publish_failures_in_a_row} publishes "
                        "failed in a row"
                    )
        except BaseException as error:
            self._die(error)

    def _die(self, error: BaseException) -> None:
        """The loop cannot go on: say so, withdraw the token, stop."""
        self.failed = f"{type(error).__name__}: {error}"
        log.critical("event loop stopped: %s", self.failed, exc_info=error)
        try:
            status = msgspec.structs.replace(
                self.engine.status("loop_stopped"),
                state="error",
                detail=f"event loop stopped: {self.failed}",
            )
            self._publish_raw(topics.STATUS, messages.encode(status))
        except BaseException:
            log.exception("could not publish the error status")
        self._withdraw_token()
        # Queriers get no answer at once rather than waiting for a reply
        # that will never come.
        for entity in self._declared:
            try:
                entity.undeclare()
            except BaseException as failure:
                log.debug("undeclare: %s", failure)
        self._declared.clear()
        self._stop.set()

    def _withdraw_token(self) -> None:
        token, self._token = self._token, None
        if token is not None:
            try:
                token.undeclare()
            except BaseException as error:
                log.debug("token undeclare: %s", error)

    def spin_once(self, timeout: float | None = None) -> None:
        """Handle at most one inbox item, then any due clock tick."""
        self._tick_wall_clock()
        self._check_stall()
        if timeout is None:
            timeout = self._clock.seconds_to_next() if self._clock else 0.5
        item = self._inbox.get(timeout=max(timeout, 0.001))
        if item is None:
            return
        kind, key, payload, arrived, origin = item
        if kind == "wake":
            return
        if kind == "resume":
            self._resume()
        elif kind == "query":
            self._answer(*payload)
        elif kind == "solve":
            self._step(payload)
        elif kind == "explained":
            self._on_sample(
                kind,
                self.topics.key(topics.EXPLAINED),
                messages.encode(
                    messages.Explanation(
                        payload.solve_id, payload.plan_id, payload.why
                    )
                ),
            )
        elif kind == "goal":
            self._on_sample(kind, key, payload, origin, arrived)
        elif kind == "busy":
            self._on_sample(
                kind,
                self.topics.key(topics.BUSY),
                messages.encode(messages.Busy(key, payload)),
            )
        else:
            self._on_sample(kind, key, payload, origin=origin)

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

    def _check_stall(self) -> None:
        """With the bus clock, say when it has not ticked for a while."""
        limit = self.config.clock_stall
        if self.config.clock != "bus" or limit is None:
            return
        quiet = self._seconds() - self._last_clock_s
        if quiet < limit or self._stall_reported:
            return
        self._stall_reported = True
        self._on_sample(
            "stalled",
            self.topics.key(topics.STALLED),
            messages.encode(
                messages.Stalled(round(quiet, 3), self._decoder.bus_now)
            ),
        )

    def _now(self) -> int:
        if self._clock is not None:
            return self._last_tick if self._last_tick is not None else 0
        bus_now = self._decoder.bus_now
        return bus_now if bus_now is not None else 0

    def _on_sample(
        self,
        kind: str,
        key: str,
        payload: bytes,
        origin: Origin | None = None,
        arrived: float = 0.0,
    ) -> None:
        self._journal.write(key, payload)
        source = None
        if kind in _BUS_INPUTS:  # not the node's own notices
            source = self._provenance.resolve(key, origin)
            self._journal.write(
                self.topics.key(topics.SOURCES),
                messages.encode(messages.InputSource(key, source)),
            )
        self._annotate(key, payload)
        event = self._decoder.event(key, payload)
        if isinstance(event, GoalArrived) and len(self._arrivals) < 4096:
            self._arrivals.setdefault(event.goal.goal_id, arrived)
        if kind == "clock" and isinstance(event, Tick):
            self._last_clock_s = self._seconds()
            self._stall_reported = False
        if event is not None and source is None:
            self._step(event)
        elif event is not None and source is not None:
            self._provenance.begin(event, source)
            try:
                self._step(event)
            finally:
                self._provenance.end()

    def _step(self, event: Event) -> None:
        self._sync_counters()
        self._run(self.engine.step(event, self._now()))
        self._engine_waiting = self.engine.goals_waiting

    def _run(self, commands: list[Command]) -> None:
        """Carry out a step's commands: journal, then solves, then the bus.

        The step's outputs (and what the annotator derives from each) are
        journaled first; with ``--state`` the journal is flushed before any
        output reaches the bus (write-ahead), so a node killed at any point
        and resumed from its journal never repeats a dispatch the bus saw.
        An output on disk but not yet on the bus when the process died is
        sent again on resume, with its ids (:meth:`Engine.resume_commands`).
        """
        for command in commands:
            message = getattr(command, "message", None)
            if isinstance(message, messages.Status) and message.event in (
                "goal_accepted",
                "goal_rejected",
            ):  # the goal has its verdict: its deadline is over
                self._arrivals.pop(message.goal_id or "", None)
        if commands and self._sharing and self._share_state():
            # The standby's copy first, so that it never lags behind
            # what the bus has seen (same publisher link, in order).
            self._share_snapshot()
        outputs = [
            (
                command.suffix,
                messages.encode(self._provenance.annotate(command.message)),
            )
            for command in commands
            if isinstance(command, Publish)
        ]
        puts: list[tuple[str, bytes]] = []

        def stage(suffix: str, payload: bytes) -> None:
            # Each output, then what the annotator derives from it, as
            # replay derives it.
            key = self.topics.key(suffix)
            self._journal.write(key, payload)
            puts.append((suffix, payload))
            for item in self._derive(key, payload):
                if item.publish:
                    stage(item.suffix, item.payload)
                else:
                    self._journal.write(
                        self.topics.key(item.suffix), item.payload
                    )

        for suffix, payload in outputs:
            stage(suffix, payload)
        if self._durable:
            self._journal.flush()
        for command in commands:
            if not isinstance(command, Publish):
                self._execute(command)
        for suffix, payload in puts:
            self._put(suffix, payload)
        if self._durable:
            self._maybe_rotate()

    def _share_snapshot(self) -> None:
        """Publish the engine's state for a hot standby."""
        self._put(topics.SNAPSHOT, messages.encode(self.engine.snapshot()))

    def _write_snapshot(self) -> None:
        """The engine's state as the next journal message, on disk."""
        self._journal.write(
            self.topics.key(topics.SNAPSHOT),
            messages.encode(self.engine.snapshot()),
        )
        self._journal.flush()

    def _maybe_rotate(self) -> None:
        """Start a new journal file, opened by a snapshot, when too big."""
        recorder = self._journal.recorder
        limit = self._journal_max_bytes
        if recorder is None or limit is None or recorder.size < limit:
            return
        path = recorder.rotate()
        log.info("journal continues in %s", path)
        self._journal.write(
            self.topics.key(topics.NODE_INFO),
            messages.encode(
                node_info(self.config, self.engine.initial, self._security)
            ),
        )
        self._write_snapshot()

    def _resume(self) -> None:
        """Say the state was rebuilt; ask again for a solve in flight."""
        log.info(
            "resumed at t=%s from plan %s",
            self.engine.now,
            self.engine.plan_id,
        )
        commands = self.engine.resume_commands(self.resumed)
        pending = self.engine.pending_solve()
        if pending is not None:
            commands.append(pending)
        self._run(commands)

    def _sync_counters(self) -> None:
        inbox = self._inbox
        self.engine.count_shell(
            inputs_dropped=inbox.lost,
            telemetry_superseded=inbox.superseded,
            clock_superseded=inbox.clock_superseded,
            goals_busy=inbox.busy,
            queries_dropped=inbox.queries_dropped,
            publish_failures=self._publish_failures,
            loop_faults=self._faults,
        )

    def _execute(self, command: Command) -> None:
        """Start a solve or an explanation, or log (see :meth:`_run`)."""
        if isinstance(command, StartSolve):
            future = self._workers.submit(
                self._solve_scoped, command, self._solve_config(command)
            )
            future.add_done_callback(self._solve_callback(command.solve_id))
        elif isinstance(command, StartExplain):
            self._explainer.submit(self._explain, command)
        elif isinstance(command, Log):
            log.log(logging.getLevelName(command.level.upper()), command.text)

    def _solve_config(self, command: StartSolve) -> NodeConfig:
        """The settings of a solve: its limit cut to the goals' deadline.

        The response deadline runs from the arrival of the oldest goal of
        the solve; decoding, merging and waiting behind another solve came
        out of it already, the start plan, model and solver share the rest
        (less a margin to publish) with the solves that the goals queued
        behind this one will need.
        """
        config = self.config
        goals = self.engine.pending_goals
        if config.response_deadline is None or not goals:
            return config
        arrived = [self._arrivals[g] for g in goals if g in self._arrivals]
        for goal_id in goals:
            self._arrivals.pop(goal_id, None)
        if not arrived:
            return config
        left = config.response_deadline - (self._seconds() - min(arrived))
        # Goals queued behind this solve need solves of their own within
        # their deadlines: each batch gets an equal share of what is left.
        batches = -(-self.engine.goals_waiting // config.goals_per_solve)
        limit = max((left - PUBLISH_MARGIN_S) / (1 + batches), MIN_SOLVE_S)
        if config.time_limit is not None and config.time_limit <= limit:
            return config
        return config.replace(time_limit=limit)

    def _solve_scoped(self, command: StartSolve, config: NodeConfig) -> Plan:
        with cancel_scope(self._cancel):
            return self._solve_fn(config, command)

    def _explain(self, command: StartExplain) -> None:
        try:
            with cancel_scope(self._cancel):
                why = run_explain(self.config, command.problem, command.plan)
        except BaseException:  # an explanation is advisory: log only
            log.exception("explaining plan %d failed", command.plan_id)
            return
        self._inbox.put(
            "explained", Explained(command.solve_id, command.plan_id, why)
        )

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
            self._inbox.put("solve", event)

        return done

    def _publish_raw(self, suffix: str, payload: bytes) -> None:
        key = self.topics.key(suffix)
        self._journal.write(key, payload)
        self._put(suffix, payload)
        self._annotate(key, payload)

    def _put(self, suffix: str, payload: bytes) -> None:
        key = self.topics.key(suffix)
        publisher = self._publishers.get(suffix)
        try:
            if publisher is not None:
                publisher.put(payload)
            else:
                self.session.put(key, payload, encoding=JSON)
            self._publish_failures_in_a_row = 0
        except _FATAL:
            raise
        except BaseException as error:  # ZError, or a panic in zenoh
            # Keep serving; the bus may return.
            self._publish_failures += 1
            self._publish_failures_in_a_row += 1
            log.error(
                "publish on %s failed: %s: %s",
                key[:200],
                type(error).__name__,
                error,
            )

    def _derive(self, key: str, payload: bytes) -> list[Any]:
        """What :class:`Annotator` derives from a message (once each)."""
        try:
            return list(
                self._annotator.observe(key, payload, self._journal.last_ns)
            )
        except Exception:  # a visualisation aid must never stop the loop
            log.exception("cannot derive profiles or log from %s", key)
            return []

    def _annotate(self, key: str, payload: bytes) -> None:
        """Publish or journal what :class:`Annotator` derives from it."""
        for item in self._derive(key, payload):
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
        self._sync_counters()
        message: msgspec.Struct | None
        if suffix == topics.PLAN:
            message = self.engine.plan_message
        elif suffix == topics.SNAPSHOT:
            message = self.engine.snapshot()
        else:
            message = self.engine.status("query")
        try:
            if message is None:
                query.reply_err(b'{"error": "no plan yet"}', encoding=JSON)
            else:
                query.reply(
                    self.topics.key(suffix),
                    messages.encode(message),
                    encoding=JSON,
                )
        except _FATAL:
            raise
        except BaseException as error:  # ZError, or a panic in zenoh
            log.warning("query reply failed: %s", error)
        finally:
            query.drop()
