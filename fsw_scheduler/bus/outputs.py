"""The node's outputs: journal first, then the bus (write-ahead).

:class:`NodeOutputs` is the object a
:class:`~fsw_scheduler.bus.node.SchedulerNode` carries a step's commands
out with: every output and what the annotator derives from it goes to the
journal, in processing order, before it reaches the bus; the journal's
head (metadata, settings, snapshot), its rotation and its retry after a
disk fault live here too, with the node's publishers and the count of
publishes that failed. It is given what it writes with (session, journal
writer, annotator, provenance, engine) and owns no thread: the node calls
it from its loop (and from :meth:`SchedulerNode.start`, before the loop).
"""

from __future__ import annotations

import logging
import time
from typing import TYPE_CHECKING, Any

import msgspec
import zenoh

from ..engine.events import Command, Publish
from ..journal.annotate import session_records
from ..journal.follow import needed
from ..journal.state import prune
from ..runtime.policy import node_info
from ..wire import messages, topics
from .confirm import StandbyConfirmations, is_promise
from .standing import JOURNAL, STANDBY_LATE, STANDBY_LEFT, Standing

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..engine.core import Engine
    from ..journal.annotate import Annotator
    from ..journal.writer import OrderedWriter
    from ..runtime.config import NodeConfig
    from .provenance import Provenance

log = logging.getLogger("fsw_scheduler.node")

JSON = zenoh.Encoding.APPLICATION_JSON
# Faults that end the loop at once instead of being survived.
FATAL = (KeyboardInterrupt, SystemExit)


#: Seconds between attempts to write a failed journal again.
JOURNAL_RETRY_S = 5.0

#: Seconds between two whole states shared with a standby: between them
#: it gets the journal's records (``scheduler/changes``), and a snapshot
#: only when it asks (it joined, or missed a message).
SNAPSHOT_EVERY_S = 10.0


#: A step's outputs as journaled, waiting for the bus: (suffix, payload).
Staged = list[tuple[str, bytes]]


def _undurable(message: msgspec.Struct) -> msgspec.Struct:
    """A status sent while the journal is down says so."""
    if isinstance(message, messages.Status):
        return msgspec.structs.replace(message, durable=False)
    return message


class NodeOutputs:
    """Journal, then publish: the scheduler node's outputs.

    Parameters
    ----------
    session
        The node's Zenoh session (publishes without a declared publisher
        go through it).
    keys
        The node's key expressions (:class:`~fsw_scheduler.wire.topics.
        Topics`).
    config
        Node settings (for ``scheduler/config`` and the journal's head).
    engine
        The engine whose statuses and snapshots are published.
    journal
        The journal writer, shared with the node (which journals inputs).
    annotator
        What derives profiles, level checks and log entries from messages.
    provenance
        What sets ``source`` on the status verdicts about an input.
    security
        How the bus is protected, published in ``scheduler/config``.
    wall_ns
        Wall clock in nanoseconds (the journal's session start).
    durable
        Whether the journal is synced (fsync) before outputs reach the
        bus.
    share_state
        Whether a hot standby wants the state now (asked before each
        step with outputs); None: the state is never shared.
    journal_max_bytes
        Size at which the journal continues in a new file (None: never).
    state_max_bytes
        Bytes the state folder may keep; older parts are removed after a
        rotation (None: all are kept).

    Attributes
    ----------
    publishers
        Declared publishers by key suffix (the others go through the
        session).
    publish_failures
        Publishes that failed since the start.
    publish_failures_in_a_row
        Publishes that failed since the last one that went out.
    standing
        The conditions a status query's answer names until they end
        (:mod:`.standing`).
    """

    def __init__(
        self,
        session: zenoh.Session,
        keys: topics.Topics,
        config: NodeConfig,
        engine: Engine,
        journal: OrderedWriter,
        annotator: Annotator,
        provenance: Provenance,
        *,
        security: messages.SecurityInfo | None = None,
        wall_ns: Callable[[], int] = time.time_ns,
        durable: bool = False,
        share_state: Callable[[], bool] | None = None,
        journal_max_bytes: int | None = None,
        state_max_bytes: int | None = None,
        wake: Callable[[], None] | None = None,
    ) -> None:
        self.session = session
        self.topics = keys
        self.config = config
        self.engine = engine
        self.durable = durable
        self.publishers: dict[str, zenoh.Publisher] = {}
        self.publish_failures = 0
        self.publish_failures_in_a_row = 0
        self.standing = Standing()
        self._journal = journal
        self._annotator = annotator
        self._provenance = provenance
        self._security = security
        self._wall_ns = wall_ns
        self._share_state = share_state
        self._journal_max_bytes = journal_max_bytes
        self._state_max_bytes = state_max_bytes
        # Until the node has started, the first part's head is being
        # written: no rotation (see :meth:`allow_rotation`).
        self._may_rotate = False
        self._fault_said = False
        self._fault_retry = 0.0
        # What a standby is sent: the records since the last message.
        self._seq = 0
        self._snapshot_due = 0.0
        # A goal verdict waits for a standby's word (confirm.py).
        self._confirm: StandbyConfirmations | None = None
        if share_state is not None:
            journal.tap = []
            self._confirm = StandbyConfirmations(
                session,
                keys,
                say=lambda detail: self.alarm(detail, STANDBY_LATE),
                wake=wake,
            )
        self._sharing = False  # whether a standby was there last time
        # The step's goal_accepted verdicts and the record they wait on.
        self._promises: tuple[dict[bytes, str], str, int] | None = None
        self._resumed = ""

    # -- lifecycle -----------------------------------------------------------

    def declare(self, *suffixes: str) -> None:
        """Declare a publisher on each of these key suffixes."""
        for suffix in suffixes:
            self.publishers[suffix] = self.session.declare_publisher(
                self.topics.key(suffix), encoding=JSON
            )

    def open(self, resumed: str) -> None:
        """Write the journal's head: metadata, settings, then the state.

        The settings (``scheduler/config``, saying ``resumed``) are also
        published; the state is written only when durable.
        """
        self._describe_journal()
        self._resumed = resumed
        self.publish(topics.NODE_INFO, messages.encode(self.info()))
        if self.durable:
            self._write_snapshot()

    def info(self) -> messages.NodeInfo:
        """The settings as ``scheduler/config`` says them now (a query's
        answer: a view or a ``send`` that starts after the node)."""
        return msgspec.structs.replace(
            node_info(
                self.config,
                self.engine.initial,
                self._security,
                resumed=self._resumed,
            ),
            durable=self._journal.fault is None,
        )

    def answer(
        self, suffix: str
    ) -> tuple[msgspec.Struct | None, bytes | None]:
        """What a query on ``suffix`` is answered (None: nothing yet), and
        its attachment (a snapshot's tag)."""
        if suffix == topics.PLAN:
            return self.engine.plan_message, None
        if suffix == topics.SNAPSHOT:
            # The records so far go first; the state says which it follows.
            tag = self.snapshot_tag()
            return self.engine.snapshot(), tag
        if suffix == topics.PROFILES:
            return self._annotator.profiles, None
        if suffix == topics.NODE_INFO:
            return self.info(), None
        return self.standing.apply(self.engine.status("query")), None

    def sync(self) -> None:
        """When durable, put what was journaled on the disk now (fsync):
        what precedes a command survives a power loss."""
        if self.durable:
            self._journal.sync()

    def allow_rotation(self) -> None:
        """The node has started: a journal grown too big may rotate.

        Before, the first file's head must hold what the node says first
        (replay expects a resumed node's status in its file).
        """
        self._may_rotate = True

    def close(self) -> None:
        """Undeclare the publishers and close the journal's recorder."""
        for publisher in self.publishers.values():
            try:
                publisher.undeclare()
            except zenoh.ZError as error:  # session already closed
                log.debug("undeclare: %s", error)
        self.publishers.clear()
        if self._confirm is not None:
            self._confirm.close()
        if self._journal.recorder is not None:
            self._journal.recorder.close()

    # -- a step's outputs ----------------------------------------------------

    def write_ahead(self, commands: list[Command]) -> Staged:
        """Journal a step's outputs; return them, for :meth:`send`.

        The outputs (and what the annotator derives from each) are
        journaled; with ``--state`` the journal is synced (``fsync``,
        once for the whole step) before this returns, so that none
        reaches the bus before it is on the disk. With a standby, the
        state is shared first.
        """
        undurable = self.durable and self._journal.fault is not None
        outputs = [
            (
                command.suffix,
                _undurable(self._provenance.annotate(command.message))
                if undurable
                else self._provenance.annotate(command.message),
            )
            for command in commands
            if isinstance(command, Publish)
        ]
        puts: Staged = []

        def stage(
            suffix: str, payload: bytes, message: msgspec.Struct | None
        ) -> None:
            # Each output, then what the annotator derives from it (from
            # the typed message; replay derives the same from the bytes).
            key = self.topics.key(suffix)
            self._journal.write(key, payload)
            puts.append((suffix, payload))
            for item in self._derive(key, payload, message):
                if item.publish:
                    stage(item.suffix, item.payload, None)
                else:
                    self._journal.write(
                        self.topics.key(item.suffix), item.payload
                    )

        confirm = self._confirm
        promised: dict[bytes, str] = {}  # goal_accepted payload: goal id
        for suffix, message in outputs:
            payload = messages.encode(message)
            stage(suffix, payload, message)
            if (
                is_promise(message)
                # The same verdict again (a re-sent goal) a standby holds.
                and not (confirm is not None and confirm.kept(message.goal_id))
            ):
                promised[payload] = message.goal_id or ""
        # The standby's copy before the bus sees any output, so that it
        # never lags behind what the bus has seen (same link, in order).
        seq = self.share(bool(promised))
        if promised and seq is not None:
            self._promises = (promised, self.stream, seq)
        if puts:
            # Group commit: one sync for every record of the step (its
            # inputs, the solve results, its outputs) before any output.
            self.sync()
        elif self.durable:
            self._journal.flush()  # nothing commands: the page cache
        return puts

    def send(self, puts: Staged) -> None:
        """Publish what :meth:`write_ahead` journaled, then tend the
        journal (a fault to report or retry, a file to rotate). A goal's
        ``goal_accepted`` is held back until a standby holds its step
        (:mod:`.confirm`; :meth:`release` sends it)."""
        promises, self._promises = self._promises, None
        if promises is not None and self._confirm is not None:
            payloads, stream, seq = promises
            held = [(s, p) for s, p in puts if p in payloads]
            if self._confirm.hold(stream, seq, held, tuple(payloads.values())):
                puts = [(s, p) for s, p in puts if p not in payloads]
        for suffix, payload in puts:
            self.put(suffix, payload)
        self.release()
        self.watch()
        if self.durable and self._journal.fault is None:
            self._maybe_rotate()

    def release(self) -> float | None:
        """Send the verdicts whose step a standby now holds (or whose wait
        ran out); the seconds until the next one is due anyway."""
        if self._confirm is None:
            return None
        free, left = self._confirm.release()
        for suffix, payload in free:
            self.put(suffix, payload)
        if self._confirm.healthy():
            self.standing.put(STANDBY_LATE, None)
        return left

    def share(self, confirm: bool = False) -> int | None:
        """Send a hot standby what was journaled since the last time: the
        records, and the whole state every :data:`SNAPSHOT_EVERY_S`; with
        ``confirm``, asking it to say when it holds them. The sequence
        number to wait for (None: nothing sent, no standby)."""
        if self._share_state is None:
            return None
        if not self._share_state():
            if self._sharing:
                self._sharing = False  # a standby left: said once
                self.alarm(
                    "no standby holds this node's state any more (it left "
                    "the bus): goals accepted until one is back are held "
                    "by this node alone, lost if both computers are reset "
                    "and the other boots first",
                    STANDBY_LEFT,
                )
            # No one to share with: a standby that comes asks for the
            # state, which holds what is dropped here; the number moves
            # on, so that one that already had a state sees the gap.
            if self._journal.tap:
                self._journal.tap = []
                self._seq += 1
            return None
        if not self._sharing:
            self._sharing = True  # a standby (back): nothing to say
            self.standing.put(STANDBY_LEFT, None)
        before = self._seq
        seq = self.share_changes(confirm)
        if time.monotonic() >= self._snapshot_due:
            self._share_snapshot()
        return seq if seq > before else None

    def share_changes(self, confirm: bool = False) -> int:
        """Publish the records journaled since the last message (if any);
        the sequence number of the last message sent."""
        tap = self._journal.tap
        if not tap:
            return self._seq
        self._journal.tap = []
        # What the standby steps on: inputs and solve results, not the
        # outputs they gave (it would only skip them).
        tap = [(k, p) for k, p in tap if needed(self.topics, k)]
        if not tap:
            return self._seq
        self._seq += 1
        self.put(
            topics.CHANGES,
            messages.encode(
                messages.Changes(
                    self.stream,
                    self._seq,
                    self.engine.term,
                    tuple((k, msgspec.Raw(p)) for k, p in tap),
                    confirm,
                )
            ),
        )
        return self._seq

    @property
    def stream(self) -> str:
        """This commander's run, as its standby knows it: a node commands
        in one term, and a new term starts a new stream."""
        return f"{self.config.node_id or ''}:{self.engine.term}"

    def snapshot_tag(self) -> bytes:
        """What a shared state says it follows: ``<stream> <seq>`` (the
        records journaled until now are sent first)."""
        seq = self.share_changes() if self._journal.tap is not None else 0
        return f"{self.stream} {seq}".encode()

    def publish(self, suffix: str, payload: bytes) -> None:
        """Journal, publish and annotate one message outside a step."""
        key = self.topics.key(suffix)
        self._journal.write(key, payload)
        self.put(suffix, payload)
        self.annotate(key, payload)

    def put(self, suffix: str, payload: bytes) -> None:
        """Publish on the bus only; a failure is logged and counted."""
        key = self.topics.key(suffix)
        publisher = self.publishers.get(suffix)
        try:
            if publisher is not None:
                publisher.put(payload)
            else:
                self.session.put(key, payload, encoding=JSON)
            self.publish_failures_in_a_row = 0
        except FATAL:
            raise
        except BaseException as error:  # ZError, or a panic in zenoh
            # Keep serving; the bus may return.
            self.publish_failures += 1
            self.publish_failures_in_a_row += 1
            log.error(
                "publish on %s failed: %s: %s",
                key[:200],
                type(error).__name__,
                error,
            )

    def annotate(
        self, key: str, payload: bytes, message: msgspec.Struct | None = None
    ) -> None:
        """Publish or journal what :class:`Annotator` derives from it."""
        for item in self._derive(key, payload, message):
            if item.publish:
                self.publish(item.suffix, item.payload)
            else:
                self._journal.write(self.topics.key(item.suffix), item.payload)

    # -- the journal ---------------------------------------------------------

    def watch(self) -> None:
        """When durable, tend a journal that cannot be written.

        Say so at once (the bus does not need the disk), go on without
        durability, try again every :data:`JOURNAL_RETRY_S` in a new
        part, say when it is back.
        """
        if not self.durable:
            return
        fault = self._journal.fault
        now = time.monotonic()
        if fault is None:
            return
        if not self._fault_said:
            self._fault_said, self._fault_retry = True, now + JOURNAL_RETRY_S
            self._say_journal(
                "degraded",
                "journal_failed",
                f"journal: {fault}: commanding without durability (a "
                "restart would lose what happens until it is back); trying "
                f"again every {JOURNAL_RETRY_S:g} s",
            )
            return
        if now < self._fault_retry:
            return
        self._fault_retry = now + JOURNAL_RETRY_S
        if not self._journal.resume():
            return
        self._head_of_part()
        if self._journal.fault is None:
            self._fault_said = False
            recorder = self._journal.recorder
            where = recorder.paths[-1].name if recorder is not None else ""
            self._say_journal(
                "ok", "journal_resumed", f"journal continues in {where}"
            )

    def _say_journal(self, state: str, event: str, detail: str) -> None:
        """A status about the journal, straight to the bus (not journaled:
        it is about the journal)."""
        self.standing.put(JOURNAL, detail if state != "ok" else None)
        status = self.engine.status(event, detail=detail)
        status = msgspec.structs.replace(
            status,
            state=state if status.state == "ok" else status.state,
            activities={},
            durable=self._journal.fault is None,
        )
        log.warning("%s: %s", event, detail)
        self.put(topics.STATUS, messages.encode(status))
        info = node_info(self.config, self.engine.initial, self._security)
        self.put(
            topics.NODE_INFO,
            messages.encode(
                msgspec.structs.replace(
                    info, durable=self._journal.fault is None
                )
            ),
        )

    def alarm(self, detail: str, condition: str) -> None:
        """An alarm on the bus only (not journaled: no decision); the
        ``condition`` it begins stands in query answers until it ends."""
        self.standing.put(condition, detail)
        status = self.engine.status("alarm", detail=detail, state="degraded")
        self.put(topics.STATUS, messages.encode(status))

    def _share_snapshot(self) -> None:
        """Publish the engine's state for a hot standby."""
        tag = self.snapshot_tag()
        self._snapshot_due = time.monotonic() + SNAPSHOT_EVERY_S
        try:
            self.session.put(
                self.topics.key(topics.SNAPSHOT),
                messages.encode(self.engine.snapshot()),
                encoding=JSON,
                attachment=tag,
            )
        except FATAL:
            raise
        except BaseException as error:  # ZError, or a panic in zenoh
            self.publish_failures += 1
            log.error("sharing the state failed: %s", error)

    def _write_snapshot(self) -> None:
        """The engine's state as the next journal message, on disk."""
        self._journal.write(
            self.topics.key(topics.SNAPSHOT),
            messages.encode(self.engine.snapshot()),
        )
        self._journal.sync()

    def _maybe_rotate(self) -> None:
        """Start a new journal file, opened by a snapshot, when too big."""
        recorder = self._journal.recorder
        limit = self._journal_max_bytes
        if recorder is None or limit is None or recorder.size < limit:
            return
        if not self._may_rotate:
            return
        path = self._journal.rotate()
        if path is None:
            self.watch()  # the disk refused the next part: say so
            return
        log.info("journal continues in %s", path)
        self._head_of_part()
        if self._state_max_bytes is not None:
            # The new part opens with the state: older files may go.
            for old in prune(path.parent, path, self._state_max_bytes):
                log.info("state budget: removed %s", old.name)

    def _head_of_part(self) -> None:
        """What opens each journal part: the settings, then the state."""
        self._journal.write(
            self.topics.key(topics.NODE_INFO),
            messages.encode(
                node_info(self.config, self.engine.initial, self._security)
            ),
        )
        self._write_snapshot()

    def _derive(
        self, key: str, payload: bytes, message: msgspec.Struct | None = None
    ) -> list[Any]:
        """What :class:`Annotator` derives from a message (once each)."""
        stamp = self._journal.last_ns
        try:
            if message is not None:
                return self._annotator.observe_message(key, message, stamp)
            return self._annotator.observe(key, payload, stamp)
        except Exception:  # a visualisation aid must never stop the loop
            log.exception("cannot derive profiles or log from %s", key)
            return []

    def _describe_journal(self) -> None:
        """Session metadata and attachments at the head of the journal."""
        recorder = self._journal.recorder
        if recorder is None:
            return
        start_ns = self._wall_ns()
        metadata, attachments = session_records(
            self.config, self.engine.initial, start_ns
        )
        try:
            for name, pairs in metadata:
                recorder.add_metadata(name, pairs)
            for name, media_type, data in attachments:
                recorder.add_attachment(
                    name, data, media_type=media_type, log_time_ns=start_ns
                )
        except OSError as error:
            self._journal.fail(error)


def reply(
    query: zenoh.Query, key: str, payload: bytes | None, tag: bytes | None
) -> None:
    """Answer ``query`` with ``payload`` on ``key`` (an error reply when
    there is nothing yet: no plan), then release it.

    A reply that fails (the querier left, a zenoh fault) is logged: the
    loop keeps serving.
    """
    try:
        if payload is None:
            query.reply_err(b'{"error": "no plan yet"}', encoding=JSON)
        else:
            query.reply(key, payload, encoding=JSON, attachment=tag)
    except FATAL:
        raise
    except BaseException as error:  # ZError, or a panic in zenoh
        log.warning("query reply failed: %s", error)
    finally:
        query.drop()
