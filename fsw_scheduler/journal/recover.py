"""Recovering an MCAP file that a crash left unfinished.

An unfinished file has no summary or footer, so ``mcap.reader.make_reader``
cannot open it. :func:`recover` reads every complete record it can (chunk
by chunk, stopping at the first damaged or cut one) and rewrites them into
a finished file.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import IO, TYPE_CHECKING

from mcap.exceptions import McapError
from mcap.opcode import Opcode
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
from mcap.writer import CompressionType, Writer

from .writer import LIBRARY, MCAP_MAGIC, RECORD_HEAD, PathLike

if TYPE_CHECKING:
    from collections.abc import Iterator, Sequence

    from mcap.records import McapRecord

__all__ = [
    "is_finished",
    "iter_complete_records",
    "recover",
    "scan_messages",
]


def is_finished(path: PathLike) -> bool:
    """Whether a file ends with the closing magic (it has a footer)."""
    with open(path, "rb") as f:
        f.seek(0, io.SEEK_END)
        if f.tell() < 2 * len(MCAP_MAGIC):
            return False
        f.seek(-len(MCAP_MAGIC), io.SEEK_END)
        return f.read(len(MCAP_MAGIC)) == MCAP_MAGIC


def iter_complete_records(stream: IO[bytes]) -> Iterator[McapRecord]:
    """Yield every complete, well-formed record up to the first defect.

    Framing is checked before parsing (the whole record body must be
    there), chunks are decompressed and CRC-checked, and reading stops at
    the footer or at the first truncated or damaged record: on a file cut
    by a crash that is the end of the last write that reached the OS.
    """
    magic = stream.read(len(MCAP_MAGIC))
    if magic != MCAP_MAGIC:
        if len(magic) < len(MCAP_MAGIC) and MCAP_MAGIC.startswith(magic):
            return  # killed while the magic was written: nothing after it
        raise McapError("not an MCAP file: bad magic")
    known = {int(op) for op in Opcode}
    while True:
        head = stream.read(RECORD_HEAD.size)
        if len(head) < RECORD_HEAD.size:
            return
        opcode, length = RECORD_HEAD.unpack(head)
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


def scan_messages(
    path: PathLike,
) -> tuple[dict[int, Schema], dict[int, Channel], list[Message]]:
    """Every complete schema, channel and message of a file, even unfinished.

    Read with :func:`iter_complete_records`, up to the first defect; a
    message of a channel not (yet) declared is left out.

    Returns
    -------
    schemas, channels, messages
        Schemas and channels by id, and the messages in file order.
    """
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    messages: list[Message] = []
    with open(path, "rb") as f:
        for record in iter_complete_records(f):
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
        writer.start(profile="", library=LIBRARY)
        for record in iter_complete_records(fin):
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
