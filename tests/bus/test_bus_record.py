"""Tests of bus recording and replay on real loopback Zenoh peers."""

from __future__ import annotations

import argparse
import functools
import json
import threading
from typing import TYPE_CHECKING

import pytest
import zenoh

from fsw_scheduler.bus.record import KeyFilter, RecordStats, record, replay
from fsw_scheduler.bus.session import (
    add_zenoh_arguments,
    listening_endpoints,
    loopback_config,
    open_peer_pair,
    wait_matching,
    wait_until,
    zenoh_config,
)
from fsw_scheduler.errors import BusError, ConfigError
from fsw_scheduler.journal.info import info
from fsw_scheduler.journal.reader import iter_messages
from fsw_scheduler.journal.writer import Recorder

from .peers import matching

if TYPE_CHECKING:
    from pathlib import Path

TIMEOUT_S = 10.0
KEYS = (
    "fsw/sat1/telemetry/resources/battery",
    "fsw/sat1/telemetry/activities/BatteryCharge",
    "fsw/sat1/clock",
)
T0 = 1_700_000_000_000_000_000


class FakeTime:
    """Clock that only moves when slept on; records requested sleeps."""

    def __init__(self) -> None:
        self.now = 100.0
        self.sleeps: list[float] = []

    def clock(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.sleeps.append(seconds)
        self.now += seconds


def _record_traffic(
    a: zenoh.Session, b: zenoh.Session, path: Path, n: int
) -> RecordStats:
    """Publish n messages from a on KEYS, record them on b into path."""
    stop = threading.Event()
    ready = threading.Event()
    stats = RecordStats()
    with Recorder(path) as recorder:
        worker = threading.Thread(
            target=record,
            args=(b, "fsw/sat1/**", recorder, stop),
            kwargs={"ready": ready, "stats": stats},
        )
        worker.start()
        try:
            assert ready.wait(TIMEOUT_S)
            publishers = [
                a.declare_publisher(k, encoding="application/json")
                for k in KEYS
            ]
            for pub in publishers:
                wait_until(
                    functools.partial(matching, pub),
                    TIMEOUT_S,
                    what="recorder subscription",
                )
            for i in range(n):
                publishers[i % len(KEYS)].put(json.dumps({"i": i}))
            wait_until(
                lambda: stats.written >= n, TIMEOUT_S, what="all recorded"
            )
        finally:
            stop.set()
            worker.join(TIMEOUT_S)
    assert not worker.is_alive()
    return stats


def _receive(sub: zenoh.Subscriber, n: int) -> list[tuple[str, int]]:
    """Take n samples from a FIFO subscriber, with a deadline."""
    got: list[zenoh.Sample] = []

    def more() -> bool:
        while (s := sub.try_recv()) is not None:
            got.append(s)
        return len(got) >= n

    wait_until(more, TIMEOUT_S, what=f"{n} replayed samples")
    return [
        (str(s.key_expr), json.loads(s.payload.to_bytes())["i"]) for s in got
    ]


def _write_recording(path: Path, gaps_ms: list[int]) -> None:
    """Write one message per gap (cumulative ms), cycling over KEYS."""
    with Recorder(path) as rec:
        t = T0
        for i, gap in enumerate(gaps_ms):
            t += gap * 1_000_000
            rec.write(
                KEYS[i % len(KEYS)],
                json.dumps({"i": i}).encode(),
                log_time_ns=t,
            )


def test_record_then_replay_on_bus(tmp_path: Path) -> None:
    """Tests that recorded traffic replays to a subscriber, all in order."""
    path = tmp_path / "bus.mcap"
    n = 60
    with open_peer_pair() as (a, b):
        stats = _record_traffic(a, b, path, n)
        assert stats.received == stats.written == n
        assert sum(stats.by_key.values()) == n

        recorded = list(iter_messages(path))
        assert [json.loads(m.payload)["i"] for m in recorded] == list(range(n))
        assert [m.topic for m in recorded] == [
            KEYS[i % len(KEYS)] for i in range(n)
        ]

        sub = a.declare_subscriber(
            "fsw/sat1/**", zenoh.handlers.FifoChannel(1024)
        )
        try:
            wait_matching(b, KEYS[0], TIMEOUT_S)
            assert replay(b, path, rate=50.0) == n
            got = _receive(sub, n)
        finally:
            sub.undeclare()
    assert got == [(KEYS[i % len(KEYS)], i) for i in range(n)]


def test_record_keeps_publisher_timestamp(tmp_path: Path) -> None:
    """Tests that a Zenoh timestamp becomes the MCAP publish_time."""
    path = tmp_path / "stamped.mcap"
    stop = threading.Event()
    ready = threading.Event()
    stats = RecordStats()
    with open_peer_pair() as (a, b), Recorder(path) as recorder:
        worker = threading.Thread(
            target=record,
            args=(b, "fsw/sat1/**", recorder, stop),
            kwargs={"ready": ready, "stats": stats, "clock_ns": lambda: T0},
        )
        worker.start()
        try:
            assert ready.wait(TIMEOUT_S)
            wait_matching(a, KEYS[2], TIMEOUT_S)
            stamp = a.new_timestamp()
            a.put(KEYS[2], b'{"now": 3}', timestamp=stamp)
            a.put(KEYS[2], b'{"now": 4}')
            a.delete(KEYS[2])
            wait_until(
                lambda: stats.received >= 3, TIMEOUT_S, what="3 samples"
            )
        finally:
            stop.set()
            worker.join(TIMEOUT_S)
    assert (stats.written, stats.deletes) == (2, 1)
    first, second = iter_messages(path)
    assert first.publish_time_ns == stamp.get_time_as_ntp64().as_nanos()
    assert first.log_time_ns == second.log_time_ns == T0
    assert second.publish_time_ns == T0  # unstamped: falls back to log time


def test_record_flushes_while_idle(tmp_path: Path) -> None:
    """Tests that an idle recording loop still flushes within the interval."""
    path = tmp_path / "idle.mcap"
    now = [T0]
    stop = threading.Event()
    ready = threading.Event()
    stats = RecordStats()
    session = zenoh.open(loopback_config(listen=None))
    try:
        with Recorder(path, flush_interval_ns=1_000_000_000) as recorder:
            worker = threading.Thread(
                target=record,
                args=(session, "fsw/sat1/**", recorder, stop),
                kwargs={
                    "ready": ready,
                    "stats": stats,
                    "clock_ns": lambda: now[0],
                },
            )
            worker.start()
            try:
                assert ready.wait(TIMEOUT_S)
                session.put(KEYS[2], b'{"now": 1}')
                wait_until(
                    lambda: stats.written == 1, TIMEOUT_S, what="1 sample"
                )
                assert info(path).message_count == 0  # still in memory
                now[0] += 1_000_000_000  # no new sample, only time passes
                wait_until(
                    lambda: info(path).message_count == 1,
                    TIMEOUT_S,
                    what="idle flush",
                )
                assert not info(path).finished
            finally:
                stop.set()
                worker.join(TIMEOUT_S)
    finally:
        session.close()
    assert info(path).finished


def test_record_bad_key_raises_bus_error(tmp_path: Path) -> None:
    """Tests that an invalid key expression surfaces as BusError."""
    session = zenoh.open(loopback_config(listen=None))
    try:
        with (
            Recorder(tmp_path / "x.mcap") as recorder,
            pytest.raises(BusError),
        ):
            record(session, "fsw//bad", recorder, threading.Event())
    finally:
        session.close()


def test_replay_filters_and_burst(tmp_path: Path) -> None:
    """Tests that include/exclude select keys and burst never sleeps."""
    path = tmp_path / "rec.mcap"
    _write_recording(path, [0, 5, 5, 5, 5, 5, 5, 5, 5])
    fake = FakeTime()
    with open_peer_pair() as (a, b):
        sub = a.declare_subscriber(
            "fsw/sat1/**", zenoh.handlers.FifoChannel(64)
        )
        try:
            wait_matching(b, KEYS[0], TIMEOUT_S)
            count = replay(
                b,
                path,
                burst=True,
                include=["fsw/sat1/telemetry/**"],
                exclude=["fsw/*/telemetry/activities/*"],
                clock=fake.clock,
                sleep=fake.sleep,
            )
            got = _receive(sub, count)
        finally:
            sub.undeclare()
    assert count == 3
    assert got == [(KEYS[0], 0), (KEYS[0], 3), (KEYS[0], 6)]
    assert fake.sleeps == []


@pytest.mark.parametrize("rate", [1.0, 2.0, 0.5])
def test_replay_rate_scales_sleeps(tmp_path: Path, rate: float) -> None:
    """Tests that rate divides the recorded gaps requested from sleep."""
    path = tmp_path / "rec.mcap"
    gaps_ms = [0, 100, 300, 0, 600]
    _write_recording(path, gaps_ms)
    fake = FakeTime()
    session = zenoh.open(loopback_config(listen=None))
    try:
        count = replay(
            session, path, rate=rate, clock=fake.clock, sleep=fake.sleep
        )
    finally:
        session.close()
    assert count == len(gaps_ms)
    expected = [g / 1000 / rate for g in gaps_ms[1:] if g]
    assert fake.sleeps == pytest.approx(expected)


def test_replay_window_and_loop(tmp_path: Path) -> None:
    """Tests that start_offset_s/until_s cut the replay and loop repeats."""
    path = tmp_path / "rec.mcap"
    _write_recording(path, [0, 100, 100, 100, 100])  # at 0..400 ms
    fake = FakeTime()
    stop = threading.Event()
    passes: list[int] = []

    def sleep(seconds: float) -> None:
        fake.sleep(seconds)
        passes.append(1)
        if len(passes) >= 5:
            stop.set()

    session = zenoh.open(loopback_config(listen=None))
    try:
        window = replay(
            session,
            path,
            start_offset_s=0.1,
            until_s=0.35,
            clock=fake.clock,
            sleep=fake.sleep,
        )
        assert window == 3  # 100, 200 and 300 ms
        assert fake.sleeps == pytest.approx([0.1, 0.1])
        looped = replay(
            session,
            path,
            loop=True,
            stop=stop,
            clock=fake.clock,
            sleep=sleep,
        )
    finally:
        session.close()
    assert looped == 6  # 5 in the first pass, 1 in the second


def test_key_filter() -> None:
    """Tests that KeyFilter uses key-expression intersection semantics."""
    keep = KeyFilter(include=["fsw/*/telemetry/**"], exclude=["**/battery"])
    assert keep("fsw/sat1/telemetry/activities/Acq")
    assert not keep("fsw/sat1/telemetry/resources/battery")
    assert not keep("fsw/sat1/clock")
    assert KeyFilter()("anything/at/all")


def test_zenoh_arguments() -> None:
    """Tests that the standard Zenoh flags land in the Zenoh config."""
    parser = argparse.ArgumentParser()
    add_zenoh_arguments(parser)
    args = parser.parse_args(
        [
            "--mode",
            "client",
            "--connect",
            "tcp/10.0.0.1:7447",
            "--connect",
            "tcp/10.0.0.2:7447",
            "--listen",
            "tcp/127.0.0.1:7448",
            "--no-multicast-scouting",
            "--cfg",
            "transport/unicast/max_links:2",
        ]
    )
    config = zenoh_config(args)
    assert json.loads(config.get_json("mode")) == "client"
    assert json.loads(config.get_json("connect/endpoints")) == [
        "tcp/10.0.0.1:7447",
        "tcp/10.0.0.2:7447",
    ]
    assert json.loads(config.get_json("listen/endpoints")) == [
        "tcp/127.0.0.1:7448"
    ]
    assert json.loads(config.get_json("scouting/multicast/enabled")) is False
    assert json.loads(config.get_json("transport/unicast/max_links")) == 2

    bad = parser.parse_args(["--cfg", "no-colon-here"])
    with pytest.raises(ConfigError, match="KEY:VALUE"):
        zenoh_config(bad)


def test_listening_endpoints_reports_real_port() -> None:
    """Tests that an ephemeral listen port is read back from the session."""
    session = zenoh.open(loopback_config())
    try:
        endpoints = listening_endpoints(session)
    finally:
        session.close()
    assert len(endpoints) == 1
    host, _, port = endpoints[0].rpartition(":")
    assert host == "tcp/127.0.0.1"
    assert int(port) > 0


def test_peer_pair_is_connected() -> None:
    """Tests that open_peer_pair yields two peers that see each other."""
    with open_peer_pair() as (a, b):
        assert str(b.zid()) in {str(z) for z in a.info.peers_zid()}
        assert str(a.zid()) in {str(z) for z in b.info.peers_zid()}
    assert a.is_closed() and b.is_closed()


def test_record_keeps_each_sample_encoding(tmp_path: Path) -> None:
    """Tests that non-JSON samples keep their encoding, and replay it."""
    path = tmp_path / "mixed.mcap"
    stop = threading.Event()
    ready = threading.Event()
    stats = RecordStats()
    sent = [
        ("fsw/sat1/clock", b'{"now": 1}', "application/json"),
        ("fsw/sat1/camera/frame", b"\x00\x01\x02", "zenoh/bytes"),
        ("fsw/sat1/notes", b"hello", "text/plain;utf8"),
        ("fsw/sat1/cbor", b"\xa1\x61a\x01", "application/cbor"),
        ("fsw/sat1/skip/me", b"{}", "application/json"),
    ]
    with open_peer_pair() as (a, b), Recorder(path) as recorder:
        worker = threading.Thread(
            target=record,
            args=(b, "fsw/sat1/**", recorder, stop),
            kwargs={
                "ready": ready,
                "stats": stats,
                "exclude": ["fsw/sat1/skip/**"],
            },
        )
        worker.start()
        try:
            assert ready.wait(TIMEOUT_S)
            wait_matching(a, "fsw/sat1/clock", TIMEOUT_S)
            for key, payload, encoding in sent:
                a.put(key, payload, encoding=zenoh.Encoding(encoding))
            wait_until(
                lambda: stats.written + stats.excluded >= len(sent),
                TIMEOUT_S,
                what="all recorded",
            )
        finally:
            stop.set()
            worker.join(TIMEOUT_S)
    assert stats.excluded == 1 and stats.written == 4
    assert stats.by_encoding["zenoh/bytes"] == 1
    described = {c.topic: c for c in info(path).channels}
    assert described["fsw/sat1/clock"].message_encoding == "json"
    assert described["fsw/sat1/camera/frame"].message_encoding == (
        "zenoh/bytes"
    )
    assert described["fsw/sat1/notes"].message_encoding == "text/plain"
    assert described["fsw/sat1/cbor"].message_encoding == "cbor"
    assert "fsw/sat1/skip/me" not in described
    back = {m.topic: m for m in iter_messages(path)}
    assert back["fsw/sat1/notes"].encoding == "text/plain;utf8"
    assert back["fsw/sat1/camera/frame"].payload == b"\x00\x01\x02"
    assert back["fsw/sat1/clock"].encoding == "application/json"

    # Replayed with the recorded encodings.
    with open_peer_pair() as (a, b):
        sub = b.declare_subscriber(
            "fsw/sat1/**", zenoh.handlers.FifoChannel(64)
        )
        wait_matching(a, "fsw/sat1/notes", TIMEOUT_S)
        assert replay(a, path, burst=True) == 4
        got: dict[str, str] = {}

        def arrived() -> bool:
            while (s := sub.try_recv()) is not None:
                got[str(s.key_expr)] = str(s.encoding)
            return len(got) >= 4

        wait_until(arrived, TIMEOUT_S, what="replayed samples")
        sub.undeclare()
    assert got["fsw/sat1/notes"] == "text/plain;utf8"
    assert got["fsw/sat1/cbor"] == "application/cbor"
    assert got["fsw/sat1/clock"] == "application/json"


def test_only_json_recorder_skips_and_counts(tmp_path: Path) -> None:
    """Tests the skip-with-a-counter mode for non-JSON samples."""
    path = tmp_path / "json.mcap"
    with Recorder(path, only_json=True) as rec:
        assert rec.write("k/a", b"{}", log_time_ns=T0)
        assert not rec.write(
            "k/b", b"x", log_time_ns=T0 + 1, encoding="zenoh/bytes"
        )
    assert rec.skipped == 1
    assert [c.topic for c in info(path).channels] == ["k/a"]


def test_replay_remaps_keys_and_publishes_a_clock(tmp_path: Path) -> None:
    """Tests --remap (sat1 as sat2) and a bus clock from log times."""
    from fsw_scheduler.bus.record import clock_ticks, parse_remap, remap_key

    table = parse_remap(["fsw/sat1=fsw/sat2"])
    assert remap_key("fsw/sat1/clock", table) == "fsw/sat2/clock"
    assert remap_key("fsw/sat10/clock", table) == "fsw/sat10/clock"
    for bad in ("fsw/sat1", "=x", "fsw/*=a"):
        with pytest.raises(ValueError):
            parse_remap([bad])

    path = tmp_path / "rec.mcap"
    # Messages at 0, 0.5, 2.2 s: the clock ticks 0, 1, 2 before them.
    with Recorder(path) as rec:
        for i, at_ms in enumerate((0, 500, 2200)):
            rec.write(
                "fsw/sat1/telemetry/resources/battery",
                json.dumps({"i": i}).encode(),
                log_time_ns=T0 + at_ms * 1_000_000,
            )
    merged = [
        (m.topic.rsplit("/", 1)[-1], m.payload)
        for m in clock_ticks(
            iter_messages(path), "fsw/sat1/clock", T0, 1_000_000_000
        )
    ]
    assert merged == [
        ("clock", b'{"now":0}'),
        ("battery", b'{"i": 0}'),
        ("battery", b'{"i": 1}'),
        ("clock", b'{"now":1}'),
        ("clock", b'{"now":2}'),
        ("battery", b'{"i": 2}'),
    ]
    with open_peer_pair() as (a, b):
        sub = b.declare_subscriber("fsw/**", zenoh.handlers.FifoChannel(64))
        wait_matching(a, "fsw/sat2/clock", TIMEOUT_S)
        count = replay(
            a,
            path,
            burst=True,
            remap=table,
            clock_key="fsw/sat1/clock",
        )
        assert count == 6
        keys: list[str] = []

        def arrived() -> bool:
            while (s := sub.try_recv()) is not None:
                keys.append(str(s.key_expr))
            return len(keys) >= 6

        wait_until(arrived, TIMEOUT_S, what="replayed samples")
        sub.undeclare()
    assert all(k.startswith("fsw/sat2/") for k in keys)
    assert keys.count("fsw/sat2/clock") == 3


def test_dispatches_share_one_channel_and_replay_on_their_keys(
    tmp_path: Path,
) -> None:
    """Tests that dispatches of several tasks are recorded on one channel
    (``scheduler/dispatch``, the task in the message) and replayed onto
    each task's own key."""
    path = tmp_path / "bus.mcap"
    tasks = ["Acquire", "Downlink", "Point", "Acquire"]
    with Recorder(path) as rec:
        for i, task in enumerate(tasks):
            rec.write(
                f"fsw/sat1/scheduler/dispatch/{task}",
                json.dumps({"task": task, "i": i}).encode(),
                log_time_ns=T0 + i * 1_000_000,
            )
    recorded = list(iter_messages(path))
    assert {m.topic for m in recorded} == {"fsw/sat1/scheduler/dispatch"}
    with open_peer_pair() as (a, b):
        sub = a.declare_subscriber(
            "fsw/sat1/**", zenoh.handlers.FifoChannel(64)
        )
        try:
            wait_matching(b, "fsw/sat1/scheduler/dispatch/Point", TIMEOUT_S)
            assert replay(b, path, burst=True) == len(tasks)
            got = _receive(sub, len(tasks))
        finally:
            sub.undeclare()
    assert got == [
        (f"fsw/sat1/scheduler/dispatch/{task}", i)
        for i, task in enumerate(tasks)
    ]
