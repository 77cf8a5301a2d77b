"""Tests of resume from a state folder: a real node (separate process,
``--state``) killed with SIGKILL at random points, rotated journals, a
journal cut short."""

from __future__ import annotations

import random
from typing import TYPE_CHECKING

from fsw_scheduler.journal.state import journal_files, open_state

from ..factories import tool_script

if TYPE_CHECKING:
    from pathlib import Path
    from types import ModuleType


def soak_resume() -> ModuleType:
    """``tools/soak_resume``: a node session with SIGKILLs at given steps."""
    return tool_script("soak_resume")


def test_random_sigkills_resume_to_the_uninterrupted_plan(
    tmp_path: Path,
) -> None:
    """Tests the real node (separate process, --state) killed by SIGKILL
    at random points: after each restart it resumes, and the session ends
    with the plan of an uninterrupted run, every activity dispatched
    exactly as often, and every journal file replaying identically."""
    soak = soak_resume()
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
    soak = soak_resume()
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
    soak = soak_resume()
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


def test_the_state_folder_keeps_its_byte_budget(tmp_path: Path) -> None:
    """Tests ``--state-max-bytes``: with small parts the oldest files go
    once a newer part opens with the state; the folder stays within its
    budget (plus the part being written) and still resumes to the plan
    of an uninterrupted run."""
    soak = soak_resume()
    rng = random.Random(3)
    reference = soak.run_session(tmp_path, set(), rng)
    budget = 30_000
    outcome = soak.run_session(
        tmp_path,
        {(30, "report")},
        rng,
        ("--journal-max-size", "4000", "--state-max-bytes", str(budget)),
    )
    assert soak.compare(reference, outcome) == []
    files = journal_files(tmp_path / "state")
    sizes = [p.stat().st_size for p in files]
    assert sum(sizes) <= budget + max(sizes), sizes
    assert files[0].name != "journal-0001.mcap"  # the oldest went
    assert open_state(tmp_path / "state").rebuilt is not None
