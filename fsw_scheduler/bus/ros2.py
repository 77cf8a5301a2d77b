"""The scheduler's plan, status and dispatches as ROS 2 topics (rmw_zenoh).

rmw_zenoh, the Zenoh middleware of ROS 2 and Space ROS, carries a topic on
the key ``<domain>/<topic>/<DDS type>/<type hash>`` with CDR payloads, and
announces publishers with ``@ros2_lv/...`` liveliness tokens, from which
``ros2 topic list`` builds the graph. :class:`Ros2Bridge` subscribes to the
scheduler's own keys (:mod:`fsw_scheduler.wire.topics`) and republishes
each message, unchanged, as the ``data`` of a ``std_msgs/msg/String``:
the JSON a ROS 2 user reads with ``ros2 topic echo``.

The key expressions, liveliness tokens, type hash, QoS string and sample
attachment come from zenoh-ros2-sdk (``keyexpr``, ``entity``, ``utils``,
``qos``, ``attachment``) and the CDR encoding from its codec, rosbags.
The bridge does not use the SDK's ``ROS2Publisher``: that class opens a
process-wide ``ZenohSession`` singleton configured only by a router
address and environment variables, so it could not take the Zenoh flags of
the other commands (mode, listen, ``--cfg``, a JSON5 file, TLS), and it
resolves a type without a definition through the SDK's message registry,
which clones message repositories from GitHub. Here the bridge owns its
session, and the one definition it needs is shipped in the package
(``fsw_scheduler/data/ros2``) and registered offline: nothing is fetched
at run time.

The bridge is read-only toward the scheduler: it declares subscribers on
the scheduler's keys and publishers only under the ROS 2 domain's keys.
"""

from __future__ import annotations

import logging
import re
import time
import uuid
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

import zenoh
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from zenoh_ros2_sdk.attachment import Attachment
from zenoh_ros2_sdk.entity import EndpointEntity, EntityKind, NodeEntity
from zenoh_ros2_sdk.keyexpr import (
    endpoint_liveliness_keyexpr,
    node_liveliness_keyexpr,
    topic_keyexpr,
)
from zenoh_ros2_sdk.qos import (
    DEFAULT_QOS_PROFILE,
    QosDurability,
    QosProfile,
)
from zenoh_ros2_sdk.utils import (
    get_type_hash,
    resolve_domain_id,
    ros2_to_dds_type,
)

from ..errors import BusError
from ..wire import topics as keys

if TYPE_CHECKING:
    import threading
    from collections.abc import Callable

__all__ = [
    "NODE_NAME",
    "STRING_TYPE",
    "BridgeStats",
    "BridgedTopic",
    "Ros2Bridge",
    "StringCodec",
    "bridged_topics",
    "definitions_dir",
    "message_definition",
    "ros_name_token",
]

log = logging.getLogger(__name__)

#: The one ROS 2 type the bridge publishes.
STRING_TYPE = "std_msgs/msg/String"
#: The bridge's ROS 2 node name (in the namespace ``/fsw/<spacecraft>``).
NODE_NAME = "scheduler_bridge"
#: Samples held per scheduler key between two turns of the loop; past it
#: the oldest go (a ring: the bridge never holds Zenoh's network thread).
DEFAULT_CAPACITY = 256
#: (ROS 2 topic leaf, scheduler key suffix to subscribe to, latest
#: state): plan and status are states, a subscriber that starts late wants
#: the current one; dispatches are events.
_BRIDGED = (
    ("plan", keys.PLAN, True),
    ("status", keys.STATUS, True),
    ("dispatches", keys.DISPATCH + "/*", False),
)
#: The QoS of the latest-state topics, as rmw_zenoh reads it from the
#: liveliness token: reliable, transient local, keep last 1 (the publisher
#: keeps the latest sample for subscribers that start after it).
LATEST_QOS = QosProfile(
    durability=QosDurability.TRANSIENT_LOCAL, history_depth=1
)
#: The QoS of the event topics (dispatches): volatile, keep last 10.
EVENT_QOS = DEFAULT_QOS_PROFILE
_NOT_IN_NAME = re.compile(r"[^A-Za-z0-9_]")


def ros_name_token(text: str) -> str:
    """``text`` as one token of a ROS 2 name.

    ROS 2 name tokens hold letters, digits and underscores and do not
    start with a digit; any other character becomes ``_`` and a leading
    digit gets a ``_`` in front.

    Parameters
    ----------
    text
        A spacecraft id, e.g. ``sat-1``.

    Returns
    -------
    str
        A valid token, e.g. ``sat_1``.
    """
    token = _NOT_IN_NAME.sub("_", text) or "_"
    return "_" + token if token[0].isdigit() else token


@dataclass(frozen=True)
class BridgedTopic:
    """One scheduler key expression and the ROS 2 topic it appears on.

    Attributes
    ----------
    leaf
        Short name: ``plan``, ``status`` or ``dispatches``.
    key_expr
        The scheduler's Zenoh key expression, e.g. ``fsw/sat1/scheduler/plan``.
    ros_topic
        The ROS 2 topic, e.g. ``/fsw/sat1/scheduler/plan``.
    latest
        A latest-state topic (plan, status): transient local, depth 1
        (:data:`LATEST_QOS`); else volatile (:data:`EVENT_QOS`).
    """

    leaf: str
    key_expr: str
    ros_topic: str
    latest: bool = False


def bridged_topics(
    spacecraft: str = keys.DEFAULT_SPACECRAFT,
) -> tuple[BridgedTopic, ...]:
    """The topics the bridge republishes for one spacecraft.

    Parameters
    ----------
    spacecraft
        The scheduler's spacecraft id.

    Returns
    -------
    tuple of BridgedTopic
        Plan, status and dispatches (every ``scheduler/dispatch/<task>``
        on one ROS 2 topic, the task being in the message).
    """
    names = keys.Topics(spacecraft)
    namespace = ros_namespace(spacecraft)
    return tuple(
        BridgedTopic(
            leaf, names.key(suffix), f"{namespace}/scheduler/{leaf}", latest
        )
        for leaf, suffix, latest in _BRIDGED
    )


def ros_namespace(spacecraft: str) -> str:
    """``/fsw/<spacecraft token>``: the namespace of the bridge's names."""
    return f"/{keys.PREFIX}/{ros_name_token(spacecraft)}"


def message_definition(type_name: str) -> str:
    """The ``.msg`` text of a ROS 2 type shipped in the package.

    Parameters
    ----------
    type_name
        ``package/msg/Name``, e.g. ``std_msgs/msg/String``.

    Returns
    -------
    str
        The definition, read from ``fsw_scheduler/data/ros2``.

    Raises
    ------
    FileNotFoundError
        The package ships no such definition.
    """
    package, kind, name = type_name.split("/")
    path = definitions_dir() / package / kind / f"{name}.msg"
    return path.read_text(encoding="utf-8")


def definitions_dir() -> Path:
    """The folder of the ROS 2 definitions shipped in the package.

    Laid out as ``<package>/msg/<Name>.msg``, the layout zenoh-ros2-sdk's
    ``MessageRegistry(messages_dir)`` reads first: a Python ROS 2 client
    given this folder resolves the bridge's types without a download.

    Returns
    -------
    Path
        ``fsw_scheduler/data/ros2``.
    """
    return Path(str(resources.files("fsw_scheduler").joinpath("data", "ros2")))


class StringCodec:
    """CDR encoding of ``std_msgs/msg/String``, registered offline.

    The definition shipped in the package goes into a typestore of its
    own (rosbags, zenoh-ros2-sdk's codec), and the type hash is computed
    from it with the SDK's RIHS01 function, as rmw_zenoh does.
    """

    def __init__(self) -> None:
        definition = message_definition(STRING_TYPE)
        self._store = get_typestore(Stores.EMPTY)
        self._store.register(get_types_from_msg(definition, STRING_TYPE))
        self._type = self._store.types[STRING_TYPE]
        #: ``RIHS01_<sha256>``, the hash ROS 2 gives the type.
        self.type_hash: str = get_type_hash(STRING_TYPE, definition, {})
        #: ``std_msgs::msg::dds_::String_``.
        self.dds_type: str = ros2_to_dds_type(STRING_TYPE)

    def encode(self, text: str) -> bytes:
        """CDR bytes (encapsulation header included) of a String."""
        message = self._type(data=text)
        return bytes(self._store.serialize_cdr(message, STRING_TYPE))

    def decode(self, payload: bytes) -> str:
        """The ``data`` of a CDR-encoded String."""
        message = self._store.deserialize_cdr(payload, STRING_TYPE)
        return str(message.data)  # type: ignore[attr-defined]


@dataclass
class BridgeStats:
    """What the bridge did, per bridged topic leaf.

    Attributes
    ----------
    forwarded
        Messages republished on ROS 2, per leaf.
    skipped
        Samples not republished (deletes, payloads that are not UTF-8
        text), per leaf.
    """

    forwarded: dict[str, int] = field(default_factory=dict)
    skipped: dict[str, int] = field(default_factory=dict)


@dataclass
class _Route:
    topic: BridgedTopic
    subscriber: zenoh.Subscriber
    publisher: Any  # zenoh.Publisher, or zenoh.ext.AdvancedPublisher
    token: zenoh.LivelinessToken
    gid: bytes
    # Where matching is read (an advanced publisher does not say).
    matcher: zenoh.Publisher
    sequence: int = 0


class Ros2Bridge:
    """Republish the scheduler's plan, status and dispatches on ROS 2.

    Single-threaded: Zenoh fills one ring channel per scheduler key and
    :meth:`spin_once` (or :meth:`run`) drains them and publishes; no
    callback runs bridge code.

    Parameters
    ----------
    session
        An open Zenoh session on the scheduler's bus; the ROS 2 tools reach
        the bridge through the same routers (rmw_zenoh's ``rmw_zenohd`` or
        any Zenoh router).
    spacecraft
        The scheduler's spacecraft id.
    domain_id
        The ROS 2 domain; None reads ``ROS_DOMAIN_ID`` (default 0), as
        ROS 2 does.
    capacity
        Samples held per scheduler key between two turns of the loop.
    seed_s
        Seconds :meth:`open` waits for the scheduler's plan and status
        (its queryables) to fill the latest-state topics; 0: none.
    clock_ns
        Source timestamp of each ROS 2 sample, in ns since the Unix epoch.

    Examples
    --------
    >>> with zenoh.open(config) as session, Ros2Bridge(session) as bridge:
    ...     bridge.run(stop)                                 # doctest: +SKIP
    """

    def __init__(
        self,
        session: zenoh.Session,
        spacecraft: str = keys.DEFAULT_SPACECRAFT,
        *,
        domain_id: int | None = None,
        capacity: int = DEFAULT_CAPACITY,
        clock_ns: Callable[[], int] = time.time_ns,
        seed_s: float = 1.0,
    ) -> None:
        self.session = session
        self.spacecraft = spacecraft
        self.domain_id = resolve_domain_id(domain_id)
        self.topics = bridged_topics(spacecraft)
        self.codec = StringCodec()
        self.stats = BridgeStats()
        self._capacity = capacity
        self._clock_ns = clock_ns
        self._seed_s = seed_s
        self._routes: list[_Route] = []
        self._node_token: zenoh.LivelinessToken | None = None

    def open(self) -> Ros2Bridge:
        """Declare the ROS 2 node, its publishers and the subscribers.

        Returns
        -------
        Ros2Bridge
            ``self``.

        Raises
        ------
        BusError
            A declaration was refused (a closed session, access control).
        """
        node = NodeEntity(
            domain_id=self.domain_id,
            session_id=str(self.session.zid()),
            node_id=0,
            node_name=NODE_NAME,
            namespace=ros_namespace(self.spacecraft),
        )
        liveliness = self.session.liveliness()
        try:
            self._node_token = liveliness.declare_token(
                node_liveliness_keyexpr(node)
            )
            for idx, topic in enumerate(self.topics, start=1):
                self._routes.append(self._declare(node, idx, topic))
            if self._seed_s > 0:
                self._seed(self._seed_s)
        except zenoh.ZError as error:
            self.close()
            raise BusError(
                f"cannot declare the ROS 2 bridge: {error}"
            ) from None
        return self

    def _declare(
        self, node: NodeEntity, entity_id: int, topic: BridgedTopic
    ) -> _Route:
        # A 16-byte GID per publisher, as rmw_zenoh gives each endpoint.
        gid = uuid.uuid4().bytes
        endpoint = EndpointEntity(
            node=node,
            entity_id=entity_id,
            kind=EntityKind.PUBLISHER,
            name=topic.ros_topic,
            dds_type_name=self.codec.dds_type,
            type_hash=self.codec.type_hash,
            qos=(LATEST_QOS if topic.latest else EVENT_QOS).encode(),
            gid=gid,
        )
        key = topic_keyexpr(
            self.domain_id,
            topic.ros_topic,
            self.codec.dds_type,
            self.codec.type_hash,
        )
        cdr = zenoh.Encoding("application/cdr")
        matcher = self.session.declare_publisher(key, encoding=cdr)
        publisher: Any = matcher
        if topic.latest:
            # As rmw_zenoh does for transient local: an advanced publisher
            # whose cache a late subscriber queries (``@adv/pub/...``).
            from zenoh import ext

            publisher = ext.declare_advanced_publisher(
                self.session,
                key,
                encoding=cdr,
                cache=ext.CacheConfig(max_samples=LATEST_QOS.history_depth),
                # Samples numbered by sequence, not by timestamp: the
                # session's own flags need not turn timestamping on.
                sample_miss_detection=ext.MissDetectionConfig(
                    heartbeat=None, sporadic_heartbeat=None
                ),
                publisher_detection=True,
            )
        token = self.session.liveliness().declare_token(
            endpoint_liveliness_keyexpr(endpoint)
        )
        subscriber = self.session.declare_subscriber(
            topic.key_expr, zenoh.handlers.RingChannel(self._capacity)
        )
        return _Route(topic, subscriber, publisher, token, gid, matcher)

    def close(self) -> None:
        """Undeclare everything the bridge declared (idempotent)."""
        routes, self._routes = self._routes, []
        node, self._node_token = self._node_token, None
        entities: list[Any] = []
        for route in routes:
            entities += [route.subscriber, route.token, route.publisher]
            if route.matcher is not route.publisher:
                entities.append(route.matcher)
        if node is not None:
            entities.append(node)
        for entity in entities:
            try:
                entity.undeclare()
            except zenoh.ZError as error:
                log.debug("undeclare: %s", error)

    def __enter__(self) -> Ros2Bridge:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def ros_keys(self) -> tuple[str, ...]:
        """The Zenoh keys the bridge publishes on (all in the ROS domain)."""
        return tuple(str(r.publisher.key_expr) for r in self._routes)

    def matching(self, leaf: str) -> bool:
        """Whether a ROS 2 subscriber of topic ``leaf`` is reachable."""
        for route in self._routes:
            if route.topic.leaf == leaf:
                status = route.matcher.matching_status
                return bool(status.matching)  # type: ignore[attr-defined]
        raise KeyError(leaf)

    def spin_once(self) -> int:
        """Republish every sample waiting; returns how many were handled."""
        count = 0
        for route in self._routes:
            while (sample := route.subscriber.try_recv()) is not None:
                count += 1
                self._forward(route, sample)
        return count

    def run(
        self, stop: threading.Event, *, poll_interval_s: float = 0.01
    ) -> BridgeStats:
        """Bridge until ``stop`` is set (from a signal handler, a thread).

        Parameters
        ----------
        stop
            Ends the loop; samples already received are still published.
        poll_interval_s
            Longest wait on ``stop`` when nothing is waiting.

        Returns
        -------
        BridgeStats
            The counters.
        """
        while True:
            stopping = stop.is_set()
            handled = self.spin_once()
            if stopping:
                return self.stats
            if not handled:
                stop.wait(poll_interval_s)

    def _forward(self, route: _Route, sample: zenoh.Sample) -> None:
        payload = (
            sample.payload.to_bytes()
            if sample.kind == zenoh.SampleKind.PUT
            else None
        )
        self._send(route, payload)

    def _seed(self, timeout: float) -> None:
        """Ask the scheduler for its plan and status and publish them, so
        that the latest state is in the cache of a bridge started after
        it (a node that does not answer: the next one comes live)."""
        from .client import query_payload

        for route in self._routes:
            if not route.topic.latest:
                continue
            try:
                payload = query_payload(
                    self.session, route.topic.key_expr, timeout
                )
            except zenoh.ZError as error:
                log.debug("%s: query: %s", route.topic.key_expr, error)
                continue
            if payload is not None:
                self._send(route, payload)

    def _send(self, route: _Route, payload: bytes | None) -> None:
        leaf = route.topic.leaf
        text = None
        if payload is not None:
            try:
                text = payload.decode("utf-8")
            except UnicodeDecodeError:
                log.warning("%s: payload is not UTF-8, not bridged", leaf)
        if text is None:
            self.stats.skipped[leaf] = self.stats.skipped.get(leaf, 0) + 1
            return
        attachment = Attachment(route.sequence, self._clock_ns(), route.gid)
        try:
            route.publisher.put(
                self.codec.encode(text), attachment=attachment.to_bytes()
            )
        except zenoh.ZError as error:
            # Keep bridging: one refused put must not end the bridge.
            log.warning("%s: cannot publish: %s", route.topic.ros_topic, error)
            self.stats.skipped[leaf] = self.stats.skipped.get(leaf, 0) + 1
            return
        route.sequence += 1
        self.stats.forwarded[leaf] = self.stats.forwarded.get(leaf, 0) + 1
