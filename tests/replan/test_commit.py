"""Tests of the commit window's pins and of what a plan moved (pure)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from fsw_scheduler.model.plan import Activity, Plan, SolveStatus
from fsw_scheduler.replan.commit import (
    broken_pins,
    commit_pins,
    moved_activities,
    pin_blockers,
    pinned_problem,
)

from ..factories import make_doc, make_task, problem_from

if TYPE_CHECKING:
    from fsw_scheduler.model.problem import Problem


def _problem() -> Problem:
    return problem_from(
        make_doc(
            [
                make_task("a", 2),
                make_task("b", 2, feasible_interval=[12, 20]),
                make_task("c", 2),
                make_task("d", 2, fixed_start=11),
                make_task("e", 2),
            ],
            horizon=20,
            start=10,
        )
    )


def test_pins_are_planned_starts_inside_the_window() -> None:
    """Tests that only planned starts in [now, now + w) that the problem
    still allows are pinned: not one at the window's end, not one outside
    the task's window, not a task already fixed, not an unplanned one."""
    problem = _problem()
    previous = {"a": 10, "b": 11, "c": 14, "d": 12, "x": 10, "e": 13}
    assert commit_pins(problem, previous, 4) == {"a": 10, "e": 13}
    assert commit_pins(problem, previous, 0) == {}
    pinned = pinned_problem(problem, {"a": 10})
    assert pinned.task("a").fixed_start == 10
    assert pinned.task("a").mandatory
    assert pinned.task("c").fixed_start is None


def test_moved_and_broken_pins() -> None:
    """Tests that a moved activity is one scheduled in both plans at
    another start (one left out is not moved), and that broken pins are
    the moved or left-out ones, each named with where it went."""
    plan = Plan(
        SolveStatus.OPTIMAL,
        None,
        activities=(Activity("a", 10, 12), Activity("c", 16, 18)),
        unscheduled=("e",),
    )
    previous = {"a": 10, "c": 14, "e": 13}
    moved = moved_activities(previous, plan, {"c": "because"})
    assert [(m.task, m.from_, m.to, m.why) for m in moved] == [
        ("c", 14, 16, "because")
    ]
    assert broken_pins({"a": 10, "c": 14, "e": 13}, plan) == {
        "c": 16,
        "e": None,
    }
    blockers = pin_blockers({"c": 14, "e": 13}, plan, 10, 5)
    assert [b.cause for b in blockers] == ["commit_window"] * 2
    assert "moved to 16" in blockers[0].detail
    assert "left out" in blockers[1].detail
