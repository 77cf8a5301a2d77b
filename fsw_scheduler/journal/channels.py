"""Channels as the journal declares them: topic, encoding and schema.

One table for the two places that show the scheduler to Foxglove: the
MCAP journal (:mod:`fsw_scheduler.journal.writer`) and the live view
(:mod:`fsw_scheduler.view.live`). Both name a channel after its key, encode
its messages as JSON and describe them with the same JSON Schema under the
same name, so one layout (``docs/foxglove-layout.json``) opens a recording
and a running scheduler alike. No MCAP, no bus: plain data.
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING, Any, NamedTuple

from ..wire import topics as keys
from .annotate import DERIVED, schema_lookup

if TYPE_CHECKING:
    from collections.abc import Callable, Mapping

__all__ = [
    "JSON",
    "JSON_SCHEMA",
    "LIVE_SUFFIXES",
    "ChannelSpec",
    "channel_spec",
    "live_channels",
    "schema_data",
    "schema_name",
]

#: The MCAP / Foxglove message encoding of every scheduler channel.
JSON = "json"
#: The schema encoding of their schemas.
JSON_SCHEMA = "jsonschema"

#: What a watcher of the bus sees at fixed keys: the node's outputs, the
#: inputs others publish to it, then the channels the journal derives and
#: does not publish (level checks and ``foxglove.Log``), which a watcher
#: can derive too. Keys with a name chunk (dispatches, reports, levels)
#: are not known in advance: see :func:`channel_spec`.
LIVE_SUFFIXES: tuple[str, ...] = (
    keys.PLAN,
    keys.STATUS,
    keys.DISPATCH,
    keys.PROFILES,
    keys.SOLVES,
    keys.NODE_INFO,
    keys.TERM,
    keys.SNAPSHOT,
    keys.GOALS,
    keys.CLOCK,
    *(suffix for suffix, published in DERIVED.items() if not published),
)


class ChannelSpec(NamedTuple):
    """One channel, as a journal registers it.

    Attributes
    ----------
    topic
        The full key, e.g. ``fsw/sat1/scheduler/plan``.
    message_encoding
        ``json``.
    schema_name
        The schema's name (``fsw_scheduler.plan``, ``foxglove.Log``), or
        ``""`` for a key without a schema.
    schema_encoding
        ``jsonschema``, or ``""`` without a schema.
    schema
        The schema's text (compact JSON, sorted keys), or ``b""``.
    """

    topic: str
    message_encoding: str
    schema_name: str
    schema_encoding: str
    schema: bytes


def schema_data(schema: Mapping[str, Any]) -> bytes:
    """The text a schema is registered with: compact JSON, sorted keys."""
    return json.dumps(schema, sort_keys=True, separators=(",", ":")).encode()


def schema_name(schema: Mapping[str, Any], topic: str) -> str:
    """A schema's registered name: its ``title``, else ``$id``, else the
    first topic that used it."""
    return str(schema.get("title") or schema.get("$id") or topic)


def channel_spec(
    topic: str, lookup: Callable[[str], Mapping[str, Any] | None]
) -> ChannelSpec:
    """The JSON channel of ``topic``, with its schema if it has one.

    Parameters
    ----------
    topic
        The full key.
    lookup
        Topic -> JSON Schema or None (:func:`schema_lookup`).
    """
    schema = lookup(topic)
    if schema is None:
        return ChannelSpec(topic, JSON, "", "", b"")
    return ChannelSpec(
        topic,
        JSON,
        schema_name(schema, topic),
        JSON_SCHEMA,
        schema_data(schema),
    )


def live_channels(spacecraft: str) -> list[ChannelSpec]:
    """The channels a live view declares before any message arrives.

    Parameters
    ----------
    spacecraft
        The spacecraft id of the keys.

    Returns
    -------
    list of ChannelSpec
        One per :data:`LIVE_SUFFIXES`, in that order.
    """
    topics = keys.Topics(spacecraft)
    lookup = schema_lookup(spacecraft)
    return [channel_spec(topics.key(s), lookup) for s in LIVE_SUFFIXES]
