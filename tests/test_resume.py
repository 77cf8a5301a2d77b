"""Tests of resume from the journal: engine snapshots, rebuilding, the
state folder, and a real node killed with SIGKILL at random points."""

from __future__ import annotations

import importlib.machinery
import importlib.util
import random
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import msgspec

from fsw_scheduler.engine.config import EngineConfig
from fsw_scheduler.engine.core import Engine
from fsw_scheduler.engine.snapshot import EngineSnapshot
from fsw_scheduler.journal.state import journal_files, open_state

from .test_engine import Driver, _encoded, small_goal

if TYPE_CHECKING:
    from types import ModuleType

ROOT = Path(__file__).resolve().parents[1]


def _soak() -> ModuleType:
    loader = importlib.machinery.SourceFileLoader(
        "soak_resume", str(ROOT / "tools" / "soak_resume")
    )
    spec = importlib.util.spec_from_loader("soak_resume", loader)
    assert spec is not None
    module = importlib.util.module_from_spec(spec)
    # dataclasses look their module up in sys.modules.
    sys.modules["soak_resume"] = module
    loader.exec_module(module)
    return module


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
    attributes = set(vars(engine)) - {"config", "_dispatches"}
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
    assert _encoded(copy.history) == _encoded(original.history)
    assert copy.engine.snapshot() == original.engine.snapshot()


def test_random_sigkills_resume_to_the_uninterrupted_plan(
    tmp_path: Path,
) -> None:
    """Tests the real node (separate process, --state) killed by SIGKILL
    at random points: after each restart it resumes, and the session ends
    with the plan of an uninterrupted run, every activity dispatched
    exactly as often, and every journal file replaying identically."""
    soak = _soak()
    rng = random.Random(7)
    reference = soak.run_session(tmp_path, set(), rng)
    kills = soak.random_kills(rng, 4) | {(15, "goal"), (0, "tick")}
    outcome = soak.run_session(tmp_path, kills, rng)
    assert soak.compare(reference, outcome) == []
    assert outcome.kills == len(kills)
    assert outcome.resumed == len(kills)
    assert outcome.journals == len(kills) + 1
    assert max(outcome.dispatches.values()) == 1


def test_rotated_journal_resumes_from_the_newest_snapshot(
    tmp_path: Path,
) -> None:
    """Tests journals that rotate by size: each file opens with a snapshot,
    a node killed after rotations resumes, all files replay identically."""
    soak = _soak()
    rng = random.Random(3)
    reference = soak.run_session(tmp_path, set(), rng)
    outcome = soak.run_session(
        tmp_path,
        {(20, "tick"), (30, "report")},
        rng,
        ("--journal-max-size", "4000"),
    )
    assert soak.compare(reference, outcome) == []
    parts = [n for n in outcome.journal_files if n.count("-") == 2]
    assert parts, outcome.journal_files


def test_state_folder_finishes_a_truncated_journal(tmp_path: Path) -> None:
    """Tests that a journal cut short (killed writer) is recovered and the
    state rebuilt from what it holds."""
    soak = _soak()
    soak.run_session(tmp_path, set(), random.Random(0))
    state = tmp_path / "state"
    (path,) = journal_files(state)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) * 2 // 3])
    start = open_state(state)
    assert start.recovered == [path]
    assert start.rebuilt is not None
    assert start.rebuilt.engine.plan_id in (1, 2)
    assert start.next_journal.name == "journal-0002.mcap"
