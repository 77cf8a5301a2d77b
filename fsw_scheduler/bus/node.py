"""The scheduler as a Zenoh component: a thin shell around the engine.

One thread (the event loop) owns the :class:`~fsw_scheduler.engine.Engine`.
Zenoh callbacks only put what arrives into the
:class:`~fsw_scheduler.bus.inbox.Inbox` (coalesced, bounded, never
dropped silently); solves run on a worker thread. Every input the loop
processes and every output it publishes is written, in processing order,
to an MCAP *journal*: that linear record is what makes
:mod:`fsw_scheduler.journal.replay` exact.

Each input is handled under its own guard (a Rust panic in zenoh-python is
a ``BaseException``). If the loop stops anyway (a fault escaping the
guard, or :data:`MAX_CONSECUTIVE_FAULTS` inputs failing in a row), it
publishes ``state: error``, withdraws its liveliness token and marks the
node :attr:`SchedulerNode.failed`, which makes ``fsw-scheduler run`` exit
non-zero so a supervisor restarts it.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import TYPE_CHECKING, Any

import msgspec
import zenoh

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
    input_message,
)
from ..errors import BusError
from ..journal.annotate import Annotator, engine_problem
from ..journal.writer import OrderedWriter
from ..runtime.clock import UnitClock
from ..runtime.inputs import InputDecoder, goal_id_of
from ..runtime.policy import (
    deadline_config,
    engine_config,
    run_explain,
    run_solve,
)
from ..solving.ilp.cbc import Cancel, cancel_scope
from ..solving.ilp.child import sweep_stale_dirs
from ..wire import messages, topics
from ..wire.terms import MAX_TERM
from .inbox import BUS_INPUTS, NOTICES, Inbox, Worker, direct
from .outputs import FATAL, NodeOutputs, reply
from .provenance import Origin, Provenance, capture
from .standing import TERM_MARK
from .term_record import term_record
from .whatif import WhatIfs

if TYPE_CHECKING:
    import concurrent.futures
    from collections.abc import Callable

    from ..journal.writer import Recorder
    from ..model.plan import Plan
    from ..model.problem import Problem
    from ..runtime.config import NodeConfig
    from .lease import Lease

log = logging.getLogger("fsw_scheduler.node")


#: Inputs failing in a row (or publishes failing in a row) after which
#: the loop counts as unable to go on: it stops, says ``state: error``
#: and withdraws its token.
MAX_CONSECUTIVE_FAULTS = 20


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
        processing order (see :mod:`fsw_scheduler.journal.replay`).
    seconds, wall_ns
        Monotonic seconds (the wall time source); wall-clock nanoseconds
        (journal log times).
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
    ...         node.wait_stopped()
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
        state_max_bytes: int | None = None,
        journal_fault: str | None = None,
        clock_start: int = 0,
        publishers: Callable[[str], frozenset[str] | None] | None = None,
        term_floor: int = 0,
        on_term: Callable[[int], str | None] | None = None,
        vouched: int | None = None,
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
        wanted: Callable[[], bool] = (
            share_state if callable(share_state) else lambda: share_state
        )
        self.engine = engine or Engine(engine_config(config), problem)
        self._clock_start = clock_start
        self._journal = OrderedWriter(journal, wall_ns)
        # A journal that could not be opened (a full disk at start).
        self._journal.fault = journal_fault
        # Profiles (published), level checks and log entries (journaled)
        # derived from what the loop handles; replay derives the same.
        self._annotator = Annotator(
            self.topics, lambda: engine_problem(self.engine)
        )
        self._provenance = Provenance(publishers)
        # Everything that leaves the node, journal first (write-ahead).
        self._outputs = NodeOutputs(
            session,
            self.topics,
            config,
            self.engine,
            self._journal,
            self._annotator,
            self._provenance,
            security=security,
            wall_ns=wall_ns,
            durable=durable and journal is not None,
            share_state=wanted if self._sharing else None,
            journal_max_bytes=journal_max_bytes,
            state_max_bytes=state_max_bytes,
            wake=lambda: self._inbox.put("wake", None),
        )
        #: What a status query names until it ends (:mod:`.standing`).
        self.standing = self._outputs.standing
        self._seconds = seconds
        self._solve_fn = solve_fn
        self._inbox = Inbox(
            config.inbox_capacity,
            config.inbox_bytes,
            seconds,
            self.topics.key("**"),
        )
        for goal_id, record in self.engine.snapshot().ledger.items():
            if record.verdict == "accepted":  # resumed: sent again, it stands
                self._inbox.note_verdict(goal_id, "goal_accepted")
        self._stop = threading.Event()
        self._token: Any = None
        self.failed: str | None = None
        self._faults = 0
        self._thread: threading.Thread | None = None
        self._workers = Worker("fsw-solve")
        # Explanations on their own thread: they never hold a solve back.
        self._explainer = Worker("fsw-explain")
        # Goal id -> monotonic arrival (s), for the response deadline.
        self._arrivals: dict[str, float] = {}
        # Goals queued in the engine, as of the loop's last step (read by
        # the callbacks, which must not touch the engine).
        self._engine_waiting = 0
        self._cancel = Cancel()
        self._clock: UnitClock | None = None
        self._decoder = InputDecoder(
            self.topics,
            config.clock,
            config.max_clock_step,
            self.engine.initial.resources,
        )
        # What-if queries, answered from a copy of the state, aside.
        self._what_ifs = WhatIfs(
            self.engine,
            config,
            self._inbox,
            self._journal.write,
            self.topics.key(topics.WHAT_IF),
            solve_fn,
            seconds,
            self._cancel,
        )
        self._last_clock_s = seconds()
        self._stall_reported = False
        self._last_tick: int | None = None
        self._declared: list[Any] = []
        # The highest term seen elsewhere (redundancy): this node's term
        # is above it and above its own state's.
        self._term_floor = term_floor
        self._vouched = vouched
        self._on_term = on_term
        #: The lease this node commands on (set before :meth:`start`; see
        #: :mod:`~fsw_scheduler.bus.lease`); None: not watched.
        self.lease: Lease | None = None
        #: Why this node stopped commanding (its lease ended), else None.
        self.stood_down: str | None = None
        #: After a stall under the lease: who else commands now (None: no
        #: one, this node goes on); set by the election.
        self.reverify: Callable[[], str | None] | None = None
        # A stall re-verified, not yet journaled (seconds).
        self._paused: float | None = None

    # -- lifecycle -----------------------------------------------------------

    def start(self) -> SchedulerNode:
        """Declare subscribers, publishers, queryables; start the loop."""
        key = self.topics.key
        session = self.session
        outputs = self._outputs
        outputs.declare(
            topics.PLAN,
            topics.STATUS,
            topics.SOLVES,
            topics.NODE_INFO,
            topics.PROFILES,
        )
        self._declared.append(self._provenance.declare(session))
        if self.resumed:
            # First in the inbox: a rebuilt node speaks (and re-sends its
            # outputs) before any input, as a replay of its journal does;
            # a tick arriving as the subscribers are declared waits.
            self._inbox.put("resume", None)
        for suffix, kind in topics.SUBSCRIPTIONS:
            self._declared.append(
                session.declare_subscriber(
                    key(suffix), direct(self._sample_callback(kind))
                )
            )
        # Profiles too: a monitor that starts after a plan shows its
        # predicted levels at once (``fsw-scheduler view``).
        # The settings too: ``send`` checks a goal against the resources,
        # a late view fills its config channel.
        queryables = [
            topics.PLAN,
            topics.STATUS,
            topics.PROFILES,
            topics.NODE_INFO,
            topics.WHAT_IF,
        ]
        if self._sharing:
            # A standby that joins later asks for the state at once.
            queryables.append(topics.SNAPSHOT)
        for suffix in queryables:
            self._declared.append(
                session.declare_queryable(
                    key(suffix), direct(self._query_callback(suffix))
                )
            )
        self._token = session.liveliness().declare_token(key(topics.ALIVE))
        if self.config.clock == "wall":
            self._clock = UnitClock(
                self._seconds, self.config.time_unit, self._clock_start
            )
        sweep_stale_dirs()
        if self._sharing:
            outputs.declare(topics.SNAPSHOT)
        # Settings and state go first into the journal, from this thread,
        # before the loop (the journal's only other writer) starts.
        outputs.open(self.resumed)
        term = self._begin_term()
        outputs.sync()  # the term is on disk before any command
        if self._on_term is not None and (fault := self._on_term(term)):
            outputs.alarm(fault, TERM_MARK)  # the folder's term.json
        outputs.put(topics.TERM, self._term_payload)
        outputs.share()
        outputs.watch()  # a journal down from the start: say so
        outputs.allow_rotation()
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

    @property
    def term(self) -> int:
        """The command term this node commands in."""
        return self.engine.term

    def _begin_term(self) -> int:
        """Journal a new term, above every one seen, as an input."""
        term = max(self.engine.term, self._term_floor) + 1
        if term > MAX_TERM:
            # Never reached by raising one at a time from verified terms.
            raise BusError(f"no term left above {term - 1}")
        engine = self.engine
        self._term_payload = messages.encode(
            term_record(
                term,
                self.config.node_id or "",
                self.resumed,
                (engine.term, engine.plan_id, engine.now),
                self._term_floor,
                self._vouched,
            )
        )
        self._on_sample(
            "term", self.topics.key(topics.TERM), self._term_payload
        )
        return term

    def close(self, timeout: float = 10.0) -> None:
        """Stop the loop, wait for it, undeclare everything."""
        self._stop.set()
        self._cancel.cancel()  # a solve in flight stops now
        self._inbox.put("wake", None)
        if self._thread is not None:
            self._thread.join(timeout)
        self._workers.shutdown()
        self._explainer.shutdown()
        self._what_ifs.close()
        if self.lease is not None:
            self.lease.stop()
        self._withdraw_token()
        for entity in self._declared:
            try:
                entity.undeclare()
            except zenoh.ZError as error:  # session already closed
                log.debug("undeclare: %s", error)
        self._declared.clear()
        self._outputs.close()
        log.info("scheduler stopped")

    def __enter__(self) -> SchedulerNode:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def wait_stopped(self, timeout: float | None = None) -> bool:
        """Block until the loop has been asked to stop (or has died)."""
        return self._stop.wait(timeout)

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
                elif not inbox.put_goal(key, payload, self._seconds(), origin):
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
                    # Refused (too many wait), so finished here: zenoh
                    # sends the querier its final reply when the query's
                    # last reference goes, at the latest as this callback
                    # returns. Handing it to the loop would mean holding
                    # it, which the bound is there to prevent; drop() only
                    # makes that release explicit (finalisers are not
                    # reliable, say zenoh-python's docs).
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
                except FATAL:
                    raise
                except BaseException:
                    # Native code (zenoh's Rust panics) raises
                    # BaseExceptions: survive them like any other fault.
                    self._faults += 1
                    in_a_row += 1
                    log.exception("event loop error; continuing")
                    if in_a_row >= MAX_CONSECUTIVE_FAULTS:
                        raise
                failed = self._outputs.publish_failures_in_a_row
                if failed >= MAX_CONSECUTIVE_FAULTS:
                    # A panic poisons zenoh's transmit pipeline: every
                    # later put fails too. Nothing reaches the bus.
                    raise BusError(f"{failed} publishes failed in a row")
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
            self._outputs.publish(topics.STATUS, messages.encode(status))
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

    def _lease_holds(self) -> bool:
        """False once the lease ended: the loop stops, nothing goes out."""
        if self.stood_down is None and self.lease is not None:
            self.stood_down = self.lease.lost()
            gap = self.lease.hiccup() if self.stood_down is None else None
            if gap is not None and self.reverify is not None:
                # A stall under the lease: still the commander? Ask the
                # bus before the next output instead of standing down.
                other = self.reverify()
                if other is not None:
                    self.stood_down = (
                        f"this process did not run for {gap:.1f} s; {other}"
                    )
                else:
                    self._paused = max(gap, self._paused or 0.0)
            if self.stood_down is not None:
                self._stop.set()  # redundancy.serve closes the node
        return self.stood_down is None

    def spin_once(self, timeout: float | None = None) -> None:
        """Handle at most one inbox item, then any due clock tick."""
        if not self._lease_holds():
            return
        self._note_pause()
        self._tick_wall_clock()
        self._check_stall()
        self._outputs.watch()  # retries a failed journal without steps
        if timeout is None:
            timeout = self._clock.seconds_to_next() if self._clock else 0.5
        for held in (
            self._what_ifs.seconds_to_next(),
            self._outputs.release(),
        ):
            if held is not None:
                timeout = min(timeout, held)
        item = self._inbox.get(timeout=max(timeout, 0.001))
        try:
            self._handle(item)
        finally:
            # A solve that ended, or a hold that ran out, lets a what-if go.
            self._what_ifs.poll()

    def _handle(self, item: list[Any] | None) -> None:
        """Handle one inbox item (see :meth:`spin_once`)."""
        if item is None:
            return
        # The process may have been stopped while it waited: what came
        # meanwhile is handled after the pause is said.
        if not self._lease_holds():
            return
        self._note_pause()
        kind, key, payload, arrived, origin = item
        if kind == "wake":
            return
        if kind == "what_if":
            self._what_ifs.finish(*payload)
        elif kind == "resume":
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
        elif kind in NOTICES:  # payload: messages.Busy or Dropped
            about = getattr(payload, "key", None)  # the dropped samples'
            notice = messages.encode(payload)
            key = self.topics.key(NOTICES[kind])
            self._on_sample(kind, key, notice, origin, about=about)
        else:
            self._on_sample(kind, key, payload, origin=origin)

    def _note_pause(self) -> None:
        """Journal and step a stall under the lease this node survived, so
        that the clock jump after it dispatches late instead of missing."""
        gap, self._paused = self._paused, None
        if gap is None:
            return
        self._on_sample(
            "paused",
            self.topics.key(topics.PAUSED),
            messages.encode(messages.Paused(round(gap, 3), self._now())),
        )

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
        quiet = self._seconds() - self._last_clock_s
        if self._stall_reported or not stalled(
            self.config, self._decoder.bus_now, quiet
        ):
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
        about: str | None = None,
    ) -> None:
        self._journal.write(key, payload)
        source = None
        if kind in BUS_INPUTS or about is not None:  # not own notices
            source = self._provenance.resolve(about or key, origin)
            self._journal.write(
                self.topics.key(topics.SOURCES),
                messages.encode(messages.InputSource(key, source)),
            )
        event = self._decoder.event(key, payload)
        self._outputs.annotate(key, payload, input_message(event))
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
        self.engine.count_shell(
            **self._inbox.counters(),
            publish_failures=self._outputs.publish_failures,
            loop_faults=self._faults,
        )

    def _run(self, commands: list[Command]) -> None:
        """Carry out a step's commands: journal, then solves, then the bus.

        The step's outputs (and what the annotator derives from each) are
        journaled first; with ``--state`` the journal is synced before any
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
                self._inbox.note_verdict(message.goal_id, message.event)
        puts = self._outputs.write_ahead(commands)
        for command in commands:
            if not isinstance(command, Publish):
                self._execute(command)
        if not self._lease_holds():
            return  # journaled, never sent: a resume sends it again
        self._outputs.send(puts)

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
        """The settings of a solve: its limit cut to the goals' deadline."""
        goals = self.engine.pending_goals
        arrived = [self._arrivals.pop(g) for g in goals if g in self._arrivals]
        return deadline_config(
            self.config,
            [self._seconds() - t for t in arrived],
            self.engine.goals_waiting,
        )

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

    def _answer(self, suffix: str, query: zenoh.Query) -> None:
        self._sync_counters()
        if suffix == topics.WHAT_IF:
            self._what_ifs.ask(query)  # it replies, now or later
            return
        message, tag = self._outputs.answer(suffix)
        reply(
            query,
            self.topics.key(suffix),
            None if message is None else messages.encode(message),
            tag,
        )


def stalled(config: NodeConfig, bus_now: int | None, quiet: float) -> bool:
    """Whether the bus clock counts as stalled after ``quiet`` seconds
    without a clock message (``clock-stall``; never with the wall clock).

    Before a first clock the node waits for time to start (its status
    says now null): it has not lost a clock it had.
    """
    limit = config.clock_stall
    if config.clock != "bus" or limit is None or bus_now is None:
        return False
    return quiet >= limit
