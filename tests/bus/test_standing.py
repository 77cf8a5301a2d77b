"""Tests of the conditions a status query names until they end."""

from __future__ import annotations

from fsw_scheduler.bus.standing import (
    FENCE,
    JOURNAL,
    MAX_DETAIL,
    STANDBY_LATE,
    Standing,
)
from fsw_scheduler.wire import messages


def test_a_query_says_what_stands_and_forgets_what_ended() -> None:
    """Tests the answer while conditions stand: degraded (never better
    than the engine's word), each condition named in a fixed order, not
    durable while the journal fails; and the engine's own word again once
    every condition has ended."""
    standing = Standing()
    ok = messages.Status(state="ok", plan_id=3, event="query")
    assert standing.apply(ok) is ok
    assert standing.put(STANDBY_LATE, "no standby said within 0.5 s")
    assert not standing.put(STANDBY_LATE, "no standby said within 0.5 s")
    assert standing.put(FENCE, "receiver R fences term 7" + "x" * 1000)
    assert standing.put(JOURNAL, "journal: No space left on device")
    asked = standing.apply(ok)
    assert asked.state == "degraded" and not asked.durable
    assert list(standing.held()) == [FENCE, JOURNAL, STANDBY_LATE]
    assert asked.detail.startswith("fence: receiver R fences term 7")
    assert len(standing.held()[FENCE]) == MAX_DETAIL
    error = messages.Status(state="error", plan_id=3, detail="loop died")
    worse = standing.apply(error)
    assert worse.state == "error" and worse.detail.startswith("loop died; ")
    assert standing.put(JOURNAL, None)
    assert standing.apply(ok).durable
    assert standing.put(FENCE, None) and standing.put(STANDBY_LATE, None)
    assert not standing.put(FENCE, None)
    assert standing.apply(ok) == ok
