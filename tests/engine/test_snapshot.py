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
    # _goal_checked is a memo of a rule pass, derived from the state.
    attributes = set(vars(engine)) - {"config", "_dispatches", "_goal_checked"}
    # The dispatch lifecycle is one object holding four snapshot fields.
    attributes |= set(type(engine._dispatches).__slots__)
    fields = set(EngineSnapshot.__struct_fields__) - {"version"}
    renamed = {name.lstrip("_") for name in attributes}
    assert renamed == fields


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
