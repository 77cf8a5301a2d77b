"""Tests of the mission-model fields: alternatives, availability windows,
capacity steps and external rates, read strictly (every mistake, with its
path, in one pass) and the same way by the shipped JSON Schemas."""

from __future__ import annotations

import copy
import json
from typing import Any

import jsonschema
import msgspec
import pytest

from fsw_scheduler.errors import InputError
from fsw_scheduler.model import groups
from fsw_scheduler.model.goal import decode_goal
from fsw_scheduler.model.problem import decode_problem

from ..factories import DATA, ROOT, make_doc, make_task, problem_from

PROBLEM = jsonschema.Draft202012Validator(
    json.loads((ROOT / "schemas" / "problem.schema.json").read_text())
)


def _mission_doc() -> dict:
    """A valid problem with every field of the mission model."""
    tasks = [
        {"id": "SetHF", "length": 2, "delay_cost": 1},
        make_task("AcqHF", 3, uses={"antenna": 1}, schedule_cost=3),
        make_task("SetLF", 2, schedule_cost=3),
        make_task("AcqLF", 2, uses={"power": 2, "battery": 1}),
        make_task("Other", 2, uses={"power": 1}),
    ]
    del tasks[3]["schedule_cost"]
    return make_doc(
        tasks,
        horizon=30,
        resources={
            "binary": {"antenna": {"available": [[5, 10], [20, 25]]}},
            "multiple": {"power": {"steps": [[0, 3], [10, 1], [20, 2]]}},
            "consumable": {
                "battery": {
                    "initial": 1,
                    "max": 4,
                    "external": [[0, 1], [15, -1]],
                }
            },
        },
        alternatives=[
            {
                "id": "image",
                "schedule_cost": 3,
                "options": [["SetHF", "AcqHF"], ["SetLF", "AcqLF"]],
            }
        ],
    )


def test_a_mission_problem_decodes_and_members_take_the_group_cost() -> None:
    """Tests that a problem with every new field is accepted, that a
    member written without a schedule cost takes its group's, and that
    the indexes read it back."""
    problem = problem_from(_mission_doc())
    assert problem.task("SetHF").schedule_cost == 3
    assert problem.task("AcqLF").schedule_cost == 3
    index = problem.groups
    assert index.option_of("AcqLF") == (problem.alternatives[0], 1)
    assert index.rivals("SetHF") == ("SetLF", "AcqLF")
    assert not problem.required(problem.task("SetHF"))
    res = problem.resources
    assert res.capacity_profile("antenna", 0, 30)[4:11] == [
        0,
        1,
        1,
        1,
        1,
        1,
        0,
    ]
    assert res.capacity_profile("power", 0, 30)[9:12] == [3, 1, 1]
    assert res.external_profile("battery", 0, 30)[14:16] == [1, -1]
    assert set(res.changing) == {"antenna", "power", "battery"}
    assert problem.has_mission_model
    # The schema asks every task for its cost: written out, it passes.
    written = json.loads(msgspec.json.encode(problem.tasks))
    assert PROBLEM.is_valid(_mission_doc() | {"tasks": written})


def test_a_mandatory_group_makes_no_member_required() -> None:
    """Tests that members of a group of cost 0 are not required one by
    one (one option is), while a plain task of cost 0 still is."""
    doc = _mission_doc()
    doc["alternatives"][0]["schedule_cost"] = 0
    doc["tasks"][1]["schedule_cost"] = 0
    doc["tasks"][2]["schedule_cost"] = 0
    doc["tasks"][4]["schedule_cost"] = 0
    problem = problem_from(doc)
    required = {t.id for t in problem.tasks if problem.required(t)}
    assert required == {"Other"}
    assert groups.unscheduled_cost(problem, {"Other"}) == 0
    assert groups.unscheduled_cost(problem, {"Other", "SetLF", "AcqLF"}) == 0
    assert groups.chosen(problem, {"SetLF", "AcqLF"}) == {"image": 1}


def test_every_mission_mistake_in_one_pass() -> None:
    """Tests that each rule of the mission model is reported at its path,
    all of them at once, with a suggestion for a misspelt task."""
    doc = _mission_doc()
    doc["resources"]["binary"]["antenna"]["available"] = [
        [5, 10],
        [8, 12],
        [20, 20],
    ]
    doc["resources"]["multiple"]["power"]["steps"] = [[2, 3], [2, 1]]
    doc["resources"]["consumable"]["battery"]["external"] = [[4, 1], [3, 0]]
    doc["alternatives"][0]["options"][1].append("Othr")
    doc["alternatives"].append(
        {"id": "Other", "schedule_cost": 1, "options": [["SetHF"]]}
    )
    doc["alternatives"].append(
        {"id": "image", "schedule_cost": 1, "options": [["Other"]]}
    )
    doc["tasks"][2]["schedule_cost"] = 2
    with pytest.raises(InputError) as info:
        decode_problem(json.dumps(doc))
    found = {issue.path: issue.reason for issue in info.value.issues}
    assert set(found) == {
        "resources.binary.antenna.available[1]",
        "resources.binary.antenna.available[2]",
        "resources.multiple.power.steps[1][0]",
        "resources.multiple.power.steps[0][0]",
        "resources.consumable.battery.external[1][0]",
        "alternatives[0].options[1][2]",
        "alternatives[1].id",
        "alternatives[1].options[0][0]",
        "alternatives[2].id",
        "tasks[2].schedule_cost",
    }
    assert "did you mean 'Other'" in found["alternatives[0].options[1][2]"]
    assert (
        "sorted and disjoint" in found["resources.binary.antenna.available[1]"]
    )
    assert "duplicate group id" in found["alternatives[2].id"]


#: Mistakes of shape in the new fields: the scheduler names the path and
#: the shipped schema rejects the same document.
STATIC = {
    "misspelt available": (
        ("resources", "binary", "antenna"),
        {"availble": [[1, 2]]},
        "resources.binary.antenna.availble",
    ),
    "window of three": (
        ("resources", "binary", "antenna", "available", 0),
        [1, 2, 3],
        "resources.binary.antenna.available[0]",
    ),
    "fractional capacity step": (
        ("resources", "multiple", "power", "steps", 1, 1),
        1.5,
        "resources.multiple.power.steps[1][1]",
    ),
    "negative capacity step": (
        ("resources", "multiple", "power", "steps", 1, 1),
        -1,
        "resources.multiple.power.steps[1][1]",
    ),
    "no steps": (
        ("resources", "multiple", "power", "steps"),
        [],
        "resources.multiple.power.steps",
    ),
    "external rate as text": (
        ("resources", "consumable", "battery", "external", 0, 1),
        "1",
        "resources.consumable.battery.external[0][1]",
    ),
    "empty option": (
        ("alternatives", 0, "options", 1),
        [],
        "alternatives[0].options[1]",
    ),
    "no options": (
        ("alternatives", 0, "options"),
        [],
        "alternatives[0].options",
    ),
    "misspelt options": (
        ("alternatives", 0, "option"),
        [["SetHF"]],
        "alternatives[0].option",
    ),
    "group cost 6": (
        ("alternatives", 0, "schedule_cost"),
        6,
        "alternatives[0].schedule_cost",
    ),
    "group id with a slash": (
        ("alternatives", 0, "id"),
        "im/age",
        "alternatives[0].id",
    ),
}


@pytest.mark.parametrize("name", sorted(STATIC))
def test_shape_mistakes_of_new_fields_are_rejected_by_both(name: str) -> None:
    """Tests each shape mistake of the new fields: the scheduler names its
    path, the shipped schema rejects the document too."""
    path, value, where = STATIC[name]
    doc = _mission_doc()
    node = doc
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    with pytest.raises(InputError) as info:
        decode_problem(json.dumps(doc))
    assert where in {issue.path for issue in info.value.issues}, info.value
    full = copy.deepcopy(doc)
    for task in full["tasks"]:
        task.setdefault("schedule_cost", 3)
    assert list(PROBLEM.iter_errors(full)), f"the schema accepts {name}"


def test_a_task_outside_every_group_still_needs_its_cost() -> None:
    """Tests that only group members may leave their schedule cost out."""
    doc = _mission_doc()
    del doc["tasks"][4]["schedule_cost"]
    with pytest.raises(InputError) as info:
        decode_problem(json.dumps(doc))
    assert [i.path for i in info.value.issues] == ["tasks[4].schedule_cost"]


def test_old_documents_mean_what_they_meant() -> None:
    """Tests that the paper's problem decodes with no mission field, its
    binary resources still a list, and encodes back to the same JSON."""
    text = (DATA / "paper_table1.json").read_text()
    problem = decode_problem(text)
    assert not problem.has_mission_model
    assert isinstance(problem.resources.binary, tuple)
    assert json.loads(msgspec.json.encode(problem)) == json.loads(
        msgspec.json.encode(decode_problem(msgspec.json.encode(problem)))
    )
    assert "alternatives" not in json.loads(msgspec.json.encode(problem))


def test_goal_groups_name_the_goals_own_tasks() -> None:
    """Tests that a goal's groups are checked against its tasks, and that
    a member of a goal group may leave its cost out."""
    goal: dict[str, Any] = {
        "goal_id": "g1",
        "tasks": [
            {"id": "HF", "length": 2, "delay_cost": 1},
            {"id": "LF", "length": 1, "delay_cost": 1},
        ],
        "alternatives": [
            {"id": "pick", "schedule_cost": 2, "options": [["HF"], ["LF"]]}
        ],
    }
    decoded = decode_goal(json.dumps(goal))
    assert [t.schedule_cost for t in decoded.tasks] == [2, 2]
    goal["alternatives"][0]["options"][1] = ["LFF"]
    with pytest.raises(InputError) as info:
        decode_goal(json.dumps(goal))
    paths = [i.path for i in info.value.issues]
    assert "alternatives[0].options[1][0]" in paths
    assert "tasks[1].schedule_cost" in paths


def test_the_mission_model_example_passes_both() -> None:
    """Tests that examples/mission-model.json (the documented example)
    passes the scheduler and the shipped schema."""
    text = (ROOT / "examples" / "mission-model.json").read_text()
    assert PROBLEM.is_valid(json.loads(text))
    assert decode_problem(text).has_mission_model
