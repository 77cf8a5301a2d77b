"""Tests of the decoding of journal and bus samples into engine events."""

from __future__ import annotations

from fsw_scheduler.engine.events import InputRejected
from fsw_scheduler.runtime.inputs import InputDecoder
from fsw_scheduler.wire import messages
from fsw_scheduler.wire.topics import DROPPED, Topics

LEVEL = "fsw/sat1/telemetry/resources/battery"


def _rejection(message: messages.Dropped) -> InputRejected:
    topics = Topics("sat1")
    event = InputDecoder(topics, "bus").event(
        topics.key(DROPPED), messages.encode(message)
    )
    assert isinstance(event, InputRejected)
    return event


def test_dropped_telemetry_becomes_a_rejection_naming_the_limit() -> None:
    """Tests that a ``scheduler/dropped`` record is the rejection of the
    samples' key and kind, with the count, inbox-bytes and its value."""
    event = _rejection(
        messages.Dropped(LEVEL, "resource_level", 3, 900, 1 << 20)
    )
    assert (event.key, event.kind, event.goal_id) == (
        LEVEL,
        "resource_level",
        None,
    )
    (issue,) = event.errors
    assert issue.reason == (
        "dropped: 3 samples unread, the inbox held its limit of 1048576 "
        "bytes (inbox-bytes); send less often (the latest per key is kept "
        "while one waits), or raise inbox-bytes"
    )


def test_a_sample_larger_than_the_inbox_is_named_as_such() -> None:
    """Tests that a dropped sample larger than inbox-bytes is told to be
    smaller, not to be sent less often."""
    event = _rejection(
        messages.Dropped(LEVEL, "resource_level", 1, 2000, 1000)
    )
    (issue,) = event.errors
    assert issue.reason.startswith("dropped: 1 sample unread, one of 2000 ")
    assert "larger than the whole inbox (1000 bytes, inbox-bytes)" in (
        issue.reason
    )
