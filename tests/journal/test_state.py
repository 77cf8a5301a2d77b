"""Tests of a standby's saved copy in its state folder (StandbyStore)."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import msgspec

from fsw_scheduler.engine.core import Engine
from fsw_scheduler.journal.annotate import schema_lookup
from fsw_scheduler.journal.state import (
    StandbyStore,
    journal_files,
    open_state,
)
from fsw_scheduler.runtime.config import NodeConfig
from fsw_scheduler.runtime.policy import engine_config, node_info
from fsw_scheduler.wire import messages, topics

from ..factories import DATA, problem_from

if TYPE_CHECKING:
    from pathlib import Path

    import pytest


def _store(folder: Path, run: int = 1) -> tuple[StandbyStore, Engine]:
    """A store of a standby of the paper's problem, and an engine whose
    states it is offered."""
    import json

    problem = problem_from(
        json.loads((DATA / "paper_table1.json").read_text())
    )
    config = NodeConfig()
    keys = topics.Topics(config.spacecraft)
    store = StandbyStore(
        folder,
        run,
        (
            keys.key(topics.NODE_INFO),
            messages.encode(node_info(config, problem)),
        ),
        keys.key(topics.SNAPSHOT),
        schema_lookup(config.spacecraft),
        every_s=1.0,
    )
    return store, Engine(engine_config(config), problem)


def test_a_saved_copy_is_what_a_start_resumes(tmp_path: Path) -> None:
    """Tests that the newest state offered is written as one finished,
    synced journal part that :func:`open_state` resumes from, the part
    before it removed, saves at most every ``every_s`` (unless forced),
    and nothing written when nothing new was offered."""
    store, engine = _store(tmp_path)
    first = engine.snapshot()
    store.offer(lambda: msgspec.json.encode(first))
    assert store.save_due(10.0)
    later = msgspec.structs.replace(first, term=3, inputs=7, plan_id=4)
    store.offer(lambda: msgspec.json.encode(later))
    assert not store.save_due(10.5)  # within every_s
    assert store.save_due(11.0)
    assert not store.save_due(20.0)  # nothing new
    (only,) = journal_files(tmp_path)
    assert only.name == "journal-0001-002.mcap"
    assert not list(tmp_path.glob("*.saving"))
    start = open_state(tmp_path)
    assert start.rebuilt is not None
    rebuilt = start.rebuilt.engine.snapshot()
    assert (rebuilt.term, rebuilt.inputs, rebuilt.plan_id) == (3, 7, 4)
    assert start.next_journal.name == "journal-0002.mcap"


def test_a_copy_saved_after_commanding_sorts_after_its_journal(
    tmp_path: Path,
) -> None:
    """Tests a node that commanded (its journal is a later run) and
    stands by again: its next saved copy is a newer run, so that a start
    resumes the copy, not the older journal."""
    store, engine = _store(tmp_path)
    store.offer(lambda: msgspec.json.encode(engine.snapshot()))
    store.save_due(0.0)
    (tmp_path / "journal-0002.mcap").write_bytes(
        (tmp_path / "journal-0001-001.mcap").read_bytes()
    )
    newer = msgspec.structs.replace(engine.snapshot(), term=5)
    store.offer(lambda: msgspec.json.encode(newer))
    assert store.save_due(5.0, force=True)
    assert journal_files(tmp_path)[-1].name == "journal-0003-001.mcap"
    start = open_state(tmp_path)
    assert start.rebuilt is not None
    assert start.rebuilt.engine.term == 5


def test_a_full_disk_keeps_the_copy_in_memory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Tests ENOSPC while saving: no exception, ``fault`` says why, the
    next save once space returns writes the newest state."""
    import errno

    from fsw_scheduler.journal import writer

    store, engine = _store(tmp_path)
    real = writer.Recorder.write

    def full(*args: object, **kwargs: object) -> bool:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(writer.Recorder, "write", full)
    store.offer(lambda: msgspec.json.encode(engine.snapshot()))
    assert not store.save_due(0.0)
    assert store.fault is not None and "No space" in store.fault
    monkeypatch.setattr(writer.Recorder, "write", real)
    assert store.save_due(5.0)
    assert store.fault is None
    assert not list(tmp_path.glob("*.saving"))
    assert open_state(tmp_path).rebuilt is not None


def test_the_term_mark_only_rises_and_a_damaged_one_is_not_believed(
    tmp_path: Path,
) -> None:
    """Tests ``term.json``: written and read back, never lowered; a bit
    flip (CRC), garbage or a mark far beyond every known term is not
    believed, and the node falls back on its journal's term."""
    from fsw_scheduler.app.cli.run import _with_mark
    from fsw_scheduler.journal.state import (
        TERM_MARK,
        read_term_mark,
        write_term_mark,
    )
    from fsw_scheduler.wire.terms import MAX_TERM_JUMP

    assert read_term_mark(tmp_path) == 0
    write_term_mark(tmp_path, 3)
    write_term_mark(tmp_path, 2)  # never lowers
    assert read_term_mark(tmp_path) == 3
    assert _with_mark(tmp_path, 1, 2) == 3
    mark = tmp_path / TERM_MARK
    good = mark.read_bytes()
    for at in range(len(good)):
        for bit in range(8):
            flipped = bytearray(good)
            flipped[at] ^= 1 << bit
            mark.write_bytes(bytes(flipped))
            assert read_term_mark(tmp_path) in (0, 3), (at, bit)
    mark.write_bytes(b"\x00garbage")
    assert read_term_mark(tmp_path) == 0
    import zlib

    huge = 5 + MAX_TERM_JUMP + 1
    mark.write_bytes(
        msgspec.json.encode({"term": huge, "crc32": zlib.crc32(b"%d" % huge)})
    )
    assert read_term_mark(tmp_path) == huge
    assert _with_mark(tmp_path, 0, huge - 1) == huge
    # Its next term beyond the bound (receivers would refuse it): ignored,
    # and replaced by the highest term known, which it protects again.
    assert _with_mark(tmp_path, 0, 5) == 0
    assert read_term_mark(tmp_path) == 5
    write_term_mark(tmp_path, 6)
    assert _with_mark(tmp_path, 0, 1) == 6
    edge = 5 + MAX_TERM_JUMP  # its next term: one past the bound
    write_term_mark(tmp_path, edge)
    assert _with_mark(tmp_path, 0, 5) == 0
