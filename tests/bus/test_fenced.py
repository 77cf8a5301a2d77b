"""Tests of the commander's watch on the receivers' fences
(:mod:`fsw_scheduler.bus.fenced`) on a real Zenoh session."""

from __future__ import annotations

import msgspec
import zenoh

from fsw_scheduler.bus.fenced import FenceWatch
from fsw_scheduler.wire import messages, topics

SC = topics.Topics("sat1")


def _session() -> zenoh.Session:
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')
    config.insert_json5("scouting/multicast/enabled", "false")
    return zenoh.open(config)


def _fence(session: zenoh.Session, term: int) -> zenoh.Queryable:
    """A receiver's fence answering ``term``."""
    payload = msgspec.json.encode(messages.Term(term, "receiver"))
    return session.declare_queryable(
        SC.key(f"{topics.FENCES}/receiver"),
        lambda query: query.reply(query.key_expr, payload),
    )


def test_a_fence_that_does_not_answer_keeps_its_alarm() -> None:
    """Tests that a fence above the term raises the alarm; that a later
    question no fence answers (the receiver gone quiet) keeps it, rather
    than read as no fence above; and that a fence answering the term
    again clears it."""
    with _session() as session:
        watch = FenceWatch(session, SC, every_s=0.0)
        above = _fence(session, 7)
        alarm = watch.check(1)
        assert alarm is not None and "fences term 7" in alarm, alarm
        above.undeclare()
        assert watch.check(1) == alarm
        assert watch.standing == alarm
        level = _fence(session, 1)
        assert watch.check(1) is None
        assert watch.standing is None
        level.undeclare()
        assert watch.check(1) is None
