"""Tests of a commander's bounded wait for its standby's word
(``scheduler/saved``) before a goal verdict, on real Zenoh sessions."""

from __future__ import annotations

import time

import msgspec
import zenoh

from fsw_scheduler.bus.confirm import StandbyConfirmations, holds_verdict
from fsw_scheduler.bus.session import (
    listening_endpoints,
    loopback_config,
    wait_matching,
)
from fsw_scheduler.wire import messages, topics


def _pair() -> tuple[zenoh.Session, zenoh.Session]:
    """Two peers on loopback: the commander's session, the standby's."""
    commander = zenoh.open(loopback_config(listen="tcp/127.0.0.1:0"))
    (endpoint,) = listening_endpoints(commander)
    standby = zenoh.open(loopback_config(listen=None, connect=[endpoint]))
    return commander, standby


def test_a_verdict_waits_for_the_word_a_silent_standby_once() -> None:
    """Tests the wait: it ends as soon as a standby says it holds the
    record (or a later one); one that ran out makes the next return at
    once, until a standby answers again."""
    commander, standby = _pair()
    keys = topics.Topics("sat1")
    try:
        confirmations = StandbyConfirmations(commander, keys, wait_s=0.3)
        wait_matching(standby, keys.key(topics.SAVED), 10)

        def say(seq: int) -> None:
            standby.put(
                keys.key(topics.SAVED),
                messages.encode(messages.Saved("A:1", seq, "B", True)),
            )

        say(2)
        assert confirmations.wait("A:1", 2)
        assert confirmations.wait("A:1", 1)  # an earlier record: held
        began = time.monotonic()
        assert not confirmations.wait("A:1", 3)  # no word: the bound
        assert time.monotonic() - began >= 0.29
        began = time.monotonic()
        assert not confirmations.wait("A:1", 4)  # lagging: no second wait
        assert time.monotonic() - began < 0.1
        assert not confirmations.wait("A:2", 1)
        say(4)  # the standby is back: waits again
        deadline = time.monotonic() + 10
        while not confirmations.wait("A:1", 4):
            assert time.monotonic() < deadline
        assert (confirmations.late, confirmations.volatile) == (1, 0)
        confirmations.close()
    finally:
        standby.close()
        commander.close()


def test_only_a_goal_verdict_waits() -> None:
    """Tests which steps wait: those whose outputs accept a goal, not
    a rejection (a flood of bad inputs must not cost a save each), plans
    or other statuses."""
    status = messages.Status(state="ok", plan_id=1, event="goal_accepted")
    other = msgspec.structs.replace(status, event="plan")
    assert holds_verdict([(topics.STATUS, status)])
    assert not holds_verdict(
        [
            (
                topics.STATUS,
                msgspec.structs.replace(status, event="goal_rejected"),
            )
        ]
    )
    assert not holds_verdict([(topics.STATUS, other)])
    assert not holds_verdict([])
