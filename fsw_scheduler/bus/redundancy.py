"""One commander per spacecraft: redundant schedulers and a hot standby.

Spacecraft fly redundant computers, so two schedulers may run for one
spacecraft; only one may command it. Each node declares a liveliness token
``scheduler/nodes/<rank>/<started>/<node id>``; the one that commands also
declares ``scheduler/active/<rank>/<started>/<node id>``. The rules, the
same on every node so that they agree without talking:

* A starting node first looks for ``discovery`` seconds. If a node is
  active, it stands by. If none is, the best member commands: lowest rank,
  then earliest start, then smallest id (:func:`order`); the others stand
  by. Two nodes started at the same moment see each other during that
  look and make the same choice.
* A standby publishes ``state: standby`` on ``scheduler/status`` (naming
  the active node) and follows the active node's state: the active node
  publishes its engine snapshot on ``scheduler/snapshot`` before the
  outputs of every step, so the standby's copy never lags behind what the
  bus has seen.
* When the active token disappears (the process died, or its link: Zenoh
  notices a closed link at once and a silent one after its lease), the
  best remaining member takes over from the last snapshot it received,
  with the next ``plan_id``, asks again for a solve that was in flight,
  and publishes ``event: took_over``.
* Two active nodes (a partition healed, or a node started with the
  protocol off) see each other's active token; the worse one stands down.

Takeover time is the link-loss detection plus one pass of this loop
(:data:`POLL_S`); the tests measure it on separate processes through a
router.
"""

from __future__ import annotations

import contextlib
import logging
import os
import queue
import socket
import threading
import time
from typing import TYPE_CHECKING, NamedTuple

import msgspec
import zenoh

from ..engine.snapshot import EngineSnapshot
from ..wire import messages, topics

if TYPE_CHECKING:
    from collections.abc import Callable

    from .node import SchedulerNode

log = logging.getLogger("fsw_scheduler.redundancy")

#: Seconds between checks of the membership while nothing changes.
POLL_S = 0.1
JSON = zenoh.Encoding.APPLICATION_JSON


class Member(NamedTuple):
    """One scheduler of the spacecraft, as its tokens name it."""

    rank: int
    started_ns: int
    node_id: str

    @property
    def chunks(self) -> str:
        """The key chunks ``<rank>/<started>/<node id>``."""
        return f"{self.rank}/{self.started_ns}/{self.node_id}"

    @classmethod
    def parse(cls, tail: str) -> Member | None:
        """From ``<rank>/<started>/<node id>``; None if malformed."""
        parts = tail.split("/")
        if len(parts) != 3:
            return None
        try:
            return cls(int(parts[0]), int(parts[1]), parts[2])
        except ValueError:
            return None


def order(member: Member) -> tuple[int, int, str]:
    """The election order: rank, then start time, then id (lowest wins)."""
    return (member.rank, member.started_ns, member.node_id)


def default_node_id() -> str:
    """``<host>-<pid>``, made key-safe."""
    host = "".join(
        c if c.isalnum() or c in "_.-" else "-" for c in socket.gethostname()
    )
    return f"{host or 'node'}-{os.getpid()}"


class Redundancy:
    """This node's membership: tokens, election, the standby's state copy.

    Parameters
    ----------
    session
        The node's Zenoh session.
    spacecraft
        Whose scheduler this is.
    me
        This node.
    """

    def __init__(
        self, session: zenoh.Session, spacecraft: str, me: Member
    ) -> None:
        self.session = session
        self.topics = topics.Topics(spacecraft)
        self.me = me
        self.members: set[Member] = set()
        self.actives: set[Member] = set()
        self.changes: queue.Queue[None] = queue.Queue()
        self._lock = threading.Lock()
        self._snapshot: bytes | None = None
        self._snapshot_inputs = -1
        self._entities: list[object] = []
        self._active_token: object | None = None

    # -- membership ----------------------------------------------------------

    def join(self) -> None:
        """Declare this node and watch the others (with their history)."""
        key = self.topics.key
        liveliness = self.session.liveliness()
        for suffix, into in (
            (topics.NODES, self.members),
            (topics.ACTIVE, self.actives),
        ):
            self._entities.append(
                liveliness.declare_subscriber(
                    key(f"{suffix}/**"),
                    self._on_token(suffix, into),
                    history=True,
                )
            )
        self._entities.append(
            liveliness.declare_token(key(f"{topics.NODES}/{self.me.chunks}"))
        )
        self._entities.append(
            self.session.declare_subscriber(
                key(topics.SNAPSHOT), self._on_snapshot
            )
        )

    def _on_token(
        self, suffix: str, into: set[Member]
    ) -> Callable[[zenoh.Sample], None]:
        head = self.topics.key(suffix) + "/"

        def callback(sample: zenoh.Sample) -> None:
            member = Member.parse(str(sample.key_expr).removeprefix(head))
            if member is None:
                return
            with self._lock:
                if sample.kind == zenoh.SampleKind.PUT:
                    into.add(member)
                else:
                    into.discard(member)
            self.changes.put(None)

        return callback

    def _on_snapshot(self, sample: zenoh.Sample) -> None:
        # Callbacks only keep bytes: decoding waits for a takeover.
        self._keep_snapshot(sample.payload.to_bytes())

    def _keep_snapshot(self, payload: bytes) -> None:
        try:
            inputs = int(msgspec.json.decode(payload).get("inputs", 0))
        except (msgspec.DecodeError, AttributeError, TypeError, ValueError):
            return
        with self._lock:
            if inputs >= self._snapshot_inputs:
                self._snapshot, self._snapshot_inputs = payload, inputs

    def ask_snapshot(self, timeout: float = 2.0) -> bool:
        """Ask the active node for its state now; True if one came.

        Shared snapshots come with the active node's steps; a standby that
        joins between two of them asks, so that it never takes over
        without the state.
        """
        got = False
        try:
            for reply in self.session.get(
                self.topics.key(topics.SNAPSHOT), timeout=timeout
            ):
                if reply.ok is not None:
                    self._keep_snapshot(reply.ok.payload.to_bytes())
                    got = True
        except zenoh.ZError as error:
            log.warning("asking for the active node's state: %s", error)
        return got

    def latest_snapshot(self) -> EngineSnapshot | None:
        """The newest state the active node shared (None: none yet)."""
        with self._lock:
            payload = self._snapshot
        if payload is None:
            return None
        try:
            return msgspec.json.decode(payload, type=EngineSnapshot)
        except msgspec.DecodeError as error:
            log.error("unusable snapshot from the active node: %s", error)
            return None

    # -- the election --------------------------------------------------------

    def has_peers(self) -> bool:
        """Whether another scheduler of the spacecraft is there (a standby
        to share the state with)."""
        with self._lock:
            return any(m != self.me for m in self.members)

    def view(self) -> tuple[set[Member], set[Member]]:
        """Members and active members seen now (this node included)."""
        with self._lock:
            return set(self.members) | {self.me}, set(self.actives)

    def leader(self) -> Member | None:
        """Who should command now (None: keep the current active one).

        The active node with the best order, if any; otherwise the best
        member.
        """
        members, actives = self.view()
        if actives:
            return min(actives, key=order)
        return min(members, key=order)

    def declare_active(self) -> None:
        """Say that this node commands now."""
        if self._active_token is None:
            self._active_token = self.session.liveliness().declare_token(
                self.topics.key(f"{topics.ACTIVE}/{self.me.chunks}")
            )

    def withdraw_active(self) -> None:
        """Stop saying that this node commands."""
        token, self._active_token = self._active_token, None
        if token is not None:
            _undeclare(token)

    def publish_standby(self, active: Member | None) -> None:
        """``state: standby`` on the status key, naming the active node."""
        snapshot = self.latest_snapshot()
        status = messages.Status(
            state="standby",
            plan_id=snapshot.plan_id if snapshot else None,
            now=snapshot.now if snapshot else None,
            event="standby",
            detail=(
                f"following {active.node_id}" if active else "no active node"
            ),
            active=active.node_id if active else None,
            node_id=self.me.node_id,
        )
        try:
            self.session.put(
                self.topics.key(topics.STATUS),
                messages.encode(status),
                encoding=JSON,
            )
        except zenoh.ZError as error:
            log.warning("standby status: %s", error)

    def close(self) -> None:
        """Withdraw every token and subscriber."""
        self.withdraw_active()
        for entity in reversed(self._entities):
            _undeclare(entity)
        self._entities.clear()


def _undeclare(entity: object) -> None:
    try:
        entity.undeclare()  # type: ignore[attr-defined]
    except zenoh.ZError as error:
        log.debug("undeclare: %s", error)


def serve(
    redundancy: Redundancy,
    make_node: Callable[[EngineSnapshot | None], SchedulerNode],
    stop: threading.Event,
    discovery_s: float,
) -> SchedulerNode | None:
    """Command or stand by until ``stop``; returns the last node run.

    Parameters
    ----------
    redundancy
        This node's membership (joined).
    make_node
        Builds the scheduler node when this one must command; given the
        active node's last shared state on a takeover (None otherwise).
    stop
        Set to stop (signals).
    discovery_s
        How long to look for other schedulers first.
    """
    deadline = time.monotonic() + discovery_s
    while not stop.is_set() and time.monotonic() < deadline:
        stop.wait(min(POLL_S, max(deadline - time.monotonic(), 0)))
    node: SchedulerNode | None = None
    standing_by_for: Member | bool | None = False
    was_standby = False
    while not stop.is_set():
        leader = redundancy.leader()
        if node is None and leader == redundancy.me:
            snapshot = redundancy.latest_snapshot() if was_standby else None
            log.info(
                "commanding %s%s",
                redundancy.topics.root,
                " (taking over)" if snapshot is not None else "",
            )
            redundancy.declare_active()
            node = make_node(snapshot)
            node.start()
        elif node is not None and leader not in (redundancy.me, None):
            _, actives = redundancy.view()
            if leader in actives:
                log.warning(
                    "another active scheduler (%s) outranks this one: "
                    "standing by",
                    leader.node_id,
                )
                node.close()
                node = None
                redundancy.withdraw_active()
        if node is None:
            _, actives = redundancy.view()
            active = min(actives, key=order) if actives else None
            if active != standing_by_for:
                if active is not None:
                    redundancy.ask_snapshot()
                redundancy.publish_standby(active)
                log.info(
                    "standing by%s",
                    f" for {active.node_id}" if active else "",
                )
                standing_by_for = active
            was_standby = True
        elif node.wait_stopped(0):
            break  # the node's loop died: let a supervisor restart us
        with contextlib.suppress(queue.Empty):
            redundancy.changes.get(timeout=POLL_S)
    return node
