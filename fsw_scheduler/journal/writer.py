"""MCAP recording of bus traffic: crash-safe, rotating, splitting writing.

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
flush. A journal that must survive a power loss without paying a sync at
every flush calls :meth:`Recorder.sync` where it matters (the node: once
per step that commands, group-committing the step's records) and passes
``durable=True``, which syncs the folder when a file is created and the
file when it is finished, so that a new part's name is on disk too (a
file synced into a directory entry that was not is lost with it). An
unfinished file has no summary or footer, so
``mcap.reader.make_reader`` cannot open it:
:func:`fsw_scheduler.journal.recover.recover` rewrites it.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import struct
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import IO, Any, Literal, NamedTuple

from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import CompressionType, Writer

from ..wire.topics import journal_key
from .channels import schema_data, schema_name
from .metadata import METADATA_CRC_KEY, metadata_crc

log = logging.getLogger("fsw_scheduler.journal")

__all__ = [
    "RecordedMessage",
    "Recorder",
    "mcap_encoding",
    "split_name",
    "sync_folder",
]


Compression = Literal["zstd", "lz4", "none"]


#: A JSON Schema (as a dict) per exact topic, or a function of the topic.
SchemaSource = (
    Mapping[str, Mapping[str, Any]] | Callable[[str], Mapping[str, Any] | None]
)


PathLike = str | os.PathLike[str]


#: The MCAP magic: the first and the last bytes of a finished file.
MCAP_MAGIC = b"\x89MCAP0\r\n"


#: The head of every MCAP record: opcode (1 byte), body length (8 bytes,
#: little-endian).
RECORD_HEAD = struct.Struct("<BQ")


_COMPRESSION = {
    "zstd": CompressionType.ZSTD,
    "lz4": CompressionType.LZ4,
    "none": CompressionType.NONE,
}


#: The library named in the header of every file the journal writes.
LIBRARY = "fsw_scheduler.recording"


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
    durable
        Sync the folder after a file is created and the file when it is
        finished (see :meth:`sync` for the records in between).

    Attributes
    ----------
    paths
        Every file started so far, in order.
    message_count
        Messages written over all files.
    flush_count
        Periodic and explicit flushes done.
    sync_count
        Syncs to the disk done by :meth:`sync`.
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
        open_now: bool = True,
        durable: bool = False,
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
        self._durable = durable
        self.paths: list[Path] = []
        self.message_count = 0
        self.flush_count = 0
        self.sync_count = 0
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
        if open_now:
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
            and encoding, every ``scheduler/dispatch/<task>`` on one
            (:func:`~fsw_scheduler.wire.topics.journal_key`).
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
        topic = journal_key(topic)
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
        pairs = {
            str(k): str(v) for k, v in data.items() if k != METADATA_CRC_KEY
        }
        pairs[METADATA_CRC_KEY] = metadata_crc(name, pairs)
        self._metadata.append((name, pairs))
        if self._writer is None:
            return  # no part open (a disk error): written at the next one
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
        if self._writer is None:
            return  # no part open (a disk error): the session goes on
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

    def sync(self) -> None:
        """Flush, then put the file on the disk (``fsync``) now.

        What precedes a command must survive a power loss, not only the
        death of the process (``flush`` leaves it in the page cache).
        """
        if self._closed or self._writer is None or self._file is None:
            return
        self.flush()
        if not self._fsync:  # flush() synced already
            os.fsync(self._file.fileno())
        self.sync_count += 1

    def check_linked(self) -> None:
        """Raise if the open part was deleted (or its whole folder).

        Writes then land in an unlinked file that no restart finds: a
        disk error like any other, so the journal goes down and is
        reopened in a new part with a snapshot.

        Raises
        ------
        FileNotFoundError
            If the open part has no name left on the disk.
        """
        if self._closed or self._file is None:
            return
        if os.fstat(self._file.fileno()).st_nlink == 0:
            raise FileNotFoundError(
                errno.ENOENT,
                "journal part deleted while open (its folder removed?); "
                "what it held since the last rotation is gone",
                str(self.paths[-1]),
            )

    def close(self) -> None:
        """Finish the current file (summary, footer) and close it."""
        if self._closed:
            return
        self._closed = True
        self._close_part()

    # -- internals -------------------------------------------------------

    def reopen(self) -> Path:
        """After a write error: leave the broken part as a crash leaves it
        (the next start finishes it) and open the next one.

        Raises
        ------
        OSError
            If the next part cannot be opened either (the disk is still
            full); the recorder stays without an open part.
        """
        broken, self._file, self._writer = self._file, None, None
        if broken is not None:
            with contextlib.suppress(OSError, ValueError):
                broken.close()
        try:
            self._open_part()
        except BaseException:
            half, self._file, self._writer = self._file, None, None
            if half is not None:
                with contextlib.suppress(OSError, ValueError):
                    half.close()
            raise
        return self.paths[-1]

    def _open_part(self) -> None:
        path = split_name(self._base, len(self.paths))
        path.parent.mkdir(parents=True, exist_ok=True)
        self._file = open(path, "wb")  # noqa: SIM115 - closed in _close_part
        self._writer = Writer(
            self._file,
            chunk_size=self._chunk_size,
            compression=self._compression,
        )
        self._writer.start(profile="", library=LIBRARY)
        self.paths.append(path)
        if self._durable:
            # The new name must be on disk for its content to be found.
            sync_folder(path.parent)
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
            if self._fsync or self._durable:
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
            data = schema_data(schema)
            schema_id = self._schema_ids.get(data, 0)
            if schema_id == 0:
                schema_id = writer.register_schema(
                    name=schema_name(schema, topic),
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


def sync_folder(folder: Path) -> None:
    """``fsync`` a directory: files created, renamed or removed in it
    stay so after a power loss."""
    fd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


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


class OrderedWriter:
    """Writes inputs and outputs in processing order, log times rising.

    The node's journal: ``log_time`` is the wall clock, but never equal
    to or before the previous message's, so the file's log-time order is
    the processing order replay needs. With no recorder it writes nothing.
    """

    def __init__(
        self, recorder: Recorder | None, wall_ns: Callable[[], int]
    ) -> None:
        self.recorder = recorder
        self._wall_ns = wall_ns
        self._last = 0
        #: Why the journal is not written now (a disk error), else None:
        #: the node goes on without durability and says so.
        self.fault: str | None = None
        #: Every record written since it was last taken (None: not
        #: kept): what a hot standby is sent, journal or not.
        self.tap: list[tuple[str, bytes]] | None = None

    def write(self, key: str, payload: bytes) -> None:
        """Journal one record (and keep it in :attr:`tap`)."""
        if self.tap is not None:
            self.tap.append((key, payload))
        if self.recorder is None or self.fault is not None:
            return
        stamp = max(self._wall_ns(), self._last + 1)
        self._last = stamp
        try:
            self.recorder.write(key, payload, log_time_ns=stamp)
        except OSError as error:
            self.fail(error)

    def flush(self) -> None:
        """Flush the recorder (the page cache: a crash loses nothing)."""
        if self.recorder is not None and self.fault is None:
            try:
                self.recorder.flush()
                self.recorder.check_linked()
            except OSError as error:
                self.fail(error)

    def sync(self) -> None:
        """Flush and sync the recorder (the disk: a power loss loses
        nothing); one call per step commits all of its records."""
        if self.recorder is not None and self.fault is None:
            try:
                self.recorder.sync()
                self.recorder.check_linked()
            except OSError as error:
                self.fail(error)

    def rotate(self) -> Path | None:
        """Continue in the next part (None: the disk refused it; the
        journal is down, as after any write error, and is retried)."""
        if self.recorder is None or self.fault is not None:
            return None
        try:
            return self.recorder.rotate()
        except OSError as error:
            # Finishing the part (summary, footer) or opening the next
            # can meet a full disk too: inside the guard, like a write.
            self.fail(error)
            return None

    def fail(self, error: OSError) -> None:
        """Stop writing: the journal is down (see :attr:`fault`)."""
        self.fault = f"{type(error).__name__}: {error}"
        log.error("journal write failed: %s; going on without it", error)

    def resume(self) -> bool:
        """Try to write again, in a new part (True: the journal is back;
        the caller writes the settings and a snapshot first)."""
        if self.recorder is None or self.fault is None:
            return self.fault is None
        try:
            self.recorder.reopen()
        except OSError as error:
            log.debug("journal still unavailable: %s", error)
            return False
        self.fault = None
        return True

    @property
    def last_ns(self) -> int:
        """Log time of the last message written."""
        return self._last
