"""Tests of why a replan moved an activity (pure: one check each)."""

from __future__ import annotations

from fsw_scheduler.analysis.moved import why_moved
from fsw_scheduler.model.plan import Activity, Plan, SolveStatus

from ..factories import make_doc, make_task, problem_from


def test_each_moved_activity_says_why() -> None:
    """Tests the three reasons: an old start no longer allowed (window),
    an old slot another activity now holds (binary resource), and a free
    old slot left for a cheaper start; an unmoved task has no entry."""
    problem = problem_from(
        make_doc(
            [
                make_task("late", 2, feasible_interval=[0, 4]),
                make_task("cam1", 2, uses={"cam": 1}),
                make_task("cam2", 2, uses={"cam": 1}),
                make_task("free", 2),
                make_task("kept", 1),
            ],
            horizon=10,
            resources={"binary": ["cam"]},
        )
    )
    plan = Plan(
        SolveStatus.OPTIMAL,
        None,
        activities=(
            Activity("late", 0, 2),
            Activity("cam1", 0, 2),
            Activity("cam2", 2, 4),
            Activity("free", 0, 2),
            Activity("kept", 5, 6),
        ),
    )
    previous = {"late": 6, "cam2": 0, "free": 3, "kept": 5}
    why = why_moved(problem, plan, previous)
    assert set(why) == {"late", "cam2", "free"}
    assert "no longer allowed" in why["late"]
    assert why["cam2"].startswith("back at 0 it would break binary")
    assert "still free" in why["free"]
