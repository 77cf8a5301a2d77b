"""Tests of goal decoding and checking (fsw_scheduler.model.goal)."""

from __future__ import annotations

import json

import pytest

from fsw_scheduler.errors import InputError
from fsw_scheduler.model.goal import Goal, GoalTask, decode_goal
from fsw_scheduler.model.problem import Resources, Task

from ..factories import make_task


def _paths(doc: dict) -> list[str]:
    with pytest.raises(InputError) as info:
        decode_goal(json.dumps(doc))
    assert info.value.what == "goal"
    return [issue.path for issue in info.value.issues]


def test_table2_goal_decodes(table2_goal_doc: dict) -> None:
    """Tests that the paper's Table 2 goal decodes with its obsoletes."""
    goal = decode_goal(json.dumps(table2_goal_doc))
    assert goal.goal_id == "monitor-target-lf"
    assert goal.issued_at == 15
    assert [t.id for t in goal.tasks] == [
        "AcquisitionLF",
        "SetLFOption",
        "SetPositionZ",
    ]
    assert goal.obsoleted == ("AcquisitionHF", "SetHFOption")
    assert len(goal.precedences) == 2


def test_goal_task_converts_to_plain_task() -> None:
    """Tests that to_task drops obsoletes and keeps every task field."""
    gtask = GoalTask("a", 3, 2, 1, uses={"cam": 1}, obsoletes=("b",))
    task = gtask.to_task()
    assert type(task) is Task
    assert task == Task("a", 3, 2, 1, uses={"cam": 1})


def test_goal_defaults() -> None:
    """Tests that precedences and issued_at are optional."""
    goal = decode_goal(json.dumps({"goal_id": "g", "tasks": [make_task()]}))
    assert goal == Goal("g", (GoalTask("a", 2, 1, 1),))


@pytest.mark.parametrize(
    ("task", "path"),
    [
        (make_task(length=0), "tasks[0].length"),
        (make_task(delay_cost=9), "tasks[0].delay_cost"),
        (make_task(schedule_cost=-1), "tasks[0].schedule_cost"),
        (make_task(id=""), "tasks[0].id"),
        (make_task(feasible_interval=[5, 2]), "tasks[0].feasible_interval"),
    ],
)
def test_bad_task_field_is_named(task: dict, path: str) -> None:
    """Tests that a bad task field is reported with its path."""
    assert _paths({"goal_id": "g", "tasks": [task]}) == [path]


def test_wrong_type_is_named() -> None:
    """Tests that a type error names the field through decode_strict."""
    task = make_task()
    task["length"] = "x"
    doc = {"goal_id": "g", "tasks": [task]}
    assert _paths(doc) == ["tasks[0].length"]


def test_duplicate_ids_and_self_precedence() -> None:
    """Tests that duplicate ids and a self precedence are both reported."""
    doc = {
        "goal_id": "",
        "tasks": [make_task(), make_task()],
        "precedences": [{"before": "a", "after": "a", "kind": "lax"}],
    }
    assert _paths(doc) == ["goal_id", "tasks[1].id", "precedences[0].after"]


def test_task_may_obsolete_its_own_id() -> None:
    """Tests that a task may replace the live task of the same id."""
    doc = {"goal_id": "g", "tasks": [make_task(obsoletes=["a"])]}
    assert decode_goal(json.dumps(doc)).obsoleted == ("a",)


def test_resources_are_left_to_the_merge() -> None:
    """Tests that unknown resource names are not judged without a problem."""
    doc = {"goal_id": "g", "tasks": [make_task(uses={"whatever": -3})]}
    assert decode_goal(json.dumps(doc)).tasks[0].uses == {"whatever": -3}


def test_a_goal_s_mistakes_come_in_one_pass_with_the_resources() -> None:
    """Tests the issue's goal (a bad id, a type error, an unknown
    resource): with the running problem's resources known, all three are
    named at once, not the third after the first two are fixed."""
    doc = {
        "goal_id": "bad/id",
        "tasks": [
            {
                "id": "T",
                "length": "3",
                "delay_cost": 1,
                "schedule_cost": 1,
                "uses": {"laser": 1, "power": 2},
            }
        ],
    }
    resources = Resources(multiple={"power": 10})
    with pytest.raises(InputError) as info:
        decode_goal(json.dumps(doc), resources)
    paths = [issue.path for issue in info.value.issues]
    assert sorted(paths) == [
        "goal_id",
        "tasks[0].length",
        "tasks[0].uses.laser",
    ]
    with pytest.raises(InputError) as info:
        decode_goal(json.dumps(doc))
    assert "tasks[0].uses.laser" not in {i.path for i in info.value.issues}
