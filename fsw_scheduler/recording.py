"""MCAP recording of bus traffic: crash-safe writing, recovery and reading.

One MCAP channel per key expression, ``message_encoding="json"``; a channel
carries a ``jsonschema`` schema when one is known for its key, else none
(schema id 0). Times are nanoseconds: ``log_time`` when the recorder saw the
message, ``publish_time`` when the publisher stamped it.

This module never imports :mod:`zenoh`; :mod:`fsw_scheduler.bus.record`
connects it to the bus.

Crash safety
------------
``mcap.writer.Writer`` keeps the chunk in progress in memory until it grows
past ``chunk_size`` (1 MiB by default), so a ``kill -9`` loses everything
since the last full chunk. :class:`Recorder` therefore uses small chunks
(64 KiB by default) *and* calls the writer's public ``Writer.flush()``
(finishes the chunk in progress, writes it with its message index, flushes
the stream; on mcap releases without it, the writer's private chunk
finaliser is called instead, see :func:`_finish_chunk`) whenever
``flush_interval_ns`` of log time has passed since the last flush, checked
on every :meth:`Recorder.write` and on :meth:`Recorder.tick` (the bus
recorder ticks while idle). Data then sits in the OS page cache, which
survives the death of the process; ``fsync=True`` also asks for it to reach
the disk, which protects against power loss at the cost of a disk sync per
flush. An unfinished file has no summary or footer, so
``mcap.reader.make_reader`` cannot open it: :func:`recover` rewrites it.
"""

from __future__ import annotations

import heapq
import io
import json
import os
import struct
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any, Literal, NamedTuple

from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.reader import make_reader
from mcap.records import (
    Attachment,
    Channel,
    Chunk,
    DataEnd,
    Footer,
    Message,
    Metadata,
    Schema,
)
from mcap.stream_reader import StreamReader, breakup_chunk
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import CompressionType, Writer

if TYPE_CHECKING:
    from mcap.records import McapRecord

__all__ = [
    "ChannelInfo",
    "McapInfo",
    "RecordedMessage",
    "Recorder",
    "format_info",
    "info",
    "iter_messages",
    "recover",
    "split_name",
]

Compression = Literal["zstd", "lz4", "none"]
#: A JSON Schema (as a dict) per exact topic, or a function of the topic.
SchemaSource = (
    Mapping[str, Mapping[str, Any]] | Callable[[str], Mapping[str, Any] | None]
)
PathLike = str | os.PathLike[str]

_MAGIC = b"\x89MCAP0\r\n"
_RECORD_HEAD = struct.Struct("<BQ")
_COMPRESSION = {
    "zstd": CompressionType.ZSTD,
    "lz4": CompressionType.LZ4,
    "none": CompressionType.NONE,
}
_LIBRARY = "fsw_scheduler.recording"


class RecordedMessage(NamedTuple):
    """One message read back from a recording.

    Attributes
    ----------
    topic
        Channel topic: the Zenoh key expression it was published on.
    payload
        The message bytes (JSON).
    log_time_ns
        When it was recorded, ns since the Unix epoch.
    publish_time_ns
        When it was published, ns since the Unix epoch (the log time when
        the publisher did not stamp it).
    """

    topic: str
    payload: bytes
    log_time_ns: int
    publish_time_ns: int


def split_name(path: PathLike, part: int) -> Path:
    """Return the file name of part ``part`` of a split recording.

    Part 0 is ``path`` itself; part ``n`` is ``<stem>-<nnn><suffix>``.

    Parameters
    ----------
    path
        The name given to :class:`Recorder`.
    part
        Zero-based part number.

    Returns
    -------
    pathlib.Path
        For ``rec.mcap``: ``rec.mcap``, ``rec-001.mcap``, ``rec-002.mcap``...
    """
    path = Path(path)
    if part == 0:
        return path
    return path.with_name(f"{path.stem}-{part:03d}{path.suffix or '.mcap'}")


class Recorder:
    """Write bus messages to MCAP files, crash-safe and optionally split.

    Parameters
    ----------
    path
        Output file; split continuations go next to it (:func:`split_name`).
    compression
        Chunk compression: ``"zstd"``, ``"lz4"`` or ``"none"``.
    chunk_size
        Uncompressed bytes after which the writer closes a chunk by itself.
    flush_interval_ns
        Log-time span after which the chunk in progress is written out and
        the file flushed; bounds what a crash can lose.
    split_size
        Start a new file when the current one has reached this many bytes
        (checked before each message, so a file can exceed it by about one
        chunk). ``None`` never splits on size.
    split_duration_ns
        Start a new file when a message's log time is this far past the
        first message of the current file. ``None`` never splits on time.
    schemas
        JSON Schemas by exact topic, or a function returning the schema of
        a topic (or ``None``). A schema is registered once per file however
        many topics share it; its name is its ``title``, else its ``$id``,
        else the first topic that used it.
    fsync
        Also ``os.fsync`` the file on every flush.

    Attributes
    ----------
    paths
        Every file started so far, in order.
    message_count
        Messages written over all files.
    flush_count
        Periodic and explicit flushes done.
    """

    def __init__(
        self,
        path: PathLike,
        *,
        compression: Compression = "zstd",
        chunk_size: int = 64 * 1024,
        flush_interval_ns: int = 1_000_000_000,
        split_size: int | None = None,
        split_duration_ns: int | None = None,
        schemas: SchemaSource | None = None,
        fsync: bool = False,
    ) -> None:
        if compression not in _COMPRESSION:
            raise ValueError(
                f"compression must be one of {sorted(_COMPRESSION)}, "
                f"not {compression!r}"
            )
        if chunk_size <= 0 or flush_interval_ns <= 0:
            raise ValueError("chunk_size and flush_interval_ns must be > 0")
        if split_size is not None and split_size <= 0:
            raise ValueError("split_size must be > 0")
        if split_duration_ns is not None and split_duration_ns <= 0:
            raise ValueError("split_duration_ns must be > 0")
        self._base = Path(path)
        self._compression = _COMPRESSION[compression]
        self._chunk_size = chunk_size
        self._flush_interval_ns = flush_interval_ns
        self._split_size = split_size
        self._split_duration_ns = split_duration_ns
        self._schema_of = _schema_lookup(schemas)
        self._fsync = fsync
        self.paths: list[Path] = []
        self.message_count = 0
        self.flush_count = 0
        self._file: IO[bytes] | None = None
        self._writer: Writer | None = None
        self._closed = False
        # Per-file state, reset by _open_part().
        self._channel_ids: dict[str, int] = {}
        self._schema_ids: dict[bytes, int] = {}
        self._sequences: dict[int, int] = {}
        self._part_start_ns: int | None = None
        self._last_flush_ns: int | None = None
        self._dirty = False
        self._open_part()

    # -- context manager -------------------------------------------------

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    # -- public API ------------------------------------------------------

    @property
    def path(self) -> Path:
        """The file being written now."""
        return self.paths[-1]

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` has been called."""
        return self._closed

    def write(
        self,
        topic: str,
        payload: bytes,
        *,
        log_time_ns: int,
        publish_time_ns: int | None = None,
    ) -> None:
        """Append one message.

        Parameters
        ----------
        topic
            Key expression the message was seen on; one channel per topic.
        payload
            JSON bytes, written unchanged.
        log_time_ns
            Reception time in ns; also drives periodic flushing and
            time-based splitting.
        publish_time_ns
            Publisher's time stamp in ns; defaults to ``log_time_ns``.

        Raises
        ------
        ValueError
            If the recorder is closed.
        """
        if self._closed:
            raise ValueError("write to a closed Recorder")
        self._maybe_split(log_time_ns)
        writer = self._writer
        assert writer is not None
        channel_id = self._channel_ids.get(topic)
        if channel_id is None:
            channel_id = self._register(topic)
        sequence = self._sequences[channel_id] = (
            self._sequences[channel_id] + 1
        )
        writer.add_message(
            channel_id=channel_id,
            log_time=log_time_ns,
            data=bytes(payload),
            publish_time=(
                log_time_ns if publish_time_ns is None else publish_time_ns
            ),
            sequence=sequence,
        )
        self.message_count += 1
        self._dirty = True
        if self._part_start_ns is None:
            self._part_start_ns = log_time_ns
        if self._last_flush_ns is None:
            self._last_flush_ns = log_time_ns
        self.tick(log_time_ns)

    def tick(self, now_ns: int) -> bool:
        """Flush if ``flush_interval_ns`` has passed since the last flush.

        Call it periodically while no messages arrive so that the last ones
        do not wait in memory for the next message.

        Parameters
        ----------
        now_ns
            Current time on the same clock as the log times.

        Returns
        -------
        bool
            Whether a flush happened.
        """
        if (
            self._closed
            or not self._dirty
            or self._last_flush_ns is None
            or now_ns - self._last_flush_ns < self._flush_interval_ns
        ):
            return False
        self.flush()
        self._last_flush_ns = now_ns
        return True

    @property
    def size(self) -> int:
        """Bytes written to the current file so far."""
        return self._file.tell() if self._file is not None else 0

    def rotate(self) -> Path:
        """Finish the current file and start the next part now.

        For writers that must choose where a file ends (a journal starts
        each file with a snapshot of the state). Returns the new file.
        """
        if self._closed:
            raise ValueError("rotate a closed Recorder")
        self._close_part()
        self._open_part()
        return self.path

    def flush(self) -> None:
        """Write the chunk in progress and flush the file now."""
        if self._closed or self._writer is None or self._file is None:
            return
        _finish_chunk(self._writer)
        self._file.flush()
        if self._fsync:
            os.fsync(self._file.fileno())
        self._dirty = False
        self.flush_count += 1

    def close(self) -> None:
        """Finish the current file (summary, footer) and close it."""
        if self._closed:
            return
        self._closed = True
        self._close_part()

    # -- internals -------------------------------------------------------

    def _open_part(self) -> None:
        path = split_name(self._base, len(self.paths))
        path.parent.mkdir(parents=True, exist_ok=True)
        self._file = open(path, "wb")  # noqa: SIM115 - closed in _close_part
        self._writer = Writer(
            self._file,
            chunk_size=self._chunk_size,
            compression=self._compression,
        )
        self._writer.start(profile="", library=_LIBRARY)
        self.paths.append(path)
        self._channel_ids = {}
        self._schema_ids = {}
        self._sequences = {}
        self._part_start_ns = None
        self._dirty = True

    def _close_part(self) -> None:
        if self._writer is not None:
            self._writer.finish()
        if self._file is not None:
            self._file.flush()
            if self._fsync:
                os.fsync(self._file.fileno())
            self._file.close()
        self._writer = None
        self._file = None

    def _maybe_split(self, log_time_ns: int) -> None:
        if self._part_start_ns is None or self._file is None:
            return
        too_big = (
            self._split_size is not None
            and self._file.tell() >= self._split_size
        )
        too_long = (
            self._split_duration_ns is not None
            and log_time_ns - self._part_start_ns >= self._split_duration_ns
        )
        if too_big or too_long:
            self._close_part()
            self._open_part()

    def _register(self, topic: str) -> int:
        writer = self._writer
        assert writer is not None
        schema_id = 0
        schema = self._schema_of(topic)
        if schema is not None:
            data = json.dumps(
                schema, sort_keys=True, separators=(",", ":")
            ).encode()
            schema_id = self._schema_ids.get(data, 0)
            if schema_id == 0:
                name = str(schema.get("title") or schema.get("$id") or topic)
                schema_id = writer.register_schema(
                    name=name,
                    encoding=SchemaEncoding.JSONSchema,
                    data=data,
                )
                self._schema_ids[data] = schema_id
        channel_id = writer.register_channel(
            topic=topic,
            message_encoding=MessageEncoding.JSON,
            schema_id=schema_id,
        )
        self._channel_ids[topic] = channel_id
        self._sequences[channel_id] = 0
        return channel_id


def _finish_chunk(writer: Writer) -> None:
    """Write out the chunk in progress, below ``chunk_size`` if need be."""
    public = getattr(writer, "flush", None)
    if public is not None:
        public()
    else:
        # Older mcap releases only finish a chunk once it is full; their
        # private finaliser is the only way to bound the crash-loss window.
        writer._Writer__finalize_chunk()  # type: ignore[attr-defined]


def _schema_lookup(
    schemas: SchemaSource | None,
) -> Callable[[str], Mapping[str, Any] | None]:
    if schemas is None:
        return lambda _topic: None
    if isinstance(schemas, Mapping):
        return schemas.get
    return schemas


# -- tolerant reading ------------------------------------------------------


def _is_finished(path: PathLike) -> bool:
    """Whether a file ends with the closing magic (it has a footer)."""
    with open(path, "rb") as f:
        f.seek(0, io.SEEK_END)
        if f.tell() < 2 * len(_MAGIC):
            return False
        f.seek(-len(_MAGIC), io.SEEK_END)
        return f.read(len(_MAGIC)) == _MAGIC


def _iter_complete_records(stream: IO[bytes]) -> Iterator[McapRecord]:
    """Yield every complete, well-formed record up to the first defect.

    Framing is checked before parsing (the whole record body must be
    there), chunks are decompressed and CRC-checked, and reading stops at
    the footer or at the first truncated or damaged record: on a file cut
    by a crash that is the end of the last write that reached the OS.
    """
    magic = stream.read(len(_MAGIC))
    if magic != _MAGIC:
        if not magic:
            return
        raise McapError("not an MCAP file: bad magic")
    known = {int(op) for op in Opcode}
    while True:
        head = stream.read(_RECORD_HEAD.size)
        if len(head) < _RECORD_HEAD.size:
            return
        opcode, length = _RECORD_HEAD.unpack(head)
        if opcode == 0 or opcode not in known:
            return  # zeros after a power cut, or garbage
        body = stream.read(length)
        if len(body) < length:
            return
        try:
            reader = StreamReader(
                io.BytesIO(head + body), skip_magic=True, emit_chunks=True
            )
            record = next(iter(reader.records))
            if isinstance(record, Chunk):
                inner = breakup_chunk(record, validate_crc=True)
        except Exception:  # any parse failure ends the usable data
            return
        if isinstance(record, Chunk):
            yield from inner
        else:
            yield record
        if isinstance(record, DataEnd | Footer):
            return


def _scan_messages(
    path: PathLike,
) -> tuple[dict[int, Schema], dict[int, Channel], list[Message]]:
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    messages: list[Message] = []
    with open(path, "rb") as f:
        for record in _iter_complete_records(f):
            if isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Channel):
                channels[record.id] = record
            elif isinstance(record, Message) and record.channel_id in channels:
                messages.append(record)
    return schemas, channels, messages


def recover(src: PathLike, dst: PathLike) -> dict[str, int]:
    """Rewrite a truncated or unfinished MCAP file into a finished one.

    Every complete record up to the first truncated or damaged one is kept
    (schemas, channels, messages, metadata, attachments), in file order and
    with its original times and sequence numbers; the result has a summary
    and footer, so ``mcap.reader.make_reader`` opens it. A finished file is
    simply copied record by record.

    Parameters
    ----------
    src
        The damaged file, e.g. left behind by ``kill -9``.
    dst
        Where to write the finished file (must differ from ``src``).

    Returns
    -------
    dict of str to int
        Messages kept per channel topic.

    Raises
    ------
    mcap.exceptions.McapError
        If ``src`` is not empty and does not start with the MCAP magic.
    """
    if Path(src).resolve() == Path(dst).resolve():
        raise ValueError("recover needs a destination distinct from src")
    kept: dict[str, int] = {}
    schema_map: dict[int, int] = {0: 0}
    channel_map: dict[int, int] = {}
    channels: dict[int, Channel] = {}
    with open(src, "rb") as fin, open(dst, "wb") as fout:
        writer = Writer(fout, compression=CompressionType.ZSTD)
        writer.start(profile="", library=_LIBRARY)
        for record in _iter_complete_records(fin):
            if isinstance(record, Schema):
                if record.id not in schema_map:
                    schema_map[record.id] = writer.register_schema(
                        record.name, record.encoding, record.data
                    )
            elif isinstance(record, Channel):
                if record.id not in channel_map:
                    channels[record.id] = record
                    channel_map[record.id] = writer.register_channel(
                        record.topic,
                        record.message_encoding,
                        schema_map.get(record.schema_id, 0),
                        dict(record.metadata),
                    )
            elif isinstance(record, Message):
                new_id = channel_map.get(record.channel_id)
                if new_id is None:
                    continue  # its channel was lost
                writer.add_message(
                    channel_id=new_id,
                    log_time=record.log_time,
                    data=record.data,
                    publish_time=record.publish_time,
                    sequence=record.sequence,
                )
                topic = channels[record.channel_id].topic
                kept[topic] = kept.get(topic, 0) + 1
            elif isinstance(record, Metadata):
                writer.add_metadata(record.name, dict(record.metadata))
            elif isinstance(record, Attachment):
                writer.add_attachment(
                    record.create_time,
                    record.log_time,
                    record.name,
                    record.media_type,
                    record.data,
                )
        writer.finish()
    return kept


# -- information -----------------------------------------------------------


@dataclass(frozen=True)
class ChannelInfo:
    """One channel of a recording.

    Attributes
    ----------
    topic
        Key expression.
    message_count
        Messages on it.
    schema_name
        Name of its schema, ``""`` when schemaless.
    message_encoding
        ``"json"`` for fsw_scheduler recordings.
    """

    topic: str
    message_count: int
    schema_name: str = ""
    message_encoding: str = MessageEncoding.JSON


@dataclass(frozen=True)
class McapInfo:
    """Summary of one recording.

    Attributes
    ----------
    path
        The file.
    finished
        Whether it has a footer; unfinished files are read tolerantly and
        should be passed through :func:`recover`.
    message_count
        Messages in the file.
    start_ns, end_ns
        Earliest and latest log time (0 when there are no messages).
    channels
        Per-channel details, sorted by topic.
    """

    path: Path
    finished: bool
    message_count: int
    start_ns: int
    end_ns: int
    channels: tuple[ChannelInfo, ...] = field(default_factory=tuple)

    @property
    def duration_ns(self) -> int:
        """Log-time span between the first and the last message."""
        return self.end_ns - self.start_ns


def info(path: PathLike) -> McapInfo:
    """Describe a recording: channels, counts, time span.

    Finished files are described from their summary section; unfinished
    ones by scanning their complete records.

    Parameters
    ----------
    path
        An MCAP file.

    Returns
    -------
    McapInfo
        The description.
    """
    path = Path(path)
    if _is_finished(path):
        with open(path, "rb") as f:
            summary = make_reader(f).get_summary()
        if summary is not None and summary.statistics is not None:
            stats = summary.statistics
            counts = stats.channel_message_counts
            channels = tuple(
                sorted(
                    (
                        ChannelInfo(
                            topic=ch.topic,
                            message_count=counts.get(ch.id, 0),
                            schema_name=_schema_name(summary.schemas, ch),
                            message_encoding=ch.message_encoding,
                        )
                        for ch in summary.channels.values()
                    ),
                    key=lambda c: c.topic,
                )
            )
            return McapInfo(
                path=path,
                finished=True,
                message_count=stats.message_count,
                start_ns=stats.message_start_time,
                end_ns=stats.message_end_time,
                channels=_merge_channels(channels),
            )
    schemas, channels_by_id, messages = _scan_messages(path)
    counts_by_id: dict[int, int] = {}
    for message in messages:
        counts_by_id[message.channel_id] = (
            counts_by_id.get(message.channel_id, 0) + 1
        )
    scanned = tuple(
        sorted(
            (
                ChannelInfo(
                    topic=ch.topic,
                    message_count=counts_by_id.get(ch.id, 0),
                    schema_name=_schema_name(schemas, ch),
                    message_encoding=ch.message_encoding,
                )
                for ch in channels_by_id.values()
            ),
            key=lambda c: c.topic,
        )
    )
    times = [m.log_time for m in messages]
    return McapInfo(
        path=path,
        finished=_is_finished(path),
        message_count=len(messages),
        start_ns=min(times, default=0),
        end_ns=max(times, default=0),
        channels=_merge_channels(scanned),
    )


def _schema_name(schemas: Mapping[int, Schema], channel: Channel) -> str:
    schema = schemas.get(channel.schema_id)
    return schema.name if schema is not None else ""


def _merge_channels(
    channels: Sequence[ChannelInfo],
) -> tuple[ChannelInfo, ...]:
    """Merge channels that share a topic (allowed by MCAP, rare)."""
    merged: dict[str, ChannelInfo] = {}
    for ch in channels:
        seen = merged.get(ch.topic)
        merged[ch.topic] = (
            ch
            if seen is None
            else ChannelInfo(
                topic=ch.topic,
                message_count=seen.message_count + ch.message_count,
                schema_name=seen.schema_name or ch.schema_name,
                message_encoding=seen.message_encoding,
            )
        )
    return tuple(merged.values())


def _utc(ns: int) -> str:
    stamp = datetime.fromtimestamp(ns // 1_000_000_000, tz=timezone.utc)
    return f"{stamp:%Y-%m-%dT%H:%M:%S}.{ns % 1_000_000_000:09d}Z"


def format_info(description: McapInfo) -> str:
    """Render :class:`McapInfo` as a short human-readable table.

    Parameters
    ----------
    description
        As returned by :func:`info`.

    Returns
    -------
    str
        Several lines, without a trailing newline.
    """
    d = description
    lines = [
        f"file:      {d.path}"
        + ("" if d.finished else "  (unfinished: run recover)"),
        f"messages:  {d.message_count}",
        f"start:     {_utc(d.start_ns)}  ({d.start_ns} ns)",
        f"end:       {_utc(d.end_ns)}  ({d.end_ns} ns)",
        f"duration:  {d.duration_ns / 1e9:.3f} s",
        f"channels:  {len(d.channels)}",
    ]
    width = max((len(c.topic) for c in d.channels), default=0)
    for ch in d.channels:
        schema = ch.schema_name or "(no schema)"
        lines.append(f"  {ch.topic:<{width}}  {ch.message_count:>8}  {schema}")
    return "\n".join(lines)


# -- reading messages ------------------------------------------------------


def iter_messages(
    path: PathLike | Sequence[PathLike],
    *,
    topics: Iterable[str] | None = None,
    start_ns: int | None = None,
    end_ns: int | None = None,
) -> Iterator[RecordedMessage]:
    """Iterate over recorded messages in log-time order.

    Parameters
    ----------
    path
        One file, or the parts of a split recording (merged by log time).
        Unfinished files are read tolerantly (all complete messages,
        sorted in memory).
    topics
        Keep only these exact topics; ``None`` keeps all.
    start_ns
        Keep messages with ``log_time >= start_ns``.
    end_ns
        Keep messages with ``log_time < end_ns``.

    Yields
    ------
    RecordedMessage
        Messages with equal log times keep their file order.
    """
    wanted = None if topics is None else frozenset(topics)
    if isinstance(path, str | os.PathLike):
        yield from _iter_one(path, wanted, start_ns, end_ns)
        return
    parts = [_iter_one(p, wanted, start_ns, end_ns) for p in path]
    yield from heapq.merge(*parts, key=lambda m: m.log_time_ns)


def _iter_one(
    path: PathLike,
    topics: frozenset[str] | None,
    start_ns: int | None,
    end_ns: int | None,
) -> Iterator[RecordedMessage]:
    if not _is_finished(path):
        _schemas, channels, messages = _scan_messages(path)
        messages.sort(key=lambda m: m.log_time)  # stable: keeps file order
        for m in messages:
            topic = channels[m.channel_id].topic
            if (
                (topics is None or topic in topics)
                and (start_ns is None or m.log_time >= start_ns)
                and (end_ns is None or m.log_time < end_ns)
            ):
                yield RecordedMessage(
                    topic, m.data, m.log_time, m.publish_time
                )
        return
    with open(path, "rb") as f:
        reader = make_reader(f)
        for _schema, channel, m in reader.iter_messages(
            topics=None if topics is None else sorted(topics),
            log_time_order=True,
            starting_at=start_ns,
            ending_before=end_ns,
        ):
            yield RecordedMessage(
                channel.topic, m.data, m.log_time, m.publish_time
            )
