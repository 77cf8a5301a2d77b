"""Tests of ``fsw-scheduler view``: a real node on loopback, the view on a
free port, real Foxglove WebSocket clients (the ``websockets`` library)."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import struct
import subprocess
import sys
import threading
import time
from typing import TYPE_CHECKING, Any, TypeVar

import msgspec
import pytest
import zenoh

pytest.importorskip("foxglove")
pytest.importorskip("websockets")

from websockets.sync.client import connect
from websockets.typing import Subprotocol

from fsw_scheduler.app.cli.main import main
from fsw_scheduler.app.live_view import LiveBridge
from fsw_scheduler.bus.session import (
    loopback_config,
    wait_connected,
)
from fsw_scheduler.journal.annotate import LOG_SCHEMA
from fsw_scheduler.journal.channels import (
    LIVE_SUFFIXES,
    live_channels,
)
from fsw_scheduler.view.live import LiveServer
from fsw_scheduler.wire import topics as keys
from fsw_scheduler.wire.messages import PlanMessage, Status
from fsw_scheduler.wire.profiles import Profiles

from ..factories import cli_command

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator

    from fsw_scheduler.testing import SchedulerHarness

pytest_plugins = ["fsw_scheduler.testing"]

T = TypeVar("T")

WAIT_S = 20.0
TOPICS = keys.Topics()
PLAN = TOPICS.key(keys.PLAN)
STATUS = TOPICS.key(keys.STATUS)
PROFILES = TOPICS.key(keys.PROFILES)
LOG = TOPICS.key(keys.LOG)
LEVELS = TOPICS.key(keys.LEVELS)
#: The protocols foxglove-sdk serves, newest first.
SUBPROTOCOLS = [
    Subprotocol("foxglove.sdk.v1"),
    Subprotocol("foxglove.websocket.v1"),
]


class FoxgloveClient:
    """A Foxglove WebSocket client: what the Foxglove app does, in short.

    Keeps the server info, the advertised channels (by topic) and every
    message received on a subscription, as (topic, payload).
    """

    def __init__(
        self, url: str, subprotocols: list[Subprotocol] | None = None
    ) -> None:
        # websockets 17 wants the connection entered as a context.
        self._stack = contextlib.ExitStack()
        self.ws = self._stack.enter_context(
            connect(
                url,
                subprotocols=subprotocols or SUBPROTOCOLS,
                open_timeout=WAIT_S,
            )
        )
        self.info: dict[str, Any] | None = None
        self.channels: dict[str, dict[str, Any]] = {}
        self.messages: list[tuple[str, bytes]] = []
        self._topic_of: dict[int, str] = {}
        self._next = 1

    def close(self) -> None:
        self._stack.close()

    def pump(self, until: Callable[[], bool], what: str) -> None:
        """Read until ``until()`` holds; fail after ``WAIT_S``."""
        deadline = time.monotonic() + WAIT_S
        while not until():
            left = deadline - time.monotonic()
            assert left > 0, f"no {what} within {WAIT_S} s"
            with contextlib.suppress(TimeoutError):
                self._take(self.ws.recv(timeout=min(left, 0.5)))

    def _take(self, frame: str | bytes) -> None:
        if isinstance(frame, str):
            doc = json.loads(frame)
            if doc["op"] == "serverInfo":
                self.info = doc
            elif doc["op"] == "advertise":
                for channel in doc["channels"]:
                    self.channels[channel["topic"]] = channel
            return
        # Binary "message data": opcode 1, subscription id, time, payload.
        assert frame[0] == 1, frame[:1]
        (sub_id,) = struct.unpack_from("<I", frame, 1)
        self.messages.append((self._topic_of[sub_id], bytes(frame[13:])))

    def subscribe(self, *topics: str) -> None:
        self.pump(
            lambda: set(topics) <= set(self.channels), f"advert of {topics}"
        )
        subscriptions = []
        for topic in topics:
            self._topic_of[self._next] = topic
            subscriptions.append(
                {"id": self._next, "channelId": self.channels[topic]["id"]}
            )
            self._next += 1
        self.ws.send(
            json.dumps({"op": "subscribe", "subscriptions": subscriptions})
        )

    def received(self, topic: str) -> list[bytes]:
        return [p for t, p in self.messages if t == topic]

    def wait_for(
        self, topic: str, kind: type[T], predicate: Callable[[T], bool]
    ) -> T:
        """The first message on ``topic``, decoded as ``kind``, that
        ``predicate`` accepts."""
        found: list[T] = []

        def seen() -> bool:
            found[:] = [
                m
                for m in (
                    msgspec.json.decode(p, type=kind)
                    for p in self.received(topic)
                )
                if predicate(m)
            ][:1]
            return bool(found)

        self.pump(seen, f"matching message on {topic}")
        return found[0]


@contextlib.contextmanager
def live_view(
    harness: SchedulerHarness,
) -> Iterator[tuple[LiveServer, LiveBridge]]:
    """The view on its own session (connected to the node's), port 0,
    its loop on a thread; everything closed after."""
    session = zenoh.open(
        loopback_config(listen=None, connect=harness.endpoints())
    )
    stop = threading.Event()
    thread = None
    try:
        wait_connected(harness.server, session, WAIT_S)
        bridge: list[LiveBridge] = []
        server = LiveServer(
            live_channels(TOPICS.spacecraft),
            port=0,
            no_replay=[LOG],
            on_subscribe=lambda: bridge[0].poke() if bridge else None,
        )
        with server, LiveBridge(session, server) as b:
            bridge.append(b)
            b.start(timeout=5.0)
            thread = threading.Thread(target=b.run, args=(stop,))
            thread.start()
            yield server, b
    finally:
        stop.set()
        if thread is not None:
            thread.join(WAIT_S)
        session.close()


@pytest.fixture
def client_factory() -> Iterator[Callable[[str], FoxgloveClient]]:
    clients: list[FoxgloveClient] = []

    def make(url: str) -> FoxgloveClient:
        clients.append(FoxgloveClient(url))
        return clients[-1]

    try:
        yield make
    finally:
        for client in clients:
            client.close()


def test_clients_get_plans_and_a_late_one_the_current_state(
    scheduler_harness: SchedulerHarness,
    client_factory: Callable[[str], FoxgloveClient],
) -> None:
    """Tests the live view end to end: server info, channels declared up
    front with the journal's schemas, plans and statuses as they are
    published, derived log entries, and a client that connects after the
    first plan still gets the current plan, status and profiles."""
    h = scheduler_harness
    with live_view(h) as (server, _bridge):
        assert server.port > 0
        first = client_factory(server.url)
        assert first.ws.subprotocol in SUBPROTOCOLS
        first.pump(lambda: first.info is not None, "serverInfo")
        assert first.info is not None
        assert first.info["name"] == "fsw-scheduler"
        fixed = {TOPICS.key(s) for s in LIVE_SUFFIXES}
        first.pump(lambda: fixed <= set(first.channels), "every channel")
        plan_channel = first.channels[PLAN]
        assert plan_channel["encoding"] == "json"
        assert plan_channel["schemaName"] == "fsw_scheduler.plan"
        assert plan_channel["schemaEncoding"] == "jsonschema"
        assert json.loads(plan_channel["schema"])["title"] == (
            "fsw_scheduler.plan"
        )
        assert first.channels[LOG]["schemaName"] == "foxglove.Log"
        assert json.loads(first.channels[LOG]["schema"]) == json.loads(
            json.dumps(LOG_SCHEMA)
        )
        first.subscribe(PLAN, STATUS, PROFILES, LOG)
        h.tick(0)
        plan = h.wait_plan(lambda p: p.plan_id == 1)
        shown = first.wait_for(PLAN, PlanMessage, lambda p: p.plan_id == 1)
        assert shown == plan
        first.wait_for(STATUS, Status, lambda s: s.now == 0)
        first.wait_for(PROFILES, Profiles, lambda p: p.plan_id == 1)
        first.pump(
            lambda: any(b"plan 1 (initial" in p for p in first.received(LOG)),
            "the plan's log entry",
        )
        # The resources the profiles name have channels before any level.
        battery = TOPICS.resource_level("battery")
        first.pump(lambda: battery in first.channels, "battery's channel")

        late = client_factory(server.url)
        late.subscribe(PLAN, STATUS, PROFILES)
        assert late.wait_for(PLAN, PlanMessage, lambda _p: True) == plan
        status = late.wait_for(STATUS, Status, lambda _s: True)
        assert status.plan_id == 1
        late.wait_for(PROFILES, Profiles, lambda p: p.plan_id == 1)
        # A level is checked against the plan in force; whether it is
        # shown before or after the subscription, the client gets it.
        # Put from the node's session: the view, a peer of the node only,
        # does not hear the harness's other peer (peers do not forward).
        h.server.put(
            battery,
            b'{"resource": "battery", "level": 7.0, "at": 0}',
            encoding=zenoh.Encoding.APPLICATION_JSON,
        )
        late.subscribe(battery, LEVELS)
        check = late.wait_for(LEVELS, dict, lambda c: c["at"] == 0)
        assert check["resource"] == "battery" and check["plan_id"] == 1
        assert check["predicted"] is not None
        late.wait_for(battery, dict, lambda level: level["level"] == 7.0)


def test_a_view_started_after_the_plan_shows_it_at_once(
    scheduler_harness: SchedulerHarness,
    client_factory: Callable[[str], FoxgloveClient],
) -> None:
    """Tests the start-up queries: plan, status, profiles and settings of
    a node that planned before the view existed, and nothing published
    since."""
    h = scheduler_harness
    h.tick(0)
    plan = h.wait_plan(lambda p: p.plan_id == 1)
    h.settle()
    with live_view(h) as (server, bridge):
        config = TOPICS.key(keys.NODE_INFO)
        assert set(bridge.seeded) == {PLAN, STATUS, PROFILES, config}
        client = client_factory(server.url)
        client.subscribe(PLAN, STATUS, PROFILES)
        assert client.wait_for(PLAN, PlanMessage, lambda _p: True) == plan
        assert client.wait_for(STATUS, Status, lambda _s: True).plan_id == 1
        client.wait_for(PROFILES, Profiles, lambda p: p.plan_id == 1)
        assert server.replayed >= 3


def test_view_refuses_to_start_without_the_extra(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Tests exit 2 and the install command when foxglove is missing."""
    monkeypatch.setitem(sys.modules, "foxglove", None)
    assert main(["view", "--no-multicast-scouting"]) == 2
    err = capsys.readouterr().err
    assert "pip install 'fsw-scheduler[view]'" in err
    assert "foxglove-sdk" in err


def test_view_process_prints_its_url_and_stops_on_sigterm() -> None:
    """Tests ``fsw-scheduler view --port 0`` as a process: its URL and
    open links on stdout, a client served, exit 0 on SIGTERM."""
    process = subprocess.Popen(
        cli_command(
            "view",
            "--port",
            "0",
            "--timeout",
            "0.2",
            "-l",
            "tcp/127.0.0.1:0",
            "--no-multicast-scouting",
        ),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        assert process.stdout is not None
        lines: list[str] = []
        arrived = threading.Condition()

        def read(stream: Any) -> None:
            # A thread: a selector would miss lines already in the buffer.
            for line in stream:
                with arrived:
                    lines.append(line)
                    arrived.notify_all()

        reader = threading.Thread(
            target=read, args=(process.stdout,), daemon=True
        )
        reader.start()
        with arrived:
            assert arrived.wait_for(
                lambda: any("scheduler:" in line for line in lines), 60.0
            ), (lines, process.poll())
        text = "".join(lines)
        url = next(w for w in text.split() if w.startswith("ws://"))
        assert url.startswith("ws://127.0.0.1:")
        assert "https://app.foxglove.dev" in text
        assert "foxglove://open?ds=foxglove-websocket" in text
        client = FoxgloveClient(url)
        try:
            client.pump(lambda: PLAN in client.channels, "the plan channel")
        finally:
            client.close()
        process.send_signal(signal.SIGTERM)
        assert process.wait(timeout=30) == 0
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        for stream in (process.stdout, process.stderr):
            if stream is not None:
                stream.close()


@pytest.mark.parametrize(
    "protocol", ["foxglove.websocket.v1", "foxglove.sdk.v1"]
)
def test_a_late_view_serves_either_subprotocol_the_state_and_the_config(
    scheduler_harness: SchedulerHarness, protocol: str
) -> None:
    """Tests a view started after the node's first plan, and a client
    that offers one subprotocol only (the older ``foxglove.websocket.v1``
    of Foxglove Studio and ws-protocol clients, or the SDK's): it is
    answered in that protocol and gets the plan and the node's settings
    (``scheduler/config``, published long before the view started)."""
    h = scheduler_harness
    h.tick(0)
    plan = h.wait_plan(lambda p: p.plan_id == 1)
    config = TOPICS.key(keys.NODE_INFO)
    with live_view(h) as (server, _bridge):
        client = FoxgloveClient(server.url, [Subprotocol(protocol)])
        try:
            assert client.ws.subprotocol == protocol
            client.pump(lambda: client.info is not None, "serverInfo")
            client.pump(lambda: config in client.channels, "config channel")
            client.subscribe(PLAN, config)
            assert client.wait_for(PLAN, PlanMessage, lambda _p: True) == plan
            info = client.wait_for(config, dict, lambda _i: True)
            assert info["spacecraft"] == "sat1"
            assert "battery" in info["problem"]["resources"]["consumable"]
        finally:
            client.close()
