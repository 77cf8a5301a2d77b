"""Tests of strict reading: every mistake named in one pass, and the
shipped JSON Schemas rejecting what the scheduler rejects."""

from __future__ import annotations

import copy
import json
from typing import TYPE_CHECKING, Any

import jsonschema
import pytest

from fsw_scheduler.app.cli.main import main
from fsw_scheduler.errors import InputError
from fsw_scheduler.model.goal import decode_goal
from fsw_scheduler.model.problem import decode_problem
from fsw_scheduler.wire import messages

from ..factories import DATA, ROOT, make_doc, make_task

if TYPE_CHECKING:
    from pathlib import Path


def _validator(kind: str) -> jsonschema.Draft202012Validator:
    schema = json.loads((ROOT / "schemas" / f"{kind}.schema.json").read_text())
    return jsonschema.Draft202012Validator(schema)


PROBLEM = _validator("problem")
GOAL = _validator("goal")
TABLE1 = json.loads((DATA / "paper_table1.json").read_text())


def _table1(edit: Any) -> dict:
    doc = copy.deepcopy(TABLE1)
    edit(doc)
    return doc


def _set(path: tuple, value: object) -> Any:
    def edit(doc: dict) -> None:
        node = doc
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value

    return edit


#: Mistakes of shape: wrong field names, types, ranges, patterns, enums.
#: Each is rejected by the scheduler (naming ``path``) and by the schema.
STATIC = {
    "misspelt task field": (
        ("tasks", 0, "feasable_interval"),
        [10, 20],
        "tasks[0].feasable_interval",
    ),
    "unknown top-level key": (("colour",), "blue", "colour"),
    "unknown precedence field": (
        ("precedences", 0, "offest"),
        1,
        "precedences[0].offest",
    ),
    "unknown resources kind": (
        ("resources", "reusable"),
        {"x": 1},
        "resources.reusable",
    ),
    "misspelt preemption": (
        ("tasks", 0, "preemption"),
        "from_strat",
        "tasks[0].preemption",
    ),
    "misspelt precedence kind": (
        ("precedences", 0, "kind"),
        "tigth",
        "precedences[0].kind",
    ),
    "length as a string": (("tasks", 1, "length"), "10", "tasks[1].length"),
    "length zero": (("tasks", 1, "length"), 0, "tasks[1].length"),
    "length fractional": (("tasks", 1, "length"), 1.5, "tasks[1].length"),
    "delay cost 0": (("tasks", 2, "delay_cost"), 0, "tasks[2].delay_cost"),
    "schedule cost 6": (
        ("tasks", 2, "schedule_cost"),
        6,
        "tasks[2].schedule_cost",
    ),
    "negative horizon": (("horizon",), -1, "horizon"),
    "negative start": (("start",), -3, "start"),
    "id with a slash": (("tasks", 3, "id"), "Set/HF", "tasks[3].id"),
    "empty id": (("tasks", 3, "id"), "", "tasks[3].id"),
    "id too long": (("tasks", 3, "id"), "x" * 65, "tasks[3].id"),
    "window of three": (
        ("tasks", 0, "feasible_interval"),
        [1, 2, 3],
        "tasks[0].feasible_interval",
    ),
    "negative capacity": (
        ("resources", "multiple", "power"),
        -5,
        "resources.multiple.power",
    ),
    "uses as a list": (("tasks", 0, "uses"), [1], "tasks[0].uses"),
    "boolean length": (("tasks", 0, "length"), True, "tasks[0].length"),
    "tasks as an object": (("tasks",), {}, "tasks"),
    "window before 0": (
        ("tasks", 0, "feasible_interval"),
        [-5, 50],
        "tasks[0].feasible_interval[0]",
    ),
}


@pytest.mark.parametrize("name", sorted(STATIC))
def test_shape_mistakes_are_rejected_by_the_scheduler_and_the_schema(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Tests each shape mistake: the scheduler names its path, so does the
    command line (``solve`` exits 2), the shipped schema rejects the same
    document."""
    path, value, where = STATIC[name]
    doc = _table1(_set(path, value))
    with pytest.raises(InputError) as info:
        decode_problem(json.dumps(doc))
    assert where in {issue.path for issue in info.value.issues}, info.value
    assert list(PROBLEM.iter_errors(doc)), f"the schema accepts {name}"
    file = tmp_path / "problem.json"
    file.write_text(json.dumps(doc))
    assert main(["solve", str(file)]) == 2
    assert f"  {where}: " in capsys.readouterr().err


#: Mistakes across fields (references, uniqueness, windows against the
#: horizon): the scheduler rejects them; JSON Schema cannot say them, so
#: a schema-valid document may still be refused, with its reason.
SEMANTIC = {
    "duplicate id": make_doc([make_task(), make_task()]),
    "unknown resource": make_doc([make_task(uses={"laser": 1})]),
    "binary amount 2": make_doc(
        [make_task(uses={"cam": 2})], resources={"binary": ["cam"]}
    ),
    "longer than the horizon": make_doc([make_task(length=11)]),
    "window after its end": make_doc([make_task(feasible_interval=[5, 3])]),
    "precedence to an unknown task": make_doc(
        [make_task()],
        precedences=[{"before": "a", "after": "zz", "kind": "lax"}],
    ),
}


@pytest.mark.parametrize("name", sorted(SEMANTIC))
def test_cross_field_mistakes_are_rejected_by_the_scheduler(name: str) -> None:
    """Tests the mistakes a schema cannot express: the scheduler rejects
    each with a reason, although the schema accepts the shape."""
    doc = SEMANTIC[name]
    assert not list(PROBLEM.iter_errors(doc))
    with pytest.raises(InputError):
        decode_problem(json.dumps(doc))


def test_every_mistake_of_a_document_in_one_pass() -> None:
    """Tests a problem with eight mistakes of every sort: all are named at
    once (and one they cause), types and semantics together, with
    suggestions."""

    def edit(doc: dict) -> None:
        doc["tasks"][0]["feasable_interval"] = [10, 20]
        doc["tasks"][1]["length"] = "10"
        doc["tasks"][2]["preemption"] = "from_strat"
        doc["tasks"][3]["delay_cost"] = 9
        doc["tasks"][4]["uses"]["laser"] = 1
        doc["tasks"][5]["id"] = doc["tasks"][6]["id"]
        doc["precedences"][0]["after"] = "Nowhere"
        doc["colour"] = "blue"

    with pytest.raises(InputError) as info:
        decode_problem(json.dumps(_table1(edit)))
    found = {issue.path: issue.reason for issue in info.value.issues}
    assert (
        "did you mean 'feasible_interval'?"
        in (found["tasks[0].feasable_interval"])
    )
    assert found["tasks[1].length"] == "must be an integer, got a string"
    assert "did you mean 'from_start'?" in found["tasks[2].preemption"]
    assert (
        "'delete', 'from_interrupt', 'from_start', 'none'"
        in (found["tasks[2].preemption"])
    )
    assert found["tasks[3].delay_cost"] == "must be in 1..5, got 9"
    assert "unknown resource" in found["tasks[4].uses.laser"]
    assert "duplicate" in found["tasks[6].id"]
    assert "unknown task" in found["precedences[0].after"]
    assert "unknown field" in found["colour"]
    # The renamed task leaves a precedence of the original dangling: true.
    assert "unknown task" in found["precedences[2].before"]
    assert len(found) == 9, found


def test_a_syntax_error_says_line_and_column() -> None:
    """Tests that malformed JSON is placed by line and column."""
    with pytest.raises(InputError) as info:
        decode_problem('{"horizon": 3,\n  "tasks": [,]}')
    assert "line 2, column 13" in info.value.issues[0].reason


def test_a_number_beyond_a_float_is_placed_too() -> None:
    """Tests that a number past a float's range (which the decoder reports
    with no place) is named with its line and column, in a problem and in
    a goal."""
    with pytest.raises(InputError) as info:
        decode_problem('{"horizon": 3,\n  "tasks": [1E+400]}')
    (issue,) = info.value.issues
    assert issue.reason == (
        "number 1E+400 is beyond the range of a 64-bit float at line 2, "
        "column 13"
    )
    with pytest.raises(InputError) as info:
        decode_goal('{"goal_id": "g", "tasks": [{"length": -2e999}]}')
    assert "-2e999" in info.value.issues[0].reason
    assert "line 1, column 39" in info.value.issues[0].reason


def test_a_huge_number_is_shown_cut_in_its_reason() -> None:
    """Tests that an integer of 400 digits out of its range is named with
    its path and shown cut to a readable length, not echoed whole."""
    huge = "1" + "0" * 400
    with pytest.raises(InputError) as info:
        decode_problem(
            '{"horizon": 5, "start": ' + huge + ', "tasks": [{"id": "a",'
            ' "length": 1, "delay_cost": 1, "schedule_cost": 1}]}'
        )
    (issue,) = info.value.issues
    assert issue.path == "start"
    assert issue.reason.endswith("... is outside [0, 2147483647]")
    assert len(issue.reason) < 80


def test_goals_and_bus_inputs_are_strict_too() -> None:
    """Tests that a goal, a report and a level with an unknown field are
    rejected, named, and that the goal schema rejects the goal."""
    goal = json.loads((DATA / "paper_table2_goal.json").read_text())
    decode_goal(json.dumps(goal))
    assert not list(GOAL.iter_errors(goal))
    goal["tasks"][0]["lenght"] = 3
    with pytest.raises(InputError) as info:
        decode_goal(json.dumps(goal))
    assert "did you mean 'length'?" in info.value.issues[0].reason
    assert list(GOAL.iter_errors(goal))
    for kind, payload in (
        (
            "activity_report",
            {"task": "A", "state": "running", "at": 1, "x": 1},
        ),
        ("resource_level", {"resource": "b", "level": 1.0, "at": 1, "u": 1}),
    ):
        with pytest.raises(InputError):
            messages.decode_input(kind, json.dumps(payload).encode())
        assert list(_validator(kind).iter_errors(payload))


def test_the_shipped_examples_pass_both() -> None:
    """Tests that the example problem and goal pass the scheduler and the
    schemas (a strict schema that rejects good files is no help)."""
    for path in sorted(DATA.glob("paper_*.json")):
        doc = json.loads(path.read_text())
        validator = GOAL if "goal_id" in doc else PROBLEM
        assert not list(validator.iter_errors(doc)), path
        (decode_goal if "goal_id" in doc else decode_problem)(path.read_text())


#: Bus inputs with a mistake of shape: (kind, payload, path).
BUS_STATIC = [
    ("clock", {"now": -1}, "now"),
    ("clock", {"now": 2**62}, "now"),
    ("clock", {"now": "5"}, "now"),
    ("clock", {"nwo": 5}, "nwo"),
    ("activity_report", {"task": "a/b", "state": "running", "at": 1}, "task"),
    ("activity_report", {"task": "A", "state": "done", "at": 1}, "state"),
    ("activity_report", {"task": "A", "state": "running", "at": -1}, "at"),
    (
        "activity_report",
        {"task": "A", "state": "running", "at": 1, "term": -2},
        "term",
    ),
    ("resource_level", {"resource": "b*", "level": 1.0, "at": 1}, "resource"),
    ("resource_level", {"resource": "b", "level": "full", "at": 1}, "level"),
    ("resource_level", {"resource": "b", "level": 1.0, "at": -3}, "at"),
]


@pytest.mark.parametrize(("kind", "payload", "path"), BUS_STATIC)
def test_bus_input_mistakes_are_rejected_by_the_node_and_the_schema(
    kind: str, payload: dict, path: str
) -> None:
    """Tests each shape mistake of a clock, report or level: the decoder
    names its path, the shipped schema rejects the same message."""
    with pytest.raises(InputError) as info:
        messages.decode_input(kind, json.dumps(payload).encode())
    assert path in {issue.path for issue in info.value.issues}, info.value
    assert list(_validator(kind).iter_errors(payload)), (kind, payload)
