"""One commander per spacecraft: redundant schedulers, fenced by terms.

Spacecraft fly redundant computers, so two schedulers may run for one
spacecraft; only one may command it. Each node declares a liveliness token
``scheduler/nodes/<rank>/<started>/<node id>``; the one that commands also
declares ``scheduler/active/<term>/<rank>/<started>/<node id>``. The rules,
the same on every node so that they agree without talking:

* **Terms.** A node that begins to command (first start, resume, takeover,
  or again after standing down) does so in a new *term*, one above the
  highest it has verified (:mod:`fsw_scheduler.wire.terms`): its own
  folder's, the members' tokens and stored states (``scheduler/stored``),
  the receivers' fences (``scheduler/fences``), the states shared with
  it; a term beyond the bound is ignored. It commands from the newest
  state it can get; one older than a term in use, with an alarm saying
  what was lost. The term is journaled (and synced)
  before the node commands, and stamped on every plan, dispatch and
  status; receivers fence: they ignore anything from a lower term than
  the highest seen.
* **Election.** A starting node first looks for ``discovery`` seconds. If
  a node is active, it stands by. If none is, the best member commands:
  lowest rank, then earliest start, then smallest id (:func:`order`). A
  best member that does not become active within :data:`PASS_OVER_S`
  (dead, stuck, or a forged token) is passed over for the next one.
* **Standby.** A standby publishes ``state: standby`` on
  ``scheduler/status`` (naming the active node) and follows the active
  node's state (:mod:`fsw_scheduler.bus.standby`): a snapshot, then the
  records of each step (``scheduler/changes``) before its outputs, kept
  in its own folder too. When the active token disappears (the process
  died, or its link: Zenoh notices a closed link at once and a silent one
  after its lease), the best remaining member takes over from the newest
  state it holds, in a new term, and publishes ``event: took_over``. A
  node with no link to the bus at all does not take over: it cannot know
  that the active node is gone.
* **Newest state wins.** Two active nodes (a partition healed) see each
  other's tokens; the one with the higher term stays (it took over from
  the other: its state is newer), then the better order. The other
  stands down, says ``stood_down`` and hands over what the winner lacks.
* **Leases** (:mod:`fsw_scheduler.bus.lease`): a commanding node whose own
  view of the bus had a gap longer than half the Zenoh lease but shorter
  than the lease asks the bus who commands and goes on if no one else
  does; a longer gap, or the loss of every link once others were seen,
  makes it stop commanding before its next output, stand down and
  re-verify: after ``discovery`` seconds it commands again, in a new
  term, only if no one else does.

Takeover time is the link-loss detection plus one pass of this loop
(:data:`POLL_S`), measured on separate processes through a router.
"""

from __future__ import annotations

import contextlib
import logging
import queue
import threading
import time
from typing import TYPE_CHECKING, Any, Protocol

import msgspec
import zenoh

from ..errors import FieldIssue
from ..wire import messages, topics
from ..wire.terms import MAX_TERM, term_refused
from .confirm import say_saved
from .fenced import FenceWatch, tie_alarm
from .handover import stand_down, tell_lost
from .lease import has_links
from .members import Member, beats, order, precedence
from .members import default_node_id as default_node_id  # its old home
from .standby import SharedState, Tag, fence_terms, tag_of
from .standing import FENCE

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..engine.snapshot import EngineSnapshot
    from .lease import Lease
    from .node import SchedulerNode

log = logging.getLogger("fsw_scheduler.redundancy")

#: Seconds between checks of the membership while nothing changes.
POLL_S = 0.1
#: Seconds a best member may stay inactive, with no one commanding,
#: before the next one takes its place.
PASS_OVER_S = 3.0
#: Seconds no one must be seen commanding, with a link all along, before a
#: node takes command: Zenoh may drop the tokens of a closed link before
#: it drops the link, and a blind node must not read that as a death.
CONFIRM_S = 0.3
JSON = zenoh.Encoding.APPLICATION_JSON


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
        #: Active members and the term each commands in.
        self.actives: dict[Member, int] = {}
        #: The highest term verified: this node's own, or a member's
        #: (an active token with its member token, a state it shared);
        #: a term further above it than the bound is not believed
        #: (:mod:`fsw_scheduler.wire.terms`).
        self.max_term = 0
        #: Tokens, terms and states refused (out of range, a jump beyond
        #: the bound), each also logged once.
        self.refused = 0
        self._refused_said: set[str] = set()
        #: Whether another scheduler was ever seen: from then on, this
        #: node commands only while it has a link to the bus.
        self.seen_others = False
        self.fence_max = -1  # the highest term a fence answered
        self.changes: queue.Queue[None] = queue.Queue()
        self._lock = threading.Lock()
        #: The state shared with this node, followed and kept
        #: (:mod:`~fsw_scheduler.bus.standby`).
        self.shared = SharedState()
        self._entities: list[object] = []
        self._active_token: object | None = None
        self._stored_queries: Any = None

    # -- membership ----------------------------------------------------------

    def join(self) -> None:
        """Declare this node and watch the others (with their history)."""
        key = self.topics.key
        liveliness = self.session.liveliness()
        for suffix in (topics.NODES, topics.ACTIVE):
            self._entities.append(
                liveliness.declare_subscriber(
                    key(f"{suffix}/**"), self._on_token(suffix), history=True
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
        self._entities.append(
            self.session.declare_subscriber(
                key(topics.CHANGES), self._on_changes
            )
        )
        # Answered from the election's loop (:meth:`answer`), not here.
        self._stored_queries = self.session.declare_queryable(
            key(f"{topics.STORED}/{self.me.chunks}"),
            zenoh.handlers.FifoChannel(16),
        )
        self._entities.append(self._stored_queries)

    def refresh(self, timeout: float = 2.0) -> None:
        """Ask the bus which tokens exist now (a liveliness query: the
        answer is complete when it returns), after a time without links."""
        for suffix in (topics.NODES, topics.ACTIVE):
            learn = self._on_token(suffix)
            try:
                replies = self.session.liveliness().get(
                    self.topics.key(f"{suffix}/**"), timeout=timeout
                )
                for reply in replies:
                    if reply.ok is not None:
                        learn(reply.ok)
            except zenoh.ZError as error:
                log.warning("asking for the members: %s", error)

    def _on_token(self, suffix: str) -> Callable[[zenoh.Sample], None]:
        head = self.topics.key(suffix) + "/"
        active = suffix == topics.ACTIVE

        def callback(sample: zenoh.Sample) -> None:
            tail = str(sample.key_expr).removeprefix(head)
            term = 0
            if active:
                first, _, tail = tail.partition("/")
                try:
                    term = int(first)
                except ValueError:
                    return
            member = Member.parse(tail)
            if member is None or member.rank < 0:
                return  # not a token a scheduler declares
            put = sample.kind == zenoh.SampleKind.PUT
            with self._lock:
                if not active:
                    (self.members.add if put else self.members.discard)(member)
                    self.seen_others |= member != self.me
                    if put and member in self.actives:
                        # Its member token came after its active one.
                        self._verify(self.actives[member])
                elif put:
                    refused = term_refused(term, self.max_term)
                    if refused is not None:
                        # Never a commander: no one stands down for it.
                        self._refuse(str(sample.key_expr), refused)
                        return
                    self.actives[member] = term
                    if member in self.members:
                        self._verify(term)
                else:
                    self.actives.pop(member, None)
            self.changes.put(None)

        return callback

    def _verify(self, term: int) -> None:
        """A member's term: the highest verified rises (under the lock)."""
        self.max_term = max(self.max_term, term)

    def _refuse(self, what: str, why: str) -> None:
        """Count a token, term or state not believed; say it once."""
        self.refused += 1
        if what not in self._refused_said and len(self._refused_said) < 64:
            self._refused_said.add(what)
            log.warning("ignored %s: %s", what[:200], why)

    def _on_snapshot(self, sample: zenoh.Sample) -> None:
        # Callbacks only keep bytes: decoding waits for the loop.
        self._keep_snapshot(sample.payload.to_bytes(), tag_of(sample))

    def _on_changes(self, sample: zenoh.Sample) -> None:
        self.shared.on_changes(sample.payload.to_bytes())
        self.changes.put(None)  # the loop applies it now: no poll wait

    def _keep_snapshot(self, payload: bytes, tag: Tag | None = None) -> None:
        try:
            head = msgspec.json.decode(payload)
            term, inputs = head.get("term", 0), head.get("inputs", 0)
        except (msgspec.DecodeError, AttributeError, TypeError, ValueError):
            return
        with self._lock:
            refused = term_refused(term, self.max_term)
            if refused is None and term > self.max_term:
                # A state is shared by a commander whose term this node
                # has verified; a higher one is anyone's number.
                refused = (
                    f"term {term} is above every verified term "
                    f"({self.max_term})"
                )
            if refused is None and not (
                isinstance(inputs, int) and inputs >= 0
            ):
                refused = f"inputs {inputs!r} is not a count"
            if refused is not None:
                self._refuse(f"a shared state of term {term!r}", refused)
                return
        self.shared.keep(payload, (term, inputs), tag)

    def follow(self) -> None:
        """Bring the copy up to date (from the election's loop); after a
        missing record, ask the commander for its whole state."""
        if self.shared.follow():
            self.ask_snapshot()

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
                    self._keep_snapshot(
                        reply.ok.payload.to_bytes(), tag_of(reply.ok)
                    )
                    got = True
        except zenoh.ZError as error:
            log.warning("asking for the active node's state: %s", error)
        return got

    def hold(self, state: EngineSnapshot) -> None:
        """This node's own state (its folder's, read at start): its term
        is verified, and it is what peers are told this node holds."""
        payload = msgspec.json.encode(state)
        with self._lock:
            self._verify(state.term)
        self.shared.keep(payload, (state.term, state.inputs))

    def answer(self) -> None:
        """Answer the peers that asked for this node's stored state (from
        the election's loop: no Zenoh call in a callback)."""
        queries = self._stored_queries
        if queries is None:
            return
        while True:
            try:
                query = queries.try_recv()
            except zenoh.ZError:
                return
            if query is None:
                return
            try:
                stored = self.shared.told()
                if stored is not None:
                    query.reply(
                        self.topics.key(f"{topics.STORED}/{self.me.chunks}"),
                        stored,
                        encoding=JSON,
                    )
            except zenoh.ZError as error:
                log.warning("answering a peer: %s", error)
            finally:
                query.drop()

    def ask_peers(self, timeout: float = 1.0) -> None:
        """Before commanding: learn the highest term in use and the
        newest state, from the other members' stored states and from the
        receivers' fences (an open bus; the secure profile lets only the
        scheduler role answer on ``scheduler/**``)."""
        head = self.topics.key(topics.STORED) + "/"
        try:
            replies = list(
                self.session.get(
                    self.topics.key(f"{topics.STORED}/**"),
                    timeout=timeout,
                    # Its own queryable waits for this thread: not asked.
                    allowed_destination=zenoh.Locality.REMOTE,
                )
            )
        except zenoh.ZError as error:
            log.warning("asking the members' states: %s", error)
            replies = []
        for reply in replies:
            if reply.ok is None:
                continue
            member = Member.parse(str(reply.ok.key_expr).removeprefix(head))
            if member is not None and member != self.me:
                self._keep_stored(member, reply.ok.payload.to_bytes())
        for where, term in fence_terms(self.session, self.topics, timeout):
            with self._lock:
                refused = term_refused(term, self.max_term)
                if refused is None:
                    # A receiver saw it stamped on a command: in use.
                    self._verify(term)
                    self.fence_max = max(self.fence_max, term)
                else:
                    self._refuse(where, refused)

    def _keep_stored(self, member: Member, payload: bytes) -> None:
        """A member's stored state: believed within the bound (it may be
        of a term no token shows now: both computers were reset)."""
        try:
            head = msgspec.json.decode(payload)
            term, inputs = head.get("term", 0), head.get("inputs", 0)
        except (msgspec.DecodeError, AttributeError, TypeError, ValueError):
            return
        with self._lock:
            if member not in self.members:
                self._refuse(f"the state of {member.node_id}", "no member")
                return
            refused = term_refused(term, self.max_term)
            if refused is None and not (
                isinstance(inputs, int) and inputs >= 0
            ):
                refused = f"inputs {inputs!r} is not a count"
            if refused is not None:
                self._refuse(f"the state of {member.node_id}", refused)
                return
            self._verify(term)
        self.shared.keep(payload, (term, inputs))

    def vouched(self) -> int:
        """The highest term a receiver's fence answered (-1: none); any,
        once another scheduler was seen (its state decides then)."""
        return MAX_TERM if self.seen_others else self.fence_max

    def latest_snapshot(self) -> EngineSnapshot | None:
        """The newest state the active node shared (None: none yet)."""
        self.follow()
        return self.shared.latest()

    # -- the election --------------------------------------------------------

    def has_peers(self) -> bool:
        """Whether another scheduler of the spacecraft is there (a standby
        to share the state with)."""
        with self._lock:
            return any(m != self.me for m in self.members)

    def view(self) -> tuple[set[Member], dict[Member, int]]:
        """Members (this node included) and active members with their
        terms, as seen now."""
        with self._lock:
            return set(self.members) | {self.me}, dict(self.actives)

    def commander(self) -> tuple[Member, int] | None:
        """The active member that should command, with its term: the
        highest term, then the best order (None: no one is active)."""
        members, actives = self.view()
        # An active token without its member token is not a scheduler's
        # (a forgery, or a node half gone): it commands nothing.
        actives = {m: t for m, t in actives.items() if m in members}
        if not actives:
            return None
        best = min(actives, key=lambda m: precedence(m, actives[m]))
        return best, actives[best]

    def candidate(self, idle_s: float) -> Member:
        """Who should take command when no one has for ``idle_s`` seconds:
        the best member, or the next one for each :data:`PASS_OVER_S`
        the ones before it let pass."""
        members, _ = self.view()
        ranked = sorted(members, key=order)
        return ranked[min(int(idle_s // PASS_OVER_S), len(ranked) - 1)]

    def declare_active(self, term: int) -> None:
        """Say that this node commands now, in ``term``."""
        self.withdraw_active()
        self._active_token = self.session.liveliness().declare_token(
            self.topics.key(f"{topics.ACTIVE}/{term}/{self.me.chunks}")
        )
        with self._lock:
            self.max_term = max(self.max_term, term)

    def withdraw_active(self) -> None:
        """Stop saying that this node commands."""
        token, self._active_token = self._active_token, None
        if token is not None:
            _undeclare(token)

    def publish_standby(
        self,
        active: Member | None,
        event: str = "standby",
        detail: str = "",
    ) -> None:
        """``state: standby`` on the status key, naming the active node
        (``event``: ``standby``, or ``stood_down`` with the reason)."""
        snapshot = self.latest_snapshot()
        following = f"following {active.node_id}" if active else ""
        status = messages.Status(
            state="standby",
            plan_id=snapshot.plan_id if snapshot else None,
            now=snapshot.now if snapshot else None,
            event=event,
            detail="; ".join(
                d for d in (detail, following or "no active node") if d
            ),
            active=active.node_id if active else None,
            node_id=self.me.node_id,
            term=snapshot.term if snapshot else 0,
        )
        self._say(status)

    def publish_lost_goal(
        self, goal_id: str, term: int, winner: Member | None, now_term: int
    ) -> None:
        """``goal_rejected`` for a goal this node took in ``term`` that the
        commander which outranks it does not have: send it again. Stamped
        with the winner's term, ``now_term``, so that fencing receivers
        hear it."""
        reason = (
            f"accepted in term {term} by {self.me.node_id}, which stood "
            f"down; the commander "
            f"{winner.node_id if winner else ''} does not hold it: send "
            "the goal again"
        )
        status = messages.Status(
            state="standby",
            plan_id=None,
            event="goal_rejected",
            goal_id=goal_id,
            errors=(FieldIssue("", reason),),
            detail=f"goal {goal_id} lost at a partition",
            active=winner.node_id if winner else None,
            node_id=self.me.node_id,
            term=now_term,
        )
        self._say(status)

    def hand_over(self, facts: messages.Facts) -> None:
        """Publish what this node commanded for the commander that
        outranks it to merge (``scheduler/facts``, see
        :mod:`fsw_scheduler.engine.merge`)."""
        if not (facts.facts or facts.goals):
            return
        try:
            self.session.put(
                self.topics.key(topics.FACTS),
                messages.encode(facts),
                encoding=JSON,
                congestion_control=zenoh.CongestionControl.BLOCK,
            )
        except zenoh.ZError as error:
            log.warning("facts: %s", error)

    def publish_alarm(self, node: SchedulerNode, alarm: str) -> None:
        """``alarm`` (state ``degraded``) from the commanding ``node`` (a
        receiver's fence above its term, :mod:`.fenced`; another commander
        met in the same term)."""
        log.error("%s", alarm)
        engine = node.engine
        self._say(
            messages.Status(
                state="degraded",
                plan_id=engine.plan_id,
                now=engine.now,
                event="alarm",
                detail=alarm,
                node_id=self.me.node_id,
                term=node.term,
            )
        )

    def _say(self, status: messages.Status) -> None:
        """Publish a status of this node (not commanding: no journal)."""
        try:
            self.session.put(
                self.topics.key(topics.STATUS),
                messages.encode(status),
                encoding=JSON,
            )
        except zenoh.ZError as error:
            log.warning("status %s: %s", status.event, error)

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


class MakeNode(Protocol):
    """Builds the node that commands (see :func:`serve`)."""

    def __call__(
        self,
        state: EngineSnapshot | None,
        event: str,
        term_floor: int,
        on_term: Callable[[int], None],
    ) -> SchedulerNode: ...


def serve(
    redundancy: Redundancy,
    make_node: MakeNode,
    stop: threading.Event,
    discovery_s: float,
    lease: Callable[[], Lease] | None = None,
    settle_s: float = 0.0,
) -> SchedulerNode | None:
    """Command or stand by until ``stop``; returns the last node run.

    Parameters
    ----------
    redundancy
        This node's membership (joined).
    make_node
        Builds the scheduler node when this one must command: from a
        state (the newest shared one on a takeover, its own after standing
        down; None: its own journal or problem), with the status event it
        says first (``took_over``, ``resumed``), above ``term_floor``, and
        calling ``on_term(term)`` once its term is on disk.
    stop
        Set to stop (signals).
    discovery_s
        How long to look for other schedulers first, and again after
        standing down.
    lease
        Builds the lease a commanding node keeps (None: none).
    settle_s
        After a time without any link, how long a standby watches the bus
        again before it may take command (the Zenoh lease: a router that
        restarts meshes with the others within it, and a commander seen
        through it then is no commander lost).
    """
    _look(stop, discovery_s, redundancy)
    boot = redundancy.latest_snapshot()  # this node's folder, if any
    followed = False  # whether it stood by for a commander it saw
    node: SchedulerNode | None = None
    standing_by_for: Member | bool | None = False
    own: EngineSnapshot | None = None  # this node's state, stood down
    reason = ""  # why this node stood down, until it has said so
    idle_since = time.monotonic()
    hold_until = 0.0  # no command before (monotonic seconds)
    seen_commander = False
    tied: set[Member] = set()  # commanders met in this node's term
    isolated = False
    while not stop.is_set():
        if node is None and redundancy.seen_others:
            if not has_links(redundancy.session):
                # Blind: the pass-over clock stops; nothing is decided.
                isolated, idle_since = True, time.monotonic()
            elif isolated:
                # Back on the bus: learn who commands before deciding.
                isolated = False
                idle_since = _reverify(stop, redundancy, discovery_s)
                hold_until = idle_since + settle_s
                continue
        current = redundancy.commander()
        if current is not None:
            idle_since = time.monotonic()
        elif seen_commander:
            # The commander vanished: confirm it, links and all.
            hold_until = max(hold_until, time.monotonic() + CONFIRM_S)
        seen_commander = current is not None
        if (
            node is None
            and current is None
            and time.monotonic() >= hold_until
            and _may_command(redundancy, time.monotonic() - idle_since)
        ):
            # The highest term in use and the newest state, first.
            redundancy.ask_peers(max(1.0, discovery_s))
            state, event = _newest(redundancy, own, followed)
            log.info(
                "commanding %s%s",
                redundancy.topics.root,
                f" ({event})" if state is not None else "",
            )
            redundancy.shared.commanding = True
            node = make_node(
                state, event, redundancy.max_term, redundancy.declare_active
            )
            if lease is not None:
                node.lease = lease().start()
                node.reverify = _recheck(redundancy, node)
            node.start()
            fences = FenceWatch(redundancy.session, redundancy.topics)
            own = boot = None
        elif node is not None and current is not None:
            other, term = current
            # This node's own token may not be seen yet: compare terms.
            if other != redundancy.me and beats(
                (other, term), (redundancy.me, node.term)
            ):
                # A lease that ended is the cause; the other commander is
                # what this node sees of it.
                lost = node.lease.lost() if node.lease is not None else None
                own = stand_down(
                    redundancy,
                    node,
                    other,
                    f"{lost}; {other.node_id} commands in term {term}"
                    if lost
                    else f"{other.node_id} commands in term {term} (this "
                    f"node: {node.term})",
                )
                node, standing_by_for = None, other
            elif (tie := tie_alarm(redundancy, node.term, tied)) is not None:
                redundancy.publish_alarm(node, tie)
        if node is not None and node.stood_down is not None:
            # Said once the bus is seen again: the link may be down now.
            reason = node.stood_down
            own = stand_down(redundancy, node, None, None)
            node, standing_by_for = None, False
            idle_since = _reverify(stop, redundancy, discovery_s)
            continue
        if node is None:
            current = redundancy.commander()
            active = current[0] if current else None
            # A stand-down is said once a link is there to carry it.
            say = reason if reason and has_links(redundancy.session) else ""
            confirming = active is None and time.monotonic() < hold_until
            if (active != standing_by_for and not confirming) or say:
                if active is not None:
                    followed = True
                    redundancy.ask_snapshot()
                    if boot is not None:
                        # Started with a state of its own, and someone
                        # commands: goals it alone holds are lost.
                        tell_lost(redundancy, boot, active)
                        boot = None
                redundancy.publish_standby(
                    active, "stood_down" if say else "standby", say
                )
                reason = "" if say else reason
                log.info(
                    "standing by%s",
                    f" for {active.node_id}" if active else "",
                )
                standing_by_for = active
            redundancy.follow()
            redundancy.shared.save()
            say_saved(
                redundancy.session,
                redundancy.topics,
                redundancy.me.node_id,
                redundancy.shared,
            )
        elif node.wait_stopped(0):
            break  # the node's loop died: let a supervisor restart us
        else:
            if (alarm := fences.check(node.term)) is not None:
                redundancy.publish_alarm(node, alarm)
            # A status query names it for as long as the last answer did.
            node.standing.put(FENCE, fences.standing)
        redundancy.answer()
        with contextlib.suppress(queue.Empty):
            redundancy.changes.get(timeout=POLL_S)
    redundancy.shared.save(force=True)
    return node


def _recheck(
    redundancy: Redundancy, node: SchedulerNode
) -> Callable[[], str | None]:
    """What a commander asks after a stall under the lease: does another
    commander outrank it now? (None: no, it goes on in its term.)"""

    def check() -> str | None:
        redundancy.refresh(1.0)
        current = redundancy.commander()
        if current is None:
            return None
        other, term = current
        if other != redundancy.me and beats(
            (other, term), (redundancy.me, node.term)
        ):
            return f"{other.node_id} commands in term {term}"
        return None

    return check


def _reverify(
    stop: threading.Event, redundancy: Redundancy, discovery_s: float
) -> float:
    """Learn who commands before deciding (back on the bus, or after
    standing down): watch, then ask the bus; the new idle clock start."""
    _look(stop, discovery_s, redundancy)
    redundancy.refresh(max(1.0, discovery_s))
    return time.monotonic()


def _look(
    stop: threading.Event, seconds: float, redundancy: Redundancy
) -> None:
    """Watch the membership for ``seconds`` (tokens arrive meanwhile),
    answering the peers that ask what this node holds."""
    deadline = time.monotonic() + seconds
    while not stop.is_set() and time.monotonic() < deadline:
        redundancy.answer()
        stop.wait(min(POLL_S, max(deadline - time.monotonic(), 0)))


def _may_command(redundancy: Redundancy, idle_s: float) -> bool:
    """No one commands: is it this node's turn, and can it see the bus?"""
    if redundancy.candidate(idle_s) != redundancy.me:
        return False
    # Once others were seen, a node without any link cannot tell that they
    # stopped commanding, only that it lost them: it waits for the bus.
    return not redundancy.seen_others or has_links(redundancy.session)


def _newest(
    redundancy: Redundancy, own: EngineSnapshot | None, followed: bool
) -> tuple[EngineSnapshot | None, str]:
    """The state to command from: the newest of the shared one (or a
    member's stored one, or this node's folder's) and this node's own
    (after standing down), with the event to say first: ``took_over``
    by a node that followed a commander, else ``resumed``."""
    shared = redundancy.latest_snapshot()
    if own is not None and (
        shared is None
        or (own.term, own.inputs) >= (shared.term, shared.inputs)
    ):
        return own, "resumed"
    return shared, "took_over" if followed else "resumed"
