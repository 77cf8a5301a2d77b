"""Tests of the node's outputs: the journal is on the disk (fsync) before
any output reaches the bus, one sync per step, and a full disk at a
rotation stays inside the journal's guard."""

from __future__ import annotations

import errno
import os
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any

import msgspec

from fsw_scheduler.journal.annotate import schema_lookup
from fsw_scheduler.journal.writer import Recorder
from fsw_scheduler.testing import SchedulerHarness
from fsw_scheduler.wire import messages

if TYPE_CHECKING:
    import pytest

    from fsw_scheduler.engine.snapshot import EngineSnapshot


class SyncLog:
    """Wraps ``os.fsync``: for each sync of the journal, the bytes then
    on the disk and how many dispatches the client had received."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder.resolve()
        self.copies: list[tuple[int, bytes]] = []
        self.folder_syncs = 0
        self.received = lambda: 0
        self._lock = threading.Lock()
        self._real = os.fsync

    def __call__(self, fd: int) -> None:
        self._real(fd)
        target = Path(os.readlink(f"/proc/self/fd/{fd}"))
        if target == self.folder:
            self.folder_syncs += 1
        elif target.parent == self.folder:
            with self._lock:
                self.copies.append((self.received(), target.read_bytes()))


def journaled_dispatches(data: bytes, tmp: Path) -> list[messages.Dispatch]:
    """The dispatches a journal's bytes hold (read as a crash leaves
    them: complete records only)."""
    from fsw_scheduler.journal.recover import scan_messages

    tmp.write_bytes(data)
    _, channels, found = scan_messages(tmp)
    return [
        msgspec.json.decode(m.data, type=messages.Dispatch)
        for m in found
        # One channel for every dispatch (older journals: one per task).
        if "/scheduler/dispatch" in channels[m.channel_id].topic
    ]


def test_every_dispatch_is_on_the_disk_before_the_bus_sees_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Tests a durable journal: each dispatch a client receives was in the
    journal's bytes at an fsync made before the client received it; the
    folder is synced when the file is created; syncs are one per step
    (group commit), far fewer than the records written."""
    folder = tmp_path / "state"
    syncs = SyncLog(folder)
    monkeypatch.setattr(os, "fsync", syncs)
    recorder = Recorder(
        folder / "journal-0001.mcap",
        schemas=schema_lookup("sat1"),
        durable=True,
    )
    options: dict[str, Any] = {"journal": recorder, "durable": True}
    with SchedulerHarness(node_options=options) as h:
        syncs.received = lambda: len(h.dispatches)
        for now in range(12):
            h.tick(now)
        h.settle()
        received = list(h.dispatches)
        records = recorder.message_count
        synced = len(syncs.copies)
    assert received, "the paper's plan dispatches within 12 units"
    assert syncs.folder_syncs >= 1
    scratch = tmp_path / "scratch.mcap"
    for index, dispatch in enumerate(received):
        before = [data for seen, data in syncs.copies if seen <= index]
        assert any(
            dispatch in journaled_dispatches(data, scratch) for data in before
        ), f"dispatch {dispatch.dispatch_id} not on the disk before the bus"
    assert synced <= records // 2, (synced, records)


def test_a_full_disk_at_a_rotation_is_a_journal_fault(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Tests ENOSPC while a part is finished at a rotation: no traceback
    escapes; the node says ``journal_failed``, answers the next goal and
    continues in a new part once space returns."""
    from fsw_scheduler.bus import outputs

    from ..factories import ping_goal

    full = {"on": False}
    close_part = Recorder._close_part

    def failing(self: Recorder) -> None:
        if full["on"]:
            raise OSError(errno.ENOSPC, "No space left on device")
        close_part(self)

    monkeypatch.setattr(Recorder, "_close_part", failing)
    monkeypatch.setattr(outputs, "JOURNAL_RETRY_S", 0.2)
    recorder = Recorder(
        tmp_path / "journal-0001.mcap", schemas=schema_lookup("sat1")
    )
    options = {
        "journal": recorder,
        "durable": True,
        "journal_max_bytes": 1,  # every step rotates
    }
    with SchedulerHarness(node_options=options) as h:
        h.tick(0)
        h.wait_plan(lambda p: p.plan_id == 1)
        full["on"] = True
        h.tick(1)
        failed = h.wait_status(lambda s: s.event == "journal_failed")
        assert "No space left" in failed.detail
        h.publish_goal(ping_goal("while-full", "Full"))
        h.wait_status(
            lambda s: s.goal_id == "while-full" and s.event == "goal_accepted"
        )
        full["on"] = False
        h.wait_status(lambda s: s.event == "journal_resumed", 10)
        assert h.node.alive
        assert h.node.failed is None


def test_a_standby_kept_by_changes_holds_the_commanders_state() -> None:
    """Tests the standby's copy: after the whole state once, it gets each
    step's records (``scheduler/changes``), never the whole state again
    within :data:`SNAPSHOT_EVERY_S`; applied in order they give exactly
    the commander's state (goals, plan, lifecycle, term), in far fewer
    bytes than a snapshot per step."""
    from fsw_scheduler.bus.redundancy import Member, Redundancy

    from ..factories import ping_goal

    sizes: dict[str, list[int]] = {"snapshot": [], "changes": []}

    def count(sample: Any) -> None:
        kind = str(sample.key_expr).rsplit("/", 1)[-1]
        sizes[kind].append(len(sample.payload.to_bytes()))

    options: dict[str, Any] = {"share_state": True}
    with SchedulerHarness(node_options=options) as h:
        taps = [
            h.client.declare_subscriber(f"fsw/sat1/scheduler/{kind}", count)
            for kind in sizes
        ]
        standby = Redundancy(h.client, "sat1", Member(1, 1, "standby"))
        standby.shared.config = h.config
        standby.join()
        try:
            h.tick(0)
            h.wait_plan(lambda p: p.plan_id == 1)
            standby.max_term = h.node.term  # the token's term, verified
            assert standby.ask_snapshot()
            for now in range(1, 6):
                h.publish_goal(ping_goal(f"g{now}", f"T{now}"))
                h.wait_status(lambda s: s.goal_id == f"g{now}")
                h.tick(now)
            h.settle()
            copy = standby.latest_snapshot()
            truth = h.node.engine.snapshot()
        finally:
            standby.close()
            for tap in taps:
                tap.undeclare()

    def core(state: EngineSnapshot | None) -> Any:
        assert state is not None
        return msgspec.structs.replace(
            state, counters=messages.Counters(), inputs=0
        )

    assert copy is not None
    assert set(copy.ledger) == {f"g{n}" for n in range(1, 6)}
    assert core(copy) == core(truth)
    assert sizes["snapshot"] == []  # shared at start, then changes only
    assert len(sizes["changes"]) >= 5
    whole = len(msgspec.json.encode(truth))
    # Each step sends a fraction of the whole state, whatever its size.
    assert max(sizes["changes"]) < whole / 2, (sizes["changes"], whole)
