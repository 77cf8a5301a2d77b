"""Tests of the node's inbox: coalescing that never hides an outcome."""

from __future__ import annotations

from fsw_scheduler.bus.inbox import Inbox

KEY = "fsw/sat1/telemetry/activities/Downlink"


def _report(state: str) -> bytes:
    return b'{"task": "Downlink", "state": "' + state.encode() + b'", "at": 4}'


def _drain(inbox: Inbox) -> list[bytes]:
    out = []
    while (item := inbox.get(0.001)) is not None:
        out.append(item[2])
    return out


def test_running_reports_coalesce() -> None:
    """Tests that a newer report replaces a waiting 'running' one."""
    inbox = Inbox(max_goals=4, max_bytes=1 << 20)
    inbox.put_latest("activity_report", KEY, _report("running"))
    inbox.put_latest("activity_report", KEY, _report("completed"))
    assert _drain(inbox) == [_report("completed")]
    assert inbox.superseded == 1


def test_a_failure_is_never_replaced_by_a_later_report() -> None:
    """Tests that 'failed' then 'running' on one key both reach the loop."""
    inbox = Inbox(max_goals=4, max_bytes=1 << 20)
    inbox.put_latest("activity_report", KEY, _report("failed"))
    inbox.put_latest("activity_report", KEY, _report("running"))
    inbox.put_latest("activity_report", KEY, _report("completed"))
    # The running one is coalesced into the completion behind the failure.
    assert _drain(inbox) == [_report("failed"), _report("completed")]
    assert inbox.superseded == 1


def test_levels_still_coalesce() -> None:
    """Tests that telemetry levels keep only the latest value per key."""
    inbox = Inbox(max_goals=4, max_bytes=1 << 20)
    key = "fsw/sat1/telemetry/resources/battery"
    for level in (b"1", b"2", b"3"):
        inbox.put_latest("resource_level", key, level)
    assert _drain(inbox) == [b"3"]
    assert inbox.superseded == 2
