"""Tests of ``record``, ``recover``, ``info`` and ``replay`` as processes.

Each test opens one in-process loopback peer; the command under test runs
in a real subprocess that connects to it, with multicast scouting off.
Synchronisation is by ``matching_status``, by polling the recording on disk
or by waiting for the process, never by fixed sleeps.
"""

from __future__ import annotations

import json
import re
import signal
import subprocess
from typing import IO, TYPE_CHECKING

import pytest
import zenoh
from mcap.reader import make_reader
from mcap.well_known import MessageEncoding, SchemaEncoding

from fsw_scheduler.bus.session import (
    listening_endpoints,
    loopback_config,
    wait_until,
)
from fsw_scheduler.journal.info import format_info, info

from ..bus.peers import matching
from ..factories import ROOT, cli_command

if TYPE_CHECKING:
    from collections.abc import Iterator
    from pathlib import Path

PAPER = ROOT / "replay" / "paper.mcap"
#: Generous: a subprocess importing zenoh on a busy 2-core machine.
TIMEOUT_S = 30.0
#: The longest a flushed message may take to reach the file (flush 0.2 s).
FLUSH_WAIT_S = 5.0
CLOCK = "fsw/sat1/clock"
BATTERY = "fsw/sat1/telemetry/resources/battery"
REPORT = "fsw/sat1/telemetry/activities/BatteryCharge"
KEYS = (CLOCK, BATTERY, REPORT)


def bus_flags(endpoint: str) -> list[str]:
    """Zenoh flags: connect to the test peer only, on loopback."""
    return [
        "--connect",
        endpoint,
        "--listen",
        "tcp/127.0.0.1:0",
        "--no-multicast-scouting",
    ]


def payload(key: str, i: int) -> bytes:
    """Message number ``i`` on ``key``, in the contract's shapes."""
    if key == CLOCK:
        doc: dict = {"now": i}
    elif key == BATTERY:
        doc = {"resource": "battery", "level": float(i), "at": i}
    else:
        doc = {"task": "BatteryCharge", "state": "running", "at": i}
    return json.dumps(doc).encode()


def number(data: bytes) -> int:
    """The ``i`` that :func:`payload` put in a message."""
    doc = json.loads(data)
    return int(doc.get("now", doc.get("at")))


def count_on_disk(path: Path) -> int:
    """Messages that have reached ``path`` so far (tolerant read)."""
    return info(path).message_count if path.exists() else 0


@pytest.fixture
def peer() -> Iterator[tuple[zenoh.Session, str]]:
    """A loopback peer and the endpoint it listens on."""
    session = zenoh.open(loopback_config())
    try:
        yield session, listening_endpoints(session)[0]
    finally:
        session.close()


class Recording:
    """A ``fsw-scheduler record`` process and its output."""

    def __init__(self, tmp_path: Path, endpoint: str) -> None:
        self.out = tmp_path / "rec.mcap"
        self._log: IO[bytes] = open(tmp_path / "record.log", "wb")  # noqa: SIM115
        self.process = subprocess.Popen(
            cli_command(
                "record",
                "--out",
                str(self.out),
                "--key",
                "fsw/sat1/**",
                "--flush-interval",
                "0.2",
                *bus_flags(endpoint),
            ),
            stdout=self._log,
            stderr=subprocess.STDOUT,
        )
        self.log_path = tmp_path / "record.log"

    def log(self) -> str:
        """What the process printed."""
        self._log.flush()
        return self.log_path.read_text()

    def close(self) -> None:
        """Kill the process if it still runs; close the log."""
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait(TIMEOUT_S)
        self._log.close()


@pytest.fixture
def recording(
    tmp_path: Path, peer: tuple[zenoh.Session, str]
) -> Iterator[Recording]:
    """A running recorder connected to the test peer."""
    rec = Recording(tmp_path, peer[1])
    try:
        yield rec
    finally:
        rec.close()


def publish_matched(
    session: zenoh.Session, rec: Recording
) -> list[zenoh.Publisher]:
    """Publishers on KEYS, once the recorder's subscriber matches them."""
    publishers = [
        session.declare_publisher(k, encoding="application/json") for k in KEYS
    ]

    def matched() -> bool:
        assert rec.process.poll() is None, rec.log()
        return all(matching(p) for p in publishers)

    wait_until(matched, TIMEOUT_S, what="the recorder's subscriber")
    return publishers


def put_range(publishers: list[zenoh.Publisher], numbers: range) -> None:
    """Publish message ``i`` for each ``i``, cycling over KEYS."""
    for i in numbers:
        publishers[i % len(KEYS)].put(payload(KEYS[i % len(KEYS)], i))


def read_all(path: Path) -> list[tuple[str, str, bytes, int]]:
    """(topic, schema name, payload, log time) with the mcap reader."""
    with open(path, "rb") as f:
        out = []
        for schema, channel, message in make_reader(f).iter_messages(
            log_time_order=True
        ):
            assert channel.message_encoding == MessageEncoding.JSON
            assert schema is not None
            assert schema.encoding == SchemaEncoding.JSONSchema
            out.append(
                (channel.topic, schema.name, message.data, message.log_time)
            )
        return out


def test_killed_recording_recovers(
    tmp_path: Path,
    peer: tuple[zenoh.Session, str],
    recording: Recording,
) -> None:
    """Tests that a SIGKILLed recording recovers with all flushed data."""
    session, _ = peer
    publishers = publish_matched(session, recording)
    flushed = range(60)
    put_range(publishers, flushed)
    # Within the 0.2 s flush interval these reach the file on their own.
    wait_until(
        lambda: count_on_disk(recording.out) >= len(flushed),
        FLUSH_WAIT_S,
        what="the periodic flush",
    )
    in_flight = range(len(flushed), len(flushed) + 30)
    put_range(publishers, in_flight)
    recording.process.send_signal(signal.SIGKILL)
    assert recording.process.wait(TIMEOUT_S) == -signal.SIGKILL
    assert not info(recording.out).finished

    fixed = tmp_path / "fixed.mcap"
    result = subprocess.run(
        cli_command("recover", str(recording.out), "--out", str(fixed)),
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    total = re.search(r"recovered (\d+) messages", result.stdout)
    assert total is not None, result.stdout
    per_channel = {
        topic: int(n)
        for n, topic in re.findall(r"^\s+(\d+)\s+(\S+)$", result.stdout, re.M)
    }
    assert set(per_channel) == set(KEYS)
    assert sum(per_channel.values()) == int(total.group(1))

    messages = read_all(fixed)
    numbers = [number(data) for _t, _s, data, _lt in messages]
    assert len(flushed) <= len(numbers) <= len(flushed) + len(in_flight)
    assert numbers == list(range(len(numbers)))
    assert len(numbers) == int(total.group(1))
    for topic, schema_name, data, _lt in messages:
        assert data == payload(topic, number(data))
        assert schema_name.startswith("fsw_scheduler.")
    for key in KEYS:
        assert per_channel[key] == sum(m[0] == key for m in messages)
    times = [m[3] for m in messages]
    assert times == sorted(times)


def test_sigint_finishes_recording(
    peer: tuple[zenoh.Session, str], recording: Recording
) -> None:
    """Tests that SIGINT makes record exit 0 with a finished file."""
    session, _ = peer
    publishers = publish_matched(session, recording)
    sent = range(30)
    put_range(publishers, sent)
    wait_until(
        lambda: count_on_disk(recording.out) >= len(sent),
        FLUSH_WAIT_S,
        what="the periodic flush",
    )
    recording.process.send_signal(signal.SIGINT)
    assert recording.process.wait(TIMEOUT_S) == 0, recording.log()
    description = info(recording.out)
    assert description.finished
    messages = read_all(recording.out)
    assert [number(m[2]) for m in messages] == list(sent)
    assert f"recorded {len(sent)} messages on {len(KEYS)} keys" in (
        recording.log()
    )
    (name, meta), *_ = description.metadata
    assert name == "fsw_scheduler.recording"
    assert meta["key"].startswith("fsw/") and meta["start_time"].endswith("Z")
    assert {"fsw-scheduler", "eclipse-zenoh"} <= set(meta)


def test_info_prints_channels_counts_and_span() -> None:
    """Tests that info prints every channel, its count and the time span."""
    result = subprocess.run(
        cli_command("info", str(PAPER)),
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    description = info(PAPER)
    assert result.stdout.strip() == format_info(description)
    assert f"messages:  {description.message_count}" in result.stdout
    assert f"({description.start_ns} ns)" in result.stdout
    assert f"({description.end_ns} ns)" in result.stdout
    assert f"duration:  {description.duration_ns / 1e9:.3f} s" in (
        result.stdout
    )
    with open(PAPER, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics is not None
    counts = summary.statistics.channel_message_counts
    for channel in summary.channels.values():
        line = re.search(
            rf"^\s+{re.escape(channel.topic)}\s+(\d+)\s+(\S+)$",
            result.stdout,
            re.M,
        )
        assert line is not None, channel.topic
        assert int(line.group(1)) == counts[channel.id]
        schema = summary.schemas[channel.schema_id]
        assert line.group(2) == schema.name


def test_replay_burst_publishes_included_in_order(
    peer: tuple[zenoh.Session, str],
) -> None:
    """Tests that replay --burst --include publishes matches in order."""
    session, endpoint = peer
    included = ("fsw/sat1/telemetry/**", "fsw/sat1/scheduler/goals")
    with open(PAPER, "rb") as f:
        expected = [
            (channel.topic, message.data)
            for _schema, channel, message in make_reader(f).iter_messages(
                log_time_order=True
            )
            if "/telemetry/" in channel.topic
            or channel.topic.endswith("/goals")
        ]
    assert len(expected) > 20
    subscriber = session.declare_subscriber(
        "fsw/sat1/**", zenoh.handlers.FifoChannel(4 * len(expected))
    )
    try:
        # replay publishes as soon as its session is open; the subscriber
        # above exists before the process starts, and the process
        # connects to this peer only.
        flags = [arg for k in included for arg in ("--include", k)]
        result = subprocess.run(
            cli_command(
                "replay", str(PAPER), "--burst", *flags, *bus_flags(endpoint)
            ),
            capture_output=True,
            text=True,
            timeout=TIMEOUT_S,
            check=False,
        )
        assert result.returncode == 0, result.stderr
        assert f"published {len(expected)} messages" in result.stderr
        received: list[tuple[str, bytes]] = []

        def take() -> bool:
            while (sample := subscriber.try_recv()) is not None:
                received.append(
                    (str(sample.key_expr), sample.payload.to_bytes())
                )
            return len(received) >= len(expected)

        wait_until(take, TIMEOUT_S, what="the replayed messages")
        take()
    finally:
        subscriber.undeclare()
    assert received == expected


@pytest.mark.parametrize(
    "args",
    [
        ("recover", "{file}", "--out", "{out}"),
        ("info", "{file}"),
        ("replay", "{file}", "--verify"),
    ],
    ids=["recover", "info", "replay-verify"],
)
def test_non_mcap_file_is_bad_input(
    tmp_path: Path, args: tuple[str, ...]
) -> None:
    """Tests that a file that is not MCAP is reported as bad input."""
    bogus = tmp_path / "bogus.mcap"
    bogus.write_bytes(b"not an mcap file at all")
    out = tmp_path / "out.mcap"
    result = subprocess.run(
        cli_command(*(a.format(file=bogus, out=out) for a in args)),
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
        check=False,
    )
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    assert "bogus.mcap" in result.stderr


def test_replay_refuses_a_bus_with_a_live_scheduler(
    peer: tuple[zenoh.Session, str],
) -> None:
    """Tests that replay will not drive a live scheduler of the recorded
    spacecraft: exit 2 naming it and the way out; --remap to another
    spacecraft and --into-live publish."""
    session, endpoint = peer
    token = session.liveliness().declare_token("fsw/sat1/scheduler/alive")
    subscriber = session.declare_subscriber(
        "fsw/**", zenoh.handlers.FifoChannel(10_000)
    )
    try:
        refused = subprocess.run(
            cli_command("replay", str(PAPER), "--burst", *bus_flags(endpoint)),
            capture_output=True,
            text=True,
            timeout=TIMEOUT_S,
            check=False,
        )
        assert refused.returncode == 2, refused.stderr
        assert "a scheduler of fsw/sat1 is alive" in refused.stderr
        assert "--into-live" in refused.stderr
        assert subscriber.try_recv() is None  # nothing was published
        for extra in (["--remap", "fsw/sat1=fsw/sat9"], ["--into-live"]):
            done = subprocess.run(
                cli_command(
                    "replay",
                    str(PAPER),
                    "--burst",
                    *extra,
                    *bus_flags(endpoint),
                ),
                capture_output=True,
                text=True,
                timeout=TIMEOUT_S,
                check=False,
            )
            assert done.returncode == 0, done.stderr
            assert "published" in done.stderr
    finally:
        subscriber.undeclare()
        token.undeclare()


def test_verify_on_a_bus_recording_says_it_is_not_a_journal(
    tmp_path: Path,
) -> None:
    """Tests that ``replay --verify`` on an MCAP file of bus traffic that
    is not a scheduler journal exits 2 saying so, without a traceback."""
    from mcap.writer import Writer

    path = tmp_path / "traffic.mcap"
    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start()
        schema = writer.register_schema(
            name="clock", encoding=SchemaEncoding.JSONSchema, data=b"{}"
        )
        channel = writer.register_channel(
            topic="fsw/sat1/clock",
            message_encoding=MessageEncoding.JSON,
            schema_id=schema,
        )
        writer.add_message(
            channel, log_time=1, data=b'{"now": 1}', publish_time=1
        )
        writer.finish()
    result = subprocess.run(
        cli_command("replay", str(path), "--verify"),
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
        check=False,
    )
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    assert "not a scheduler journal" in result.stderr
