"""Tests of a commander's bounded wait for its standby's word
(``scheduler/saved``) before a goal verdict, on real Zenoh sessions."""

from __future__ import annotations

import threading

import msgspec
import zenoh

from fsw_scheduler.bus.confirm import StandbyConfirmations, is_promise
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


def test_a_verdict_is_held_until_the_word_a_silent_standby_once() -> None:
    """Tests the verdicts held back: free as soon as a standby says it
    holds their record (or a later one); one whose wait ran out goes out
    with an alarm, and later ones are not held until a standby answers
    again; a standby that cannot save is said once as an alarm."""
    commander, standby = _pair()
    keys = topics.Topics("sat1")
    woken = threading.Event()
    alarms: list[str] = []
    try:
        confirmations = StandbyConfirmations(
            commander, keys, wait_s=0.3, say=alarms.append, wake=woken.set
        )
        wait_matching(standby, keys.key(topics.SAVED), 10)

        def say(seq: int, fault: str = "") -> None:
            woken.clear()
            saved = messages.Saved("A:1", seq, "B", not fault, fault)
            standby.put(keys.key(topics.SAVED), messages.encode(saved))
            assert woken.wait(10)

        assert confirmations.healthy()  # nothing said yet, nothing late
        assert confirmations.hold("A:1", 2, ["v2"], ("g2",))
        free, left = confirmations.release()
        assert free == [] and left is not None and 0 < left <= 0.3
        assert not confirmations.kept("g2")
        say(2)
        assert confirmations.release() == (["v2"], None)
        assert confirmations.kept("g2")  # said again: it need not wait
        assert confirmations.hold("A:1", 1, ["v1"])  # an earlier record
        assert confirmations.release() == (["v1"], None)
        assert confirmations.hold("A:1", 3, ["v3"], ("g3",))  # no word
        free, left = confirmations.release()
        assert free == [] and left is not None
        threading.Event().wait(left)  # its deadline
        assert confirmations.release() == (["v3"], None)
        assert not confirmations.kept("g3")
        (late,) = alarms
        assert "no standby said within 0.3 s" in late
        assert "lost if both computers are reset" in late
        assert not confirmations.healthy()  # the alarm stands
        assert not confirmations.hold("A:1", 4, ["v4"])  # not held now
        say(5, "OSError: [Errno 28] No space left on device")
        assert confirmations.hold("A:1", 5, ["v5"], ("g5",))  # held again
        assert confirmations.release() == (["v5"], None)
        assert not confirmations.kept("g5")  # in the standby's memory only
        assert not confirmations.healthy()  # it cannot save
        say(6, "OSError: [Errno 28] No space left on device")
        assert confirmations.hold("A:1", 6, ["v6"])
        assert confirmations.release() == (["v6"], None)
        assert len(alarms) == 2 and "cannot save its copy" in alarms[1]
        assert (confirmations.late, confirmations.volatile) == (1, 2)
        say(7)
        assert confirmations.healthy()  # saved again: the episode ends
        confirmations.close()
    finally:
        standby.close()
        commander.close()


def test_only_a_goal_accepted_waits() -> None:
    """Tests which outputs wait: a goal accepted, not a rejection (a
    flood of bad inputs must not cost a save each), plans or other
    statuses."""
    status = messages.Status(state="ok", plan_id=1, event="goal_accepted")
    assert is_promise(status)
    for event in ("goal_rejected", "plan", "alarm"):
        assert not is_promise(msgspec.structs.replace(status, event=event))
