"""Reading the messages of one or more MCAP files in log-time order.

Yields :class:`~fsw_scheduler.journal.writer.RecordedMessage` items from
finished and unfinished files alike (an unfinished one is read as far as
it is intact), across the parts of a split recording.
"""

from __future__ import annotations

import heapq
import os
from typing import TYPE_CHECKING

# Re-exported: what a damaged or foreign journal raises, for callers above
# the journal that report it without importing mcap themselves.
from mcap.exceptions import McapError as McapError
from mcap.reader import make_reader
from mcap.well_known import MessageEncoding

from .recover import is_finished, scan_messages
from .writer import (
    JSON_ENCODING,
    ZENOH_ENCODING_KEY,
    PathLike,
    RecordedMessage,
)

if TYPE_CHECKING:
    from collections.abc import Iterable, Iterator, Sequence

    from mcap.records import (
        Channel,
    )

__all__ = [
    "iter_messages",
]


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
    if not is_finished(path):
        _schemas, channels, messages = scan_messages(path)
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
