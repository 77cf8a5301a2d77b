"""Tests of fsw_scheduler.recording: MCAP writing, recovery and reading."""

from __future__ import annotations

import json
import os
import queue
import shutil
import signal
import subprocess
import sys
import textwrap
import threading
import time
from typing import TYPE_CHECKING

import pytest
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.well_known import MessageEncoding, SchemaEncoding

from fsw_scheduler.journal.info import format_info, info
from fsw_scheduler.journal.reader import iter_messages
from fsw_scheduler.journal.recover import recover
from fsw_scheduler.journal.writer import RecordedMessage, Recorder, split_name

if TYPE_CHECKING:
    from pathlib import Path

T0 = 1_700_000_000_000_000_000
CLOCK_SCHEMA = {"title": "Clock", "type": "object", "required": ["now"]}
TOPICS = (
    "fsw/sat1/clock",
    "fsw/sat1/telemetry/resources/battery",
    "fsw/sat1/scheduler/status",
)


def _messages(n: int) -> list[RecordedMessage]:
    """N messages cycling over TOPICS, 1 ms apart, publish 1 us earlier."""
    out = []
    for i in range(n):
        topic = TOPICS[i % len(TOPICS)]
        payload = json.dumps({"i": i, "topic": topic}).encode()
        log = T0 + i * 1_000_000
        out.append(RecordedMessage(topic, payload, log, log - 1_000))
    return out


def _write(path: Path, messages: list[RecordedMessage], **kw) -> Recorder:
    with Recorder(path, **kw) as rec:
        for m in messages:
            rec.write(
                m.topic,
                m.payload,
                log_time_ns=m.log_time_ns,
                publish_time_ns=m.publish_time_ns,
            )
    return rec


def _read_with_mcap(path: Path) -> list[tuple[str, bytes, int, int]]:
    with open(path, "rb") as f:
        return [
            (ch.topic, m.data, m.log_time, m.publish_time)
            for _s, ch, m in make_reader(f).iter_messages(log_time_order=True)
        ]


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_round_trip(tmp_path: Path, compression: str) -> None:
    """Tests that written messages read back identically both ways."""
    path = tmp_path / "rec.mcap"
    sent = _messages(50)
    schemas = {TOPICS[0]: CLOCK_SCHEMA, TOPICS[2]: {"type": "object"}}
    _write(path, sent, compression=compression, schemas=schemas)

    assert list(iter_messages(path)) == sent
    assert _read_with_mcap(path) == [tuple(m)[:4] for m in sent]


def test_channels_and_schemas(tmp_path: Path) -> None:
    """Tests that each key gets a JSON channel and shared schemas once."""
    path = tmp_path / "rec.mcap"
    shared = {"title": "Level", "type": "object"}

    def schema_of(topic: str) -> dict | None:
        return shared if "telemetry" in topic else None

    with Recorder(path, schemas=schema_of) as rec:
        for i, key in enumerate(["a", "b", "c"]):
            rec.write(
                f"fsw/sat1/telemetry/resources/{key}",
                b"{}",
                log_time_ns=T0 + i,
            )
        rec.write("fsw/sat1/clock", b'{"now": 1}', log_time_ns=T0 + 9)

    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    assert len(summary.schemas) == 1
    (schema,) = summary.schemas.values()
    assert schema.encoding == SchemaEncoding.JSONSchema
    assert schema.name == "Level"
    assert json.loads(schema.data) == shared
    by_topic = {ch.topic: ch for ch in summary.channels.values()}
    assert len(by_topic) == 4
    assert all(
        ch.message_encoding == MessageEncoding.JSON for ch in by_topic.values()
    )
    assert by_topic["fsw/sat1/clock"].schema_id == 0
    assert by_topic["fsw/sat1/telemetry/resources/a"].schema_id == schema.id


def test_log_time_order_and_filters(tmp_path: Path) -> None:
    """Tests that reading sorts by log time and honours topic/time filters."""
    path = tmp_path / "rec.mcap"
    sent = _messages(30)
    _write(path, list(reversed(sent)))

    assert list(iter_messages(path)) == sent
    window = list(
        iter_messages(
            path,
            topics=[TOPICS[1]],
            start_ns=sent[4].log_time_ns,
            end_ns=sent[20].log_time_ns,
        )
    )
    assert window == [m for m in sent[4:20] if m.topic == TOPICS[1]]


def test_info_and_format(tmp_path: Path) -> None:
    """Tests that info reports counts, schema names and the time span."""
    path = tmp_path / "rec.mcap"
    sent = _messages(9)
    _write(path, sent, schemas={TOPICS[0]: CLOCK_SCHEMA})

    d = info(path)
    assert d.finished
    assert d.message_count == 9
    assert d.start_ns == sent[0].log_time_ns
    assert d.end_ns == sent[-1].log_time_ns
    assert d.duration_ns == 8_000_000
    counts = {c.topic: (c.message_count, c.schema_name) for c in d.channels}
    assert counts == {
        TOPICS[0]: (3, "Clock"),
        TOPICS[1]: (3, ""),
        TOPICS[2]: (3, ""),
    }
    text = format_info(d)
    assert "messages:  9" in text
    assert "Clock" in text
    assert TOPICS[1] in text


def test_periodic_flush_reaches_the_file(tmp_path: Path) -> None:
    """Tests that the flush interval puts open chunks on disk unclosed."""
    path = tmp_path / "rec.mcap"
    rec = Recorder(path, flush_interval_ns=10_000_000, chunk_size=1 << 20)
    try:
        for m in _messages(25):  # 25 ms of log time, flushes every 10 ms
            rec.write(m.topic, m.payload, log_time_ns=m.log_time_ns)
        assert rec.flush_count == 2
        on_disk = info(path)
        assert not on_disk.finished
        assert on_disk.message_count == 21  # up to the flush at 20 ms

        assert rec.tick(T0 + 30_000_000)  # idle tick past the interval
        assert info(path).message_count == 25
        assert not rec.tick(T0 + 31_000_000)
    finally:
        rec.close()
    assert info(path).finished


def test_recover_unfinished_file(tmp_path: Path) -> None:
    """Tests that recover makes an unfinished file readable by make_reader."""
    path = tmp_path / "rec.mcap"
    sent = _messages(40)
    rec = Recorder(path, flush_interval_ns=5_000_000, chunk_size=512)
    try:
        for m in sent:
            rec.write(
                m.topic,
                m.payload,
                log_time_ns=m.log_time_ns,
                publish_time_ns=m.publish_time_ns,
            )
        rec.flush()
        snapshot = tmp_path / "snapshot.mcap"
        shutil.copy(path, snapshot)
    finally:
        rec.close()

    with open(snapshot, "rb") as f, pytest.raises(McapError):
        list(make_reader(f).iter_messages())
    fixed = tmp_path / "fixed.mcap"
    kept = recover(snapshot, fixed)
    assert sum(kept.values()) == 40
    assert kept == {t: sum(m.topic == t for m in sent) for t in TOPICS}
    assert _read_with_mcap(fixed) == [tuple(m)[:4] for m in sent]
    assert info(fixed).finished


def test_recover_any_truncation(tmp_path: Path) -> None:
    """Tests that recover keeps a growing prefix at every truncation point."""
    path = tmp_path / "rec.mcap"
    sent = _messages(60)
    _write(path, sent, chunk_size=256, compression="lz4")
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    fixed = tmp_path / "fixed.mcap"
    previous = 0
    step = max(1, len(data) // 120)
    for size in [*range(0, len(data), step), len(data)]:
        cut.write_bytes(data[:size])
        kept = sum(recover(cut, fixed).values())
        got = [m.payload for m in iter_messages(fixed)]
        assert got == [m.payload for m in sent[:kept]]
        assert kept >= previous
        previous = kept
    assert previous == len(sent)


def test_recover_rejects_non_mcap(tmp_path: Path) -> None:
    """Tests that recover refuses a file that is not MCAP at all."""
    bogus = tmp_path / "bogus.mcap"
    bogus.write_bytes(b"definitely not an mcap file")
    with pytest.raises(McapError, match="magic"):
        recover(bogus, tmp_path / "out.mcap")


def test_split_size(tmp_path: Path) -> None:
    """Tests that split_size spreads a recording over several valid files."""
    path = tmp_path / "rec.mcap"
    sent = _messages(300)
    rec = _write(path, sent, chunk_size=1024, split_size=4096)

    assert len(rec.paths) >= 3
    assert rec.paths[0] == path
    assert rec.paths[1] == tmp_path / "rec-001.mcap"
    assert rec.paths[2] == split_name(path, 2) == tmp_path / "rec-002.mcap"
    total = 0
    for part in rec.paths:
        assert info(part).finished
        total += len(_read_with_mcap(part))
    assert total == len(sent)
    assert list(iter_messages(rec.paths)) == sent


def test_split_duration(tmp_path: Path) -> None:
    """Tests that split_duration_ns starts a new file per time span."""
    path = tmp_path / "rec.mcap"
    sent = _messages(30)  # 29 ms span
    rec = _write(path, sent, split_duration_ns=10_000_000)

    assert [info(p).message_count for p in rec.paths] == [10, 10, 10]
    assert list(iter_messages(rec.paths)) == sent


def test_closed_recorder_rejects_writes(tmp_path: Path) -> None:
    """Tests that writing after close raises instead of corrupting."""
    rec = _write(tmp_path / "rec.mcap", _messages(1))
    assert rec.closed
    with pytest.raises(ValueError, match="closed"):
        rec.write("fsw/sat1/clock", b"{}", log_time_ns=T0)


_WRITER_SCRIPT = textwrap.dedent(
    """
    import json, sys, time
    from fsw_scheduler.journal.writer import Recorder

    rec = Recorder(sys.argv[1], flush_interval_ns=int(sys.argv[2]))
    i = 0
    flushes = 0
    while True:
        now = time.time_ns()
        rec.write("fsw/sat1/clock", json.dumps({"now": i}).encode(),
                  log_time_ns=now)
        i += 1
        if rec.flush_count != flushes:
            flushes = rec.flush_count
            print(f"flushed {i} {now}", flush=True)
        time.sleep(0.002)
    """
)


def test_kill_9_then_recover(tmp_path: Path) -> None:
    """Tests that a SIGKILLed recorder loses at most about a flush interval."""
    path = tmp_path / "killed.mcap"
    interval_ns = 300_000_000
    lines: queue.Queue[str] = queue.Queue()
    with subprocess.Popen(
        [sys.executable, "-c", _WRITER_SCRIPT, str(path), str(interval_ns)],
        stdout=subprocess.PIPE,
        text=True,
    ) as proc:

        def pump() -> None:
            assert proc.stdout is not None
            for line in proc.stdout:
                lines.put(line)

        reader = threading.Thread(target=pump, daemon=True)
        reader.start()
        try:
            flushed = 0
            for _ in range(3):
                _, count, _at = lines.get(timeout=10).split()
                flushed = int(count)
            killed_at = time.time_ns()
            os.kill(proc.pid, signal.SIGKILL)
            proc.wait(timeout=10)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait(timeout=10)
            reader.join(timeout=10)
    assert proc.returncode == -signal.SIGKILL

    fixed = tmp_path / "fixed.mcap"
    kept = recover(path, fixed)["fsw/sat1/clock"]
    assert kept >= flushed
    with open(fixed, "rb") as f:
        got = [
            (json.loads(m.data)["now"], m.log_time)
            for _s, _c, m in make_reader(f).iter_messages()
        ]
    assert [n for n, _ in got] == list(range(kept))  # a gapless prefix
    assert killed_at - got[-1][1] < 2 * interval_ns
