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
    assert inbox.bytes == 0  # both handed out, both bytes given back


def test_levels_still_coalesce() -> None:
    """Tests that telemetry levels keep only the latest value per key."""
    inbox = Inbox(max_goals=4, max_bytes=1 << 20)
    key = "fsw/sat1/telemetry/resources/battery"
    for level in (b"1", b"2", b"3"):
        inbox.put_latest("resource_level", key, level)
    assert _drain(inbox) == [b"3"]
    assert inbox.superseded == 2


LEVEL = "fsw/sat1/telemetry/resources/battery"


class _Clock:
    """The shell's monotonic seconds, moved by the test."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_dropped_telemetry_is_answered_once_per_key_and_interval() -> None:
    """Tests that telemetry dropped for spent bytes is answered: the first
    drop at once, the later ones counted into one answer when
    DROP_NOTICE_S has passed, and the answers go before waiting items."""
    from fsw_scheduler.bus.inbox import DROP_NOTICE_S
    from fsw_scheduler.wire.messages import Dropped

    clock = _Clock()
    inbox = Inbox(max_goals=4, max_bytes=100, seconds=clock)
    inbox.put_latest("resource_level", "fsw/sat1/other", b"x" * 90)
    inbox.put_latest("resource_level", LEVEL, b"1" * 20)  # dropped
    item = inbox.get(0.0)
    assert item is not None and item[:2] == ["dropped", LEVEL]
    assert item[2] == Dropped(LEVEL, "resource_level", 1, 20, 100)
    for size in (30, 200, 40):  # within the interval: held, counted
        inbox.put_latest("resource_level", LEVEL, b"2" * size)
    assert inbox.lost == 4
    waiting = inbox.get(0.0)  # the sample that spent the bytes
    assert waiting is not None and waiting[1] == "fsw/sat1/other"
    assert inbox.get(0.0) is None
    clock.now += DROP_NOTICE_S
    item = inbox.get(0.0)
    assert item is not None
    assert item[2] == Dropped(LEVEL, "resource_level", 3, 200, 100)
    assert inbox.get(0.0) is None
    # Answered longer than the interval ago: the next drop goes at once,
    # ahead of the sample that is waiting.
    clock.now += DROP_NOTICE_S
    inbox.put_latest("resource_level", "fsw/sat1/other", b"x" * 90)
    report = _report("completed")
    inbox.put_latest("activity_report", KEY, report * 2)
    item = inbox.get(0.0)
    assert item is not None
    assert item[2] == Dropped(KEY, "activity_report", 1, 2 * len(report), 100)
    waiting = inbox.get(0.0)
    assert waiting is not None and waiting[1] == "fsw/sat1/other"


def test_a_held_answer_wakes_a_waiting_loop() -> None:
    """Tests that get() waiting for an item returns the held answer to a
    drop when its interval ends, not after its whole timeout."""
    import time

    from fsw_scheduler.bus.inbox import DROP_NOTICE_S

    inbox = Inbox(max_goals=4, max_bytes=10)
    inbox.put_latest("resource_level", LEVEL, b"1" * 20)
    first = inbox.get(0.0)
    assert first is not None and first[2].count == 1
    inbox.put_latest("resource_level", LEVEL, b"1" * 20)
    started = time.monotonic()
    held = inbox.get(30.0)
    waited = time.monotonic() - started
    assert held is not None and held[0] == "dropped"
    assert DROP_NOTICE_S * 0.5 < waited < DROP_NOTICE_S + 5.0


def test_drops_on_too_many_keys_share_one_answer() -> None:
    """Tests that drops on more keys than MAX_DROP_KEYS are counted into
    one answer on the catch-all key, so the tallies stay bounded."""
    from fsw_scheduler.bus.inbox import MAX_DROP_KEYS

    inbox = Inbox(max_goals=4, max_bytes=1, others="fsw/sat1/**")
    extra = 7
    for n in range(MAX_DROP_KEYS + extra):
        inbox.put_latest("resource_level", f"{LEVEL}{n}", b"12")
    answers = []
    while (item := inbox.get(0.0)) is not None:
        answers.append(item[2])
    assert len(answers) == MAX_DROP_KEYS + 1
    assert sum(a.count for a in answers) == inbox.lost
    other = answers[-1]
    assert (other.key, other.kind, other.count) == (
        "fsw/sat1/**",
        "telemetry",
        extra,
    )


def test_a_sample_replacing_a_waiting_one_keeps_the_bytes_bound() -> None:
    """Tests that a sample too large for the bytes left is dropped (and
    answered) even when it would replace the one waiting on its key."""
    inbox = Inbox(max_goals=4, max_bytes=100)
    inbox.put_latest("resource_level", LEVEL, b"1" * 10)
    inbox.put_latest("resource_level", LEVEL, b"2" * 200)
    assert (inbox.lost, inbox.superseded, inbox.bytes) == (1, 0, 10)
    answer, waiting = inbox.get(0.0), inbox.get(0.0)
    assert answer is not None and answer[2].size == 200
    assert waiting is not None and waiting[2] == b"1" * 10


def test_a_goal_accepted_before_is_queued_past_the_count_limit() -> None:
    """Tests a goal sent again under an accepted id while the inbox is
    full of other goals: queued all the same (the loop answers that its
    verdict stands), where another goal is refused "busy"; the byte limit
    still holds for it."""
    import json

    def goal(goal_id: str, pad: int = 0) -> bytes:
        doc = {"goal_id": goal_id, "tasks": [], "x": "y" * pad}
        return json.dumps(doc).encode()

    inbox = Inbox(max_goals=2, max_bytes=400)
    assert inbox.put_goal("k", goal("a"), 0.0)
    assert inbox.put_goal("k", goal("b"), 0.0)
    assert not inbox.put_goal("k", goal("c"), 0.0)  # full: busy
    inbox.note_verdict("c", "goal_rejected")  # a rejection is not kept
    assert not inbox.put_goal("k", goal("c"), 0.0)
    inbox.note_verdict("c", "goal_accepted")
    assert inbox.put_goal("k", goal("c"), 0.0)
    assert not inbox.put_goal("k", goal("c", 400), 0.0)  # bytes
