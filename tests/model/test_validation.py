"""Tests of the problem rules and their public seam (model.validation)."""

from __future__ import annotations

import pytest

from fsw_scheduler.errors import InputError
from fsw_scheduler.model import codec, limits, problem, validation
from fsw_scheduler.model.problem import Task
from fsw_scheduler.model.validation import check_task, check_use

from ..factories import ONE_OF_EACH, make_doc, make_task, problem_from

#: The names model.problem held before codec, limits and validation were
#: split out of it: imports from model.problem must keep working.
MOVED = {
    codec: ("MAX_DEPTH_NOTE", "decode_strict", "encode", "read_strict"),
    limits: (
        "ID_CHARS",
        "MAX_COST",
        "MAX_DELAY_COST",
        "MAX_ID_LENGTH",
        "MAX_TIME",
        "MIN_COST",
        "MIN_DELAY_COST",
        "id_issue",
        "key_path",
        "shown",
    ),
    validation: ("duplicate_ids", "time_issues", "validate_problem"),
}


def test_problem_module_keeps_the_names_it_had() -> None:
    """Tests that every name moved out of model.problem is still there, as
    the same object."""
    for home, names in MOVED.items():
        for name in names:
            assert getattr(problem, name) is getattr(home, name), name


def test_check_use_words_each_mistake_at_its_path() -> None:
    """Tests that check_use names an unknown resource with the known ones,
    a binary amount other than 1 and a negative multiple amount, and lets
    a consumable be generated."""
    resources = problem_from(make_doc([make_task()], resources=ONE_OF_EACH))
    known = resources.resources

    def found(name: str, amount: float) -> list[tuple[str, str]]:
        return [
            (i.path, i.reason)
            for i in check_use(known, name, amount, "tasks[2]")
        ]

    assert found("sun", 1) == [
        ("tasks[2].uses.sun", "unknown resource (known: cam, power, battery)")
    ]
    assert found("cam", 2) == [
        ("tasks[2].uses.cam", "binary resource amount must be 1, got 2")
    ]
    assert found("power", -1) == [
        (
            "tasks[2].uses.power",
            "multiple resource amount must be >= 0, got -1",
        )
    ]
    assert found("battery", -3) == []


def test_check_task_gives_what_decoding_gives() -> None:
    """Tests that check_task reports a task's mistakes with the words and
    paths of decode_problem, under the path it is given."""
    bad = make_task("b", length=20, uses={"cam": 2})
    with pytest.raises(InputError) as info:
        problem_from(make_doc([make_task(), bad], resources=ONE_OF_EACH))
    decoded = [(i.path, i.reason) for i in info.value.issues]
    base = problem_from(make_doc([make_task()], resources=ONE_OF_EACH))
    task = Task(
        id="b", length=20, delay_cost=1, schedule_cost=1, uses={"cam": 2.0}
    )
    checked = [(i.path, i.reason) for i in check_task(base, task, "tasks[1]")]
    assert (
        checked
        == decoded
        == [
            ("tasks[1].uses.cam", "binary resource amount must be 1, got 2.0"),
            ("tasks[1].length", "length 20 exceeds the horizon 10"),
        ]
    )


def test_the_longest_horizon_is_enforced_with_its_reason() -> None:
    """Tests that a horizon past MAX_HORIZON is rejected at the horizon's
    path with why, decoded or built in Python, and that MAX_HORIZON
    itself is accepted."""
    doc = make_doc([make_task()])
    doc["horizon"] = limits.MAX_HORIZON
    assert problem_from(doc).horizon == limits.MAX_HORIZON
    doc["horizon"] = limits.MAX_HORIZON + 1
    with pytest.raises(InputError) as caught:
        problem_from(doc)
    (issue,) = [i for i in caught.value.issues if i.path == "horizon"]
    assert "the longest horizon" in issue.reason
    assert "time limit no longer bounds" in issue.reason
    built = problem.Problem(
        horizon=limits.MAX_HORIZON * 2, tasks=(Task("a", 2, 1, 1),)
    )
    (issue,) = validation.validate_problem(built)
    assert issue.path == "horizon"
    assert f"longest horizon, {limits.MAX_HORIZON}" in issue.reason
