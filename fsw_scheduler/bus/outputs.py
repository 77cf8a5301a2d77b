"""The node's outputs: journal first, then the bus (write-ahead).

:class:`NodeOutputs` is the part of
:class:`~fsw_scheduler.bus.node.SchedulerNode` that carries a step's
commands out: every output and what the annotator derives from it goes to
the journal, in processing order, before it reaches the bus; the journal's
head (metadata, settings, snapshot) and its rotation live here too.
"""

from __future__ import annotations

import logging
import time
from typing import TYPE_CHECKING, Any

import msgspec
import zenoh

from ..engine.events import Command, Publish
from ..journal.annotate import session_records
from ..journal.state import prune
from ..runtime.policy import node_info
from ..wire import messages, topics

if TYPE_CHECKING:
    import threading
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


def _undurable(message: msgspec.Struct) -> msgspec.Struct:
    """A status sent while the journal is down says so."""
    if isinstance(message, messages.Status):
        return msgspec.structs.replace(message, durable=False)
    return message


class NodeOutputs:
    """Journal, then publish (a mixin of the scheduler node)."""

    session: zenoh.Session
    config: NodeConfig
    topics: topics.Topics
    engine: Engine
    _journal: OrderedWriter
    _annotator: Annotator
    _provenance: Provenance
    _publishers: dict[str, zenoh.Publisher]
    _arrivals: dict[str, float]
    _durable: bool
    _sharing: bool
    _share_state: Callable[[], bool]
    _journal_max_bytes: int | None
    _state_max_bytes: int | None = None
    _security: messages.SecurityInfo | None
    _wall_ns: Callable[[], int]
    _publish_failures: int
    _publish_failures_in_a_row: int
    _thread: threading.Thread | None
    _fault_said: bool = False
    _fault_retry: float = 0.0

    def _lease_holds(self) -> bool:
        raise NotImplementedError

    def _execute(self, command: Command) -> None:
        raise NotImplementedError

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
        undurable = self._durable and self._journal.fault is not None
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
        puts: list[tuple[str, bytes]] = []

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

        for suffix, message in outputs:
            stage(suffix, messages.encode(message), message)
        if self._durable:
            self._journal.flush()
        for command in commands:
            if not isinstance(command, Publish):
                self._execute(command)
        if not self._lease_holds():
            return  # journaled, never sent: a resume sends it again
        for suffix, payload in puts:
            self._put(suffix, payload)
        if self._durable:
            self._watch_journal()
        if self._durable and self._journal.fault is None:
            self._maybe_rotate()

    def _watch_journal(self) -> None:
        """A journal that cannot be written: say so at once (the bus does
        not need the disk), go on without durability, try again every
        :data:`JOURNAL_RETRY_S` in a new part, say when it is back."""
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
        status = self.engine.status(event, detail=detail)
        status = msgspec.structs.replace(
            status,
            state=state if status.state == "ok" else status.state,
            activities={},
            durable=self._journal.fault is None,
        )
        log.warning("%s: %s", event, detail)
        self._put(topics.STATUS, messages.encode(status))
        info = node_info(self.config, self.engine.initial, self._security)
        self._put(
            topics.NODE_INFO,
            messages.encode(
                msgspec.structs.replace(
                    info, durable=self._journal.fault is None
                )
            ),
        )

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
        if self._thread is None:
            # Still starting: the file's head must hold what the node says
            # first (replay expects a resumed node's status in its file).
            return
        path = recorder.rotate()
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
        except FATAL:
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

    def _annotate(
        self, key: str, payload: bytes, message: msgspec.Struct | None = None
    ) -> None:
        """Publish or journal what :class:`Annotator` derives from it."""
        for item in self._derive(key, payload, message):
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
        try:
            for name, pairs in metadata:
                recorder.add_metadata(name, pairs)
            for name, media_type, data in attachments:
                recorder.add_attachment(
                    name, data, media_type=media_type, log_time_ns=start_ns
                )
        except OSError as error:
            self._journal.fail(error)
