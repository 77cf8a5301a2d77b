"""MCAP recording of bus traffic: crash-safe writing, recovery and reading.

One MCAP channel per key expression and encoding. JSON samples go to a
``message_encoding="json"`` channel that carries a ``jsonschema`` schema
when one is known for its key, else none (schema id 0). Samples of another
Zenoh encoding keep it: CBOR, Protobuf, CDR and FlatBuffers map to the MCAP
well-known encodings, anything else is written under the Zenoh encoding's
own name; such channels record the full Zenoh encoding in their metadata
(``zenoh.encoding``) so a replay publishes the bytes as they came. Times
are nanoseconds: ``log_time`` when the recorder saw the message,
``publish_time`` when the publisher stamped it. File-level metadata
records and attachments (:meth:`Recorder.add_metadata`,
:meth:`Recorder.add_attachment`) describe the session.

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
    "AttachmentInfo",
    "ChannelInfo",
    "McapInfo",
    "RecordedMessage",
    "Recorder",
    "format_info",
    "info",
    "info_dict",
    "iter_messages",
    "mcap_encoding",
    "read_attachments",
    "read_metadata",
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
JSON_ENCODING = "application/json"
#: Channel metadata key holding the Zenoh encoding of non-JSON samples.
ZENOH_ENCODING_KEY = "zenoh.encoding"
#: Zenoh encodings (without their ``;schema`` suffix) that have an MCAP
#: well-known message encoding.
_WELL_KNOWN = {
    "application/json": MessageEncoding.JSON,
    "text/json": MessageEncoding.JSON,
    "application/cbor": MessageEncoding.CBOR,
    "application/protobuf": MessageEncoding.Protobuf,
    "application/cdr": MessageEncoding.CDR,
    "application/flatbuffers": MessageEncoding.Flatbuffer,
}


def mcap_encoding(zenoh_encoding: str) -> str:
    """The MCAP ``message_encoding`` for samples of a Zenoh encoding.

    Parameters
    ----------
    zenoh_encoding
        As ``str(sample.encoding)``, e.g. ``application/json`` or
        ``zenoh/bytes``; a ``;schema`` suffix is ignored here.

    Returns
    -------
    str
        ``json``, ``cbor``, ``protobuf``, ``cdr`` or ``flatbuffer`` for
        the well-known ones, else the Zenoh encoding itself (MCAP allows
        any name; readers then show the raw bytes).
    """
    base = zenoh_encoding.split(";", 1)[0].strip()
    return _WELL_KNOWN.get(base, base or "zenoh/bytes")


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
    encoding
        The Zenoh encoding to publish it with on replay:
        ``application/json`` for ``json`` channels, else the channel's
        recorded ``zenoh.encoding`` (or its message encoding).
    """

    topic: str
    payload: bytes
    log_time_ns: int
    publish_time_ns: int
    encoding: str = JSON_ENCODING


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
    only_json
        Skip (and count in :attr:`skipped`) messages whose encoding is not
        JSON instead of recording them under their own encoding.

    Attributes
    ----------
    paths
        Every file started so far, in order.
    message_count
        Messages written over all files.
    flush_count
        Periodic and explicit flushes done.
    skipped
        Messages refused by ``only_json`` (non-JSON encodings).
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
        only_json: bool = False,
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
        self._only_json = only_json
        self.paths: list[Path] = []
        self.message_count = 0
        self.flush_count = 0
        self.skipped = 0
        # Re-written at the head of every split part, so each part
        # describes its session on its own.
        self._metadata: list[tuple[str, dict[str, str]]] = []
        self._file: IO[bytes] | None = None
        self._writer: Writer | None = None
        self._closed = False
        # Per-file state, reset by _open_part().
        self._channel_ids: dict[tuple[str, str], int] = {}
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
        encoding: str = JSON_ENCODING,
    ) -> bool:
        """Append one message.

        Parameters
        ----------
        topic
            Key expression the message was seen on; one channel per topic
            and encoding.
        payload
            The bytes, written unchanged.
        log_time_ns
            Reception time in ns; also drives periodic flushing and
            time-based splitting.
        publish_time_ns
            Publisher's time stamp in ns; defaults to ``log_time_ns``.
        encoding
            The sample's Zenoh encoding (see :func:`mcap_encoding`).

        Returns
        -------
        bool
            False when ``only_json`` skipped it.

        Raises
        ------
        ValueError
            If the recorder is closed.
        """
        if self._closed:
            raise ValueError("write to a closed Recorder")
        message_encoding = mcap_encoding(encoding)
        if self._only_json and message_encoding != MessageEncoding.JSON:
            self.skipped += 1
            return False
        self._maybe_split(log_time_ns)
        writer = self._writer
        assert writer is not None
        channel_id = self._channel_ids.get((topic, encoding))
        if channel_id is None:
            channel_id = self._register(topic, encoding)
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
        return True

    def add_metadata(self, name: str, data: Mapping[str, str]) -> None:
        """Write a metadata record (``name`` plus string pairs).

        Foxglove shows them under the file's metadata; ``mcap info`` and
        :func:`read_metadata` list them. They are written again at the
        head of every later split part.

        Parameters
        ----------
        name
            Record name, e.g. ``fsw_scheduler.session``.
        data
            Keys and values, both strings.
        """
        if self._closed:
            raise ValueError("add_metadata to a closed Recorder")
        pairs = {str(k): str(v) for k, v in data.items()}
        self._metadata.append((name, pairs))
        assert self._writer is not None
        self._writer.add_metadata(name, pairs)
        self._dirty = True

    def add_attachment(
        self,
        name: str,
        data: bytes,
        *,
        media_type: str = "application/octet-stream",
        log_time_ns: int = 0,
        create_time_ns: int | None = None,
    ) -> None:
        """Attach a file (problem, settings, picture) to the current part.

        Parameters
        ----------
        name
            File name shown by readers, e.g. ``problem.json``.
        data
            Its bytes.
        media_type
            e.g. ``application/json``, ``application/toml``, ``image/png``.
        log_time_ns, create_time_ns
            When it belongs in the session and when it was made
            (default: ``log_time_ns``).
        """
        if self._closed:
            raise ValueError("add_attachment to a closed Recorder")
        assert self._writer is not None
        self._writer.add_attachment(
            create_time=(
                log_time_ns if create_time_ns is None else create_time_ns
            ),
            log_time=log_time_ns,
            name=name,
            media_type=media_type,
            data=bytes(data),
        )
        self._dirty = True

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
        for name, pairs in self._metadata:
            self._writer.add_metadata(name, pairs)

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

    def _register(self, topic: str, encoding: str) -> int:
        writer = self._writer
        assert writer is not None
        message_encoding = mcap_encoding(encoding)
        schema_id = 0
        metadata: dict[str, str] = {}
        schema = None
        if message_encoding == MessageEncoding.JSON:
            schema = self._schema_of(topic)
        if encoding.split(";", 1)[0].strip() != JSON_ENCODING:
            metadata[ZENOH_ENCODING_KEY] = encoding
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
            message_encoding=message_encoding,
            schema_id=schema_id,
            metadata=metadata,
        )
        self._channel_ids[(topic, encoding)] = channel_id
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


def recover(
    src: PathLike,
    dst: PathLike,
    *,
    attachments: Sequence[tuple[str, str, bytes]] = (),
) -> dict[str, int]:
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
    attachments
        Files to attach as well, as ``(name, media type, bytes)`` (e.g.
        the pictures of a session, drawn after it ended); their log time
        is the last message's.

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
    last_ns = 0
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
            if isinstance(record, Message):
                last_ns = max(last_ns, record.log_time)
        for name, media_type, data in attachments:
            writer.add_attachment(last_ns, last_ns, name, media_type, data)
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
class AttachmentInfo:
    """One attachment of a recording (its bytes: :func:`read_attachments`).

    Attributes
    ----------
    name
        File name.
    media_type
        e.g. ``application/json``.
    size
        Bytes.
    log_time_ns
        Where it belongs in the session.
    """

    name: str
    media_type: str
    size: int
    log_time_ns: int = 0


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
    metadata
        Metadata records as ``(name, {key: value})``, in file order.
    attachments
        Attachments, in file order.
    """

    path: Path
    finished: bool
    message_count: int
    start_ns: int
    end_ns: int
    channels: tuple[ChannelInfo, ...] = field(default_factory=tuple)
    metadata: tuple[tuple[str, dict[str, str]], ...] = ()
    attachments: tuple[AttachmentInfo, ...] = ()

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
                metadata=tuple(read_metadata(path)),
                attachments=tuple(
                    AttachmentInfo(
                        a.name, a.media_type, len(a.data), a.log_time
                    )
                    for a in _attachments(path)
                ),
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
        metadata=tuple(read_metadata(path)),
        attachments=tuple(
            AttachmentInfo(a.name, a.media_type, len(a.data), a.log_time)
            for a in _attachments(path)
        ),
    )


def _records_of(path: PathLike, kind: type) -> list[Any]:
    """Every record of ``kind`` in file order, finished file or not."""
    with open(path, "rb") as f:
        return [r for r in _iter_complete_records(f) if isinstance(r, kind)]


def _attachments(path: PathLike) -> list[Attachment]:
    if _is_finished(path):
        with open(path, "rb") as f:
            return list(make_reader(f).iter_attachments())
    return _records_of(path, Attachment)


def read_metadata(path: PathLike) -> list[tuple[str, dict[str, str]]]:
    """The metadata records of a recording, in file order.

    Parameters
    ----------
    path
        An MCAP file (finished or not).

    Returns
    -------
    list
        ``(name, {key: value})`` pairs.
    """
    if _is_finished(path):
        with open(path, "rb") as f:
            found = list(make_reader(f).iter_metadata())
    else:
        found = _records_of(path, Metadata)
    return [(m.name, dict(m.metadata)) for m in found]


def read_attachments(path: PathLike) -> dict[str, bytes]:
    """The attachments of a recording by name (the last of a name wins).

    Parameters
    ----------
    path
        An MCAP file (finished or not).

    Returns
    -------
    dict of str to bytes
        Attachment name to its bytes.
    """
    return {a.name: a.data for a in _attachments(path)}


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
        encoding = (
            ""
            if ch.message_encoding == MessageEncoding.JSON
            else f"  [{ch.message_encoding}]"
        )
        lines.append(
            f"  {ch.topic:<{width}}  {ch.message_count:>8}  {schema}"
            f"{encoding}"
        )
    if d.metadata:
        lines.append(f"metadata:  {len(d.metadata)}")
        for name, pairs in d.metadata:
            lines.append(f"  {name}")
            for key, value in pairs.items():
                shown = value if len(value) <= 60 else value[:57] + "..."
                lines.append(f"    {key}: {shown}")
    if d.attachments:
        lines.append(f"attachments: {len(d.attachments)}")
        for a in d.attachments:
            lines.append(f"  {a.name}  {a.media_type}  {a.size} bytes")
    return "\n".join(lines)


def info_dict(description: McapInfo) -> dict[str, Any]:
    """:class:`McapInfo` as JSON-ready data (``info --json``).

    Parameters
    ----------
    description
        As returned by :func:`info`.

    Returns
    -------
    dict
        ``file``, ``finished``, ``messages``, ``start_ns``, ``end_ns``,
        ``start`` / ``end`` (UTC, ISO 8601), ``duration_s``, ``channels``
        (topic, messages, schema, encoding), ``metadata`` (name to its
        pairs; a repeated name keeps the first) and ``attachments`` (name,
        media type, size).
    """
    d = description
    metadata: dict[str, dict[str, str]] = {}
    for name, pairs in d.metadata:
        metadata.setdefault(name, pairs)
    return {
        "file": str(d.path),
        "finished": d.finished,
        "messages": d.message_count,
        "start_ns": d.start_ns,
        "end_ns": d.end_ns,
        "start": _utc(d.start_ns),
        "end": _utc(d.end_ns),
        "duration_s": d.duration_ns / 1e9,
        "channels": [
            {
                "topic": c.topic,
                "messages": c.message_count,
                "schema": c.schema_name,
                "encoding": c.message_encoding,
            }
            for c in d.channels
        ],
        "metadata": metadata,
        "attachments": [
            {"name": a.name, "media_type": a.media_type, "size": a.size}
            for a in d.attachments
        ],
    }


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


def _replay_encoding(channel: Channel) -> str:
    """The Zenoh encoding a channel's messages are published with."""
    recorded = channel.metadata.get(ZENOH_ENCODING_KEY)
    if recorded:
        return recorded
    if channel.message_encoding == MessageEncoding.JSON:
        return JSON_ENCODING
    return channel.message_encoding


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
            channel = channels[m.channel_id]
            topic = channel.topic
            if (
                (topics is None or topic in topics)
                and (start_ns is None or m.log_time >= start_ns)
                and (end_ns is None or m.log_time < end_ns)
            ):
                yield RecordedMessage(
                    topic,
                    m.data,
                    m.log_time,
                    m.publish_time,
                    _replay_encoding(channel),
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
                channel.topic,
                m.data,
                m.log_time,
                m.publish_time,
                _replay_encoding(channel),
            )
