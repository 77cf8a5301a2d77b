"""The standby's copy of the commander's state: followed, kept, told.

A standby holds the newest state it was shared (a snapshot with the
``<stream> <seq>`` it follows), brings it up to date with the commander's
records (``scheduler/changes``, applied in order by a
:class:`~fsw_scheduler.journal.follow.Follower`), offers it to its
folder (:class:`~fsw_scheduler.journal.state.StandbyStore`) and tells
peers that ask what it holds. Which states are believed (terms) is the
election's business (:mod:`fsw_scheduler.bus.redundancy`); this object
only keeps what it is given.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from typing import TYPE_CHECKING

import msgspec
import zenoh

from ..engine.snapshot import EngineSnapshot
from ..journal.follow import Follower
from ..wire import messages, topics

if TYPE_CHECKING:
    from ..journal.state import StandbyStore
    from ..runtime.config import NodeConfig

log = logging.getLogger("fsw_scheduler.redundancy")

#: Changes messages a standby keeps waiting (its loop applies them every
#: pass); beyond, it starts again from a snapshot.
MAX_CHANGES_WAITING = 4096

#: A shared state's place in its commander's records: (stream, seq).
Tag = tuple[str, int]


def tag_of(sample: zenoh.Sample) -> Tag | None:
    """The ``<stream> <seq>`` a shared state says it follows."""
    attachment = sample.attachment
    if attachment is None:
        return None
    try:
        stream, _, seq = attachment.to_bytes().decode().rpartition(" ")
        return stream, int(seq)
    except (UnicodeDecodeError, ValueError):
        return None


def fence_terms(
    session: zenoh.Session, keys: topics.Topics, timeout: float
) -> list[tuple[str, int]]:
    """The terms receivers' fences hold (``scheduler/fences/**``), each
    with who said it: what a node about to command asks (open bus)."""
    found = []
    try:
        replies = list(
            session.get(keys.key(f"{topics.FENCES}/**"), timeout=timeout)
        )
    except zenoh.ZError as error:  # asked again before the next command
        log.warning("asking the receivers' terms: %s", error)
        return []
    for reply in replies:
        if reply.ok is None:
            continue
        try:
            payload = reply.ok.payload.to_bytes()
            term = msgspec.json.decode(payload, type=messages.Term).term
        except msgspec.DecodeError:
            continue
        found.append((str(reply.ok.key_expr), term))
    return found


class SharedState:
    """The newest state a standby holds, and how it keeps it current.

    Attributes
    ----------
    config
        The settings records are applied with (None: whole snapshots
        only, no following).
    store
        Where the copy is saved (None: memory only).
    stored
        What this node holds of its own (its folder's, or its state when
        it stood down): told to peers when there is no copy.
    commanding
        Whether this node commands now (then it keeps and tells nothing).
    """

    def __init__(self) -> None:
        self.config: NodeConfig | None = None
        self.store: StandbyStore | None = None
        self.stored: bytes | None = None
        self.commanding = False
        self._lock = threading.Lock()
        self._snapshot: bytes | None = None
        self._rank = (-1, -1)
        self._tag: Tag | None = None
        self._rebase = False
        self._follower: Follower | None = None
        self._followed: Tag | None = None
        self._changes: deque[bytes] = deque()
        self._held: list[messages.Changes] = []
        #: The last record applied that the commander waits on (to save,
        #: then say so on ``scheduler/saved``).
        self.confirm_due: Tag | None = None

    def keep(
        self, payload: bytes, rank: tuple[int, int], tag: Tag | None = None
    ) -> None:
        """A believed state: kept if it is the newest (the higher term,
        then more inputs), as the base records are applied to."""
        with self._lock:
            if rank < self._rank:
                return
            self._snapshot, self._rank = payload, rank
            self._tag, self._rebase = tag, True
        if not self.commanding:
            self.stored = payload
            if self.store is not None:
                self.store.offer(lambda: payload)  # saved by the loop

    def on_changes(self, payload: bytes) -> None:
        """A ``scheduler/changes`` message (from a callback: kept only)."""
        with self._lock:
            if len(self._changes) >= MAX_CHANGES_WAITING:
                # Too far behind: start again from a snapshot.
                self._changes.clear()
                self._held.clear()
            self._changes.append(payload)

    def follow(self) -> bool:
        """Apply the records received to the copy (from the loop); True
        if one is missing (ask the commander for its state again)."""
        with self._lock:
            rebase, self._rebase = self._rebase, False
            base, tag = self._snapshot, self._tag
            waiting = list(self._changes)
            self._changes.clear()
        if rebase:
            self._follower, self._followed = None, None
            if base is not None and tag is not None and self.config:
                try:
                    state = msgspec.json.decode(base, type=EngineSnapshot)
                    self._follower = Follower(self.config, state)
                    self._followed = tag
                except (msgspec.DecodeError, ValueError) as error:
                    log.error("unusable shared state: %s", error)
        for payload in waiting:
            try:
                self._held.append(
                    msgspec.json.decode(payload, type=messages.Changes)
                )
            except msgspec.DecodeError:
                continue
        follower, followed = self._follower, self._followed
        if follower is None or followed is None:
            del self._held[:-MAX_CHANGES_WAITING]
            return False
        stream, seq = followed
        applied = False
        held, self._held = sorted(self._held, key=lambda c: c.seq), []
        for change in held:
            if change.stream == stream and change.seq <= seq:
                continue  # in the base already
            if change.stream != stream or change.seq != seq + 1:
                # Another stream's (a newer commander), or after a gap.
                self._held.append(change)
                continue
            for key, record in change.records:
                follower.apply(key, bytes(record))
            seq, applied = change.seq, True
            if change.confirm:
                self.confirm_due = (stream, seq)
        del self._held[:-MAX_CHANGES_WAITING]
        self._followed = (stream, seq)
        if applied:
            engine = follower.engine
            with self._lock:
                self._rank = (engine.term, engine.inputs_seen)
            if self.store is not None and not self.commanding:
                self.store.offer(
                    lambda: msgspec.json.encode(engine.snapshot())
                )
        return any(c.stream == stream for c in self._held)

    def latest(self) -> EngineSnapshot | None:
        """The newest state held (None: none yet)."""
        if self._follower is not None:
            return self._follower.engine.snapshot()
        with self._lock:
            payload = self._snapshot
        if payload is None:
            return None
        try:
            return msgspec.json.decode(payload, type=EngineSnapshot)
        except msgspec.DecodeError as error:
            log.error("unusable snapshot from the active node: %s", error)
            return None

    def told(self) -> bytes | None:
        """What a peer that asks is told this node holds (None while it
        commands: the commander answers for itself)."""
        if self.commanding:
            return None
        if self._follower is not None:
            return msgspec.json.encode(self._follower.engine.snapshot())
        return self.stored

    def save(self, force: bool = False) -> None:
        """Write the copy to the folder when due (see
        :class:`~fsw_scheduler.journal.state.StandbyStore`)."""
        if self.store is not None and not self.commanding:
            # A record the commander waits on is saved at once.
            force = force or self.confirm_due is not None
            self.store.save_due(time.monotonic(), force)
