"""Tests of the text timeline's moves and pins
(fsw_scheduler.view.timeline)."""

from __future__ import annotations

import fsw_scheduler as fs
from fsw_scheduler.model.plan import Moved
from fsw_scheduler.view.timeline import timeline_text

from ..factories import DATA


def _line(text: str, task: str) -> str:
    return next(line for line in text.splitlines() if line.startswith(task))


def test_a_moved_activity_shows_its_old_place_and_a_pin_is_said() -> None:
    """Tests on the Table 2 replan at t=15 (one character a unit) that a
    moved activity's line ghosts its old place with ``:`` and ends
    ``moved from 38``, that a pinned one ends ``pinned``, and that the
    same timeline without them has neither."""
    problem = (DATA / "paper_table1.json").read_text()
    plan = fs.solve(problem)
    goal = (DATA / "paper_table2_goal.json").read_bytes()
    new_problem, new_plan, diff = fs.replan(problem, plan, goal, 15)
    moved = [Moved(m.task, m.old_start, m.new_start) for m in diff.moved]
    text = timeline_text(
        new_problem, new_plan, width=120, moved=moved, pinned=["SetLFOption"]
    )
    line = _line(text, "SetPositionY")
    assert line.endswith("moved from 38")
    bar = line.split("|")[1]
    assert bar[33 - 15] == "#" and bar[38 - 15] == ":"
    assert bar.count(":") == 1
    assert _line(text, "SetLFOption").endswith("pinned")
    plain = timeline_text(new_problem, new_plan, width=120)
    assert ":" not in _line(plain, "SetPositionY").split("|")[1]
    assert "moved from" not in plain and "pinned" not in plain
