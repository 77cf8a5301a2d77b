"""Tests of the session pictures (fsw_scheduler.view.session, `plot`)."""

from __future__ import annotations

import functools
import subprocess
import sys
from pathlib import Path

import pytest

from fsw_scheduler.view.session import plot_session, read_session

from ..factories import ROOT

FAILURE = ROOT / "replay" / "failure.mcap"
PAPER = ROOT / "replay" / "paper.mcap"
PNG = b"\x89PNG\r\n\x1a\n"


def test_read_session_rebuilds_what_happened() -> None:
    """Tests plans, problems, executed runs and measured levels."""
    session = read_session(FAILURE)
    assert session.spacecraft == "sat1"
    assert [p.plan_id for p in session.plans] == list(range(1, 12))
    assert set(session.problems) == set(range(1, 12))
    runs = [a for a in session.executed if a.task == "DownlinkSat2Ground"]
    assert len(runs) == 2  # failed once, then ran again
    assert runs[0].end - runs[0].start < 10
    battery = session.measured["battery"]
    assert battery[0] == (5, pytest.approx(battery[0][1]))
    assert len(battery) == 16
    assert "AcquisitionHF" in session.tasks


def test_empty_plans_start_from_the_predicted_level() -> None:
    """Tests the stand-in problem of a plan adopted without a solve."""
    session = read_session(FAILURE)
    empty = [p for p in session.plans if not p.activities]
    assert empty
    for plan in empty:
        problem = session.problems[plan.plan_id]
        assert problem.tasks == ()
        assert problem.start == plan.horizon_start
        level = problem.resources.consumable["battery"]
        assert isinstance(level, float | int)  # the stand-in: a plain level
        assert 0 <= level < 60


def test_plot_session_draws_every_plan_and_levels(tmp_path: Path) -> None:
    """Tests one picture per plan plus levels.png."""
    drawn = plot_session(PAPER, tmp_path / "out")
    names = [p.name for p in drawn]
    assert names == ["plan-1.png", "plan-2.png", "levels.png"]
    for path in drawn:
        assert path.read_bytes().startswith(PNG)


def test_plot_command(tmp_path: Path) -> None:
    """Tests `fsw-scheduler plot` and its refusal of a non-journal."""
    script = Path(sys.executable).with_name("fsw-scheduler")
    result = subprocess.run(
        [str(script), "plot", str(PAPER), "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.split()[-1].endswith("levels.png")
    other = tmp_path / "plain.mcap"
    from fsw_scheduler.journal.writer import Recorder

    with Recorder(other) as rec:
        rec.write("a/b", b"{}", log_time_ns=1)
    result = subprocess.run(
        [str(script), "plot", str(other), "--out", str(tmp_path / "x")],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2
    assert "not a scheduler journal" in result.stderr


def test_attach_pictures_copies_the_journal(tmp_path: Path) -> None:
    """Tests a copy with the pictures attached, messages unchanged."""
    from fsw_scheduler.journal.info import info, read_attachments
    from fsw_scheduler.journal.replay import verify
    from fsw_scheduler.view.session import attach_pictures

    picture = tmp_path / "plan-1.png"
    picture.write_bytes(PNG + b"not really")
    copy = attach_pictures(PAPER, [picture], tmp_path / "copy.mcap")
    assert read_attachments(copy) == {
        **read_attachments(PAPER),
        "plan-1.png": PNG + b"not really",
    }
    assert info(copy).message_count == info(PAPER).message_count
    assert [a.media_type for a in info(copy).attachments][-1] == "image/png"
    assert verify(copy).identical


def test_a_failed_run_is_drawn_as_failed(tmp_path: Path) -> None:
    """Tests that the session knows which runs failed, and that the Gantt
    draws a failed run otherwise than a finished one."""
    from fsw_scheduler.view.gantt import gantt

    session = read_session(FAILURE)
    first = min(
        (a for a in session.executed if a.task == "DownlinkSat2Ground"),
        key=lambda a: a.start,
    )
    assert ("DownlinkSat2Ground", first.start) in session.failed
    plan = session.plans[-1]
    problem = session.problems[plan.plan_id]
    from fsw_scheduler.model.plan import Plan

    drawn = Plan(
        plan.status, plan.objective, plan.activities, plan.unscheduled
    )
    past = list(session.tasks.values())
    draw = functools.partial(
        gantt,
        problem,
        drawn,
        now=plan.issued_at,
        history=session.executed,
        past_tasks=past,
    )
    (plain,) = draw(tmp_path / "plain.png")
    (marked,) = draw(tmp_path / "failed.png", failed=session.failed)
    assert plain.read_bytes() != marked.read_bytes()


def test_a_plan_says_its_moves_and_pins_to_the_pictures() -> None:
    """Tests on the engine's Table 2 replan at t=15 with a 30-unit commit
    window that a plan's pins are read back from the problem its solve
    record holds (SetPositionY and DownlinkSat2Ground, planned at 38 and
    39, are kept there; the running BatteryCharge is not a pin) and its
    moves from the plan (none); without the window nothing is pinned
    and the plan's moves are those the pictures ghost."""
    from fsw_scheduler.engine.config import EngineConfig
    from fsw_scheduler.engine.events import StartSolve
    from fsw_scheduler.view.session import moves_of, pins_of

    from ..engine.driver import Driver, paper_goal

    seen = {}
    for window in (30, 0):
        driver = Driver(
            config=EngineConfig(commit_window=window, stability="moves")
        )
        for now in range(16):
            driver.tick(now)
        before = driver.plan.activities
        out = driver.goal(paper_goal(), 15)
        (solve,) = [c for c in out if isinstance(c, StartSolve)]
        plan = driver.plan
        seen[window] = (
            pins_of(solve.problem, plan, before),
            {m.task for m in moves_of(plan)},
        )
    pins, moves = seen[30]
    assert {"SetPositionY", "DownlinkSat2Ground"} <= pins
    assert "BatteryCharge" not in pins
    assert not moves
    assert seen[0][0] == frozenset()
