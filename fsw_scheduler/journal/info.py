"""What an MCAP file holds: channels, counts, times, metadata, attachments.

:func:`info` describes a file (``fsw-scheduler info``), as text
(:func:`format_info`) or as a dict (:func:`info_dict`, ``--json``);
:func:`read_metadata` and :func:`read_attachments` read the session's
description records.
"""

from __future__ import annotations

import logging
import struct
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mcap.reader import make_reader
from mcap.records import (
    Attachment,
    Channel,
    Metadata,
    Schema,
)
from mcap.well_known import MessageEncoding

from .metadata import METADATA_CRC_KEY
from .recover import is_finished, iter_complete_records, scan_messages

log = logging.getLogger("fsw_scheduler.journal")

if TYPE_CHECKING:
    from collections.abc import Mapping, Sequence

    from .writer import PathLike

    pass

__all__ = [
    "AttachmentInfo",
    "ChannelInfo",
    "McapInfo",
    "format_info",
    "info",
    "info_dict",
    "read_attachments",
    "read_metadata",
]


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
    if is_finished(path):
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
    schemas, channels_by_id, messages = scan_messages(path)
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
        finished=is_finished(path),
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
        return [r for r in iter_complete_records(f) if isinstance(r, kind)]


def _attachments(path: PathLike) -> list[Attachment]:
    if is_finished(path):
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
    found = None
    if is_finished(path):
        try:
            with open(path, "rb") as f:
                found = list(make_reader(f).iter_metadata())
        except (ValueError, LookupError, struct.error, EOFError) as error:
            # The summary's index is not covered by a CRC the writer
            # fills: a damaged offset in it points into another record.
            # The records themselves are what the integrity walk checks.
            log.warning("%s: metadata index unreadable (%s)", path, error)
    if found is None:
        found = _records_of(path, Metadata)
    # The record's own CRC is the integrity walk's (check_file), not a
    # setting: readers never see it.
    return [
        (
            m.name,
            {k: v for k, v in m.metadata.items() if k != METADATA_CRC_KEY},
        )
        for m in found
    ]


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
            f"  {ch.topic:<{width}}  {ch.message_count:>8}  {schema}{encoding}"
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
