"""Tests of the ROS 2 bridge: a real scheduler node on loopback, the
bridge on the same bus, and zenoh-ros2-sdk's own graph query and
subscriber as the ROS 2 side, with every git fetch made impossible."""

from __future__ import annotations

import contextlib
import queue
import threading
import uuid
from typing import TYPE_CHECKING, Any

import msgspec
import pytest
import zenoh

pytest.importorskip("zenoh_ros2_sdk")

from zenoh_ros2_sdk import (
    ROS2Subscriber,
    ZenohSession,
    get_topic_info,
    get_topic_names_and_types,
)
from zenoh_ros2_sdk import message_registry as sdk_registry

from fsw_scheduler.bus.ros2 import (
    EVENT_QOS,
    LATEST_QOS,
    NODE_NAME,
    STRING_TYPE,
    Ros2Bridge,
    StringCodec,
    bridged_topics,
    definitions_dir,
    ros_name_token,
)
from fsw_scheduler.bus.session import (
    listening_endpoints,
    loopback_config,
    wait_matching,
    wait_until,
)
from fsw_scheduler.testing import SchedulerHarness, paper_goal
from fsw_scheduler.wire import messages

if TYPE_CHECKING:
    from collections.abc import Iterator
    from pathlib import Path

WAIT_S = 20.0
#: ROS 2 Jazzy's hash of std_msgs/msg/String (``ros2 topic info -v``).
STRING_HASH = (
    "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
)


@pytest.fixture
def no_git(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> list[str]:
    """Every way zenoh-ros2-sdk fetches definitions raises (and is
    recorded, since the SDK logs and swallows such errors); git itself
    finds an empty home and may use no protocol. Yields the attempts."""
    attempts: list[str] = []

    def refuse(*args: Any, **_: Any) -> Any:
        attempts.append(repr(args))
        raise RuntimeError("no fetching in this test")

    import zenoh_ros2_sdk._cache as sdk_cache

    for module in (sdk_cache, sdk_registry):
        for name in ("clone_to_cache", "get_message_file_path"):
            monkeypatch.setattr(module, name, refuse)
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv("GIT_CONFIG_NOSYSTEM", "1")
    monkeypatch.setenv("GIT_ALLOW_PROTOCOL", "none")
    monkeypatch.setenv("GIT_TERMINAL_PROMPT", "0")
    monkeypatch.delenv("ROS_DOMAIN_ID", raising=False)
    monkeypatch.delenv("ZENOH_SESSION_CONFIG_URI", raising=False)
    monkeypatch.delenv("ZENOH_CONFIG_OVERRIDE", raising=False)
    # The SDK's registry reads the package's shipped definitions first.
    monkeypatch.setattr(
        sdk_registry,
        "_registry",
        sdk_registry.MessageRegistry(str(definitions_dir())),
    )
    return attempts


class Inbox:
    """What a ROS 2 subscriber callback received, waited on in the test."""

    def __init__(self) -> None:
        self.items: list[str] = []
        self._cond = threading.Condition()

    def __call__(self, message: Any) -> None:
        with self._cond:
            self.items.append(message.data)
            self._cond.notify_all()

    def wait(self, predicate: Any, what: str) -> str:
        with self._cond:
            found: list[str] = []

            def seen() -> bool:
                found[:] = [text for text in self.items if predicate(text)]
                return bool(found)

            if not self._cond.wait_for(seen, WAIT_S):
                raise TimeoutError(f"no {what} in {self.items!r}")
            return found[-1]


@contextlib.contextmanager
def bridged_scheduler(
    first_plan: bool = False,
) -> Iterator[tuple[SchedulerHarness, Ros2Bridge, int]]:
    """A scheduler on Table 1, the bridge on a peer of its own connected
    to it and listening on a loopback port (yielded for the ROS 2 side);
    with ``first_plan``, the bridge starts after the node's plan 1."""
    with contextlib.ExitStack() as stack:
        harness = stack.enter_context(SchedulerHarness())
        if first_plan:
            harness.tick(0)
        session = zenoh.open(loopback_config(connect=harness.endpoints()))
        stack.callback(session.close)
        bridge = stack.enter_context(Ros2Bridge(session))
        # Declarations travel in order on the link: once the node's
        # session knows this later subscriber, it knows the bridge's.
        probe = f"test/ros2/{uuid.uuid4().hex}"
        stack.enter_context(
            contextlib.closing(_Undeclare(session.declare_subscriber(probe)))
        )
        wait_matching(harness.server, probe, WAIT_S)
        stop = threading.Event()
        thread = threading.Thread(target=bridge.run, args=(stop,))
        thread.start()

        def halt() -> None:
            stop.set()
            thread.join(WAIT_S)

        stack.callback(halt)
        (endpoint,) = listening_endpoints(session)
        yield harness, bridge, int(endpoint.rsplit(":", 1)[1])


class _Undeclare:
    def __init__(self, entity: Any) -> None:
        self.entity = entity

    def close(self) -> None:
        self.entity.undeclare()


def _ros_subscriber(
    topic: str, inbox: Inbox, port: int
) -> contextlib.AbstractContextManager[ROS2Subscriber]:
    subscriber = ROS2Subscriber(
        topic, STRING_TYPE, inbox, router_port=port, node_name="echo"
    )
    return contextlib.closing(subscriber)


@contextlib.contextmanager
def _ros_session() -> Iterator[None]:
    """Close the SDK's process-wide session at the end of the test."""
    try:
        yield
    finally:
        instance = ZenohSession._instance
        if instance is not None:
            instance.close()


def test_ros2_tools_list_and_echo_the_plan_offline(no_git: list[str]) -> None:
    """Tests that the SDK's graph query lists the bridge's three topics as
    std_msgs/msg/String under its node, and that the SDK's subscriber gets
    the plan made for a goal, CDR-decoded, as the scheduler's own JSON,
    while no definition is fetched."""
    with bridged_scheduler() as (harness, bridge, port), _ros_session():
        topics = {t.leaf: t.ros_topic for t in bridge.topics}
        assert topics == {
            "plan": "/fsw/sat1/scheduler/plan",
            "status": "/fsw/sat1/scheduler/status",
            "dispatches": "/fsw/sat1/scheduler/dispatches",
        }
        plans, dispatches = Inbox(), Inbox()
        with (
            _ros_subscriber(topics["plan"], plans, port),
            _ros_subscriber(topics["dispatches"], dispatches, port),
        ):
            listed: dict[str, list[str]] = {}

            def all_listed() -> bool:
                listed.update(
                    get_topic_names_and_types(router_port=port, timeout=1.0)
                )
                return all(t in listed for t in topics.values())

            wait_until(all_listed, WAIT_S, what="the bridge's topics")
            for topic in topics.values():
                assert listed[topic] == [STRING_TYPE]
            info = get_topic_info(
                topics["plan"], router_port=port, timeout=1.0, verbose=True
            )
            assert info is not None
            (publisher,) = info.publishers
            assert publisher.node_name == NODE_NAME
            assert publisher.node_namespace == "/fsw/sat1"
            assert publisher.type_hash == STRING_HASH
            wait_until(
                lambda: (
                    bridge.matching("plan") and bridge.matching("dispatches")
                ),
                WAIT_S,
                what="the ROS 2 subscribers",
            )

            harness.tick(0)
            verdicts = harness.send_goals([paper_goal()])
            assert verdicts == {"monitor-target-lf": {"goal_accepted"}}
            wanted = harness.wait_plan(
                lambda p: "monitor-target-lf" in p.goals
            )
            text = plans.wait(
                lambda s: (
                    msgspec.json.decode(s).get("plan_id") == wanted.plan_id
                ),
                f"plan {wanted.plan_id}",
            )
            decoded = msgspec.json.decode(text, type=messages.PlanMessage)
            assert decoded == wanted
            raw = [
                p for k, p in harness.samples if k.endswith("/scheduler/plan")
            ]
            assert text.encode() in raw  # the scheduler's bytes, unchanged
            first = harness.executed[0]
            # The command itself: a later replan may also cancel it on
            # the same topic (docs/redundancy.md, "A command is sent once").
            dispatch = dispatches.wait(
                lambda s: (
                    msgspec.json.decode(s)["task"] == first.task
                    and msgspec.json.decode(s).get("action", "run") == "run"
                ),
                f"dispatch of {first.task}",
            )
            assert msgspec.json.decode(dispatch, type=messages.Dispatch) == (
                first
            )
        assert all(key.startswith("0/fsw/sat1/") for key in bridge.ros_keys)
        assert bridge.stats.forwarded["dispatches"] >= 1
    assert no_git == []


def test_the_string_codec_is_ros2s_and_round_trips() -> None:
    """Tests that the shipped String definition gives ROS 2's type hash
    and DDS name, and that the CDR bytes are the standard ones."""
    codec = StringCodec()
    assert codec.type_hash == STRING_HASH
    assert codec.dds_type == "std_msgs::msg::dds_::String_"
    payload = codec.encode('{"a": "é"}')
    # Little-endian CDR header, length with the NUL, the UTF-8, the NUL.
    assert payload[:8] == b"\x00\x01\x00\x00\x0c\x00\x00\x00"
    assert payload[8:] == '{"a": "é"}'.encode() + b"\x00"
    assert codec.decode(payload) == '{"a": "é"}'


@pytest.mark.parametrize(
    ("spacecraft", "token"),
    [("sat1", "sat1"), ("sat-1", "sat_1"), ("2nd.sat", "_2nd_sat")],
)
def test_spacecraft_ids_become_ros2_name_tokens(
    spacecraft: str, token: str
) -> None:
    """Tests that a spacecraft id is made a valid ROS 2 name token, and
    that the scheduler keys it reads keep the id as it is."""
    assert ros_name_token(spacecraft) == token
    plan = bridged_topics(spacecraft)[0]
    assert plan.ros_topic == f"/fsw/{token}/scheduler/plan"
    assert plan.key_expr == f"fsw/{spacecraft}/scheduler/plan"


def test_a_late_ros2_subscriber_gets_the_plan_already_made() -> None:
    """Tests the latest-state topics as rmw_zenoh users expect them: a
    bridge started after the plan, then a transient-local subscriber as
    rmw_zenoh makes one (an advanced subscriber asking for history, depth
    1) started after that, receives the plan at once; the graph says
    transient local, depth 1, for plan and status, volatile for
    dispatches."""
    from zenoh import ext

    with bridged_scheduler(first_plan=True) as (harness, bridge, port):
        plan = harness.query_plan()
        assert plan is not None and plan.plan_id == 1
        topics = {t.leaf: t for t in bridge.topics}
        assert topics["plan"].latest and topics["status"].latest
        assert not topics["dispatches"].latest
        (plan_key,) = [k for k in bridge.ros_keys if "/plan/" in k]
        received: queue.SimpleQueue[bytes] = queue.SimpleQueue()
        with zenoh.open(
            loopback_config(listen=None, connect=[f"tcp/127.0.0.1:{port}"])
        ) as late:
            subscriber = ext.declare_advanced_subscriber(
                late,
                plan_key,
                lambda sample: received.put(sample.payload.to_bytes()),
                history=ext.HistoryConfig(
                    detect_late_publishers=True, max_samples=1
                ),
            )
            try:
                text = bridge.codec.decode(received.get(timeout=WAIT_S))
            finally:
                subscriber.undeclare()
        assert msgspec.json.decode(text, type=messages.PlanMessage) == plan
        tokens = [
            str(reply.ok.key_expr)
            for reply in bridge.session.liveliness().get(
                "@ros2_lv/**", timeout=2.0
            )
            if reply.ok is not None
        ]
        qos = {
            leaf: [t.rsplit("/", 1)[1] for t in tokens if f"%{leaf}/" in t]
            for leaf in topics
        }
        assert qos["plan"] == qos["status"] == [LATEST_QOS.encode()]
        assert ":1:,1:" in LATEST_QOS.encode()  # transient local, depth 1
        assert qos["dispatches"] == [EVENT_QOS.encode()]
