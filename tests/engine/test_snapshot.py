"""Tests of engine snapshots: complete, and a restored engine behaves the
same (resume from a state folder is tested in tests/journal)."""

from __future__ import annotations

import msgspec

from fsw_scheduler.engine.config import EngineConfig
from fsw_scheduler.engine.core import Engine
from fsw_scheduler.engine.snapshot import EngineSnapshot

from .driver import Driver, encoded, small_goal


def _story(driver: Driver) -> None:
    driver.tick(0)
    driver.tick(1)
    driver.report("DownlinkSat2Sat", "running", 1)
    driver.goal(small_goal("g1", "Ping"), 2)


def test_snapshot_holds_every_piece_of_engine_state() -> None:
    """Tests that a snapshot covers each engine attribute (new state must
    be added to EngineSnapshot, or resume would lose it)."""
    driver = Driver()
    _story(driver)
    engine = driver.engine
    state, queue = engine._state, engine._queue
    # The dispatch lifecycle is one object holding four snapshot fields.
    attributes = set(vars(state)) - {"config", "dispatches"}
    attributes |= set(type(state.dispatches).__slots__)
    # The queue's goal check is a memo of a rule pass, derived from the
    # state; its changes are the snapshot's ``queue``.
    renamed = {"changes": "queue"}
    attributes |= {renamed.get(name, name) for name in vars(queue)} - {
        "goal_check"
    }
    fields = set(EngineSnapshot.__struct_fields__) - {"version"}
    assert attributes == fields


def test_restored_engine_behaves_like_the_original() -> None:
    """Tests that after snapshot -> JSON -> restore the same events give
    the same commands."""
    original = Driver()
    _story(original)
    data = msgspec.json.encode(original.engine.snapshot())
    copy = Driver()
    copy.engine = Engine.restore(
        EngineConfig(), msgspec.json.decode(data, type=EngineSnapshot)
    )
    copy.now = original.now
    for driver in (original, copy):
        driver.history.clear()
        driver.tick(3)
        driver.report("DownlinkSat2Sat", "completed", 6)
        driver.tick(7)
        driver.goal(small_goal("g2", "Pong"), 8)
    assert encoded(copy.history) == encoded(original.history)
    assert copy.engine.snapshot() == original.engine.snapshot()
