"""Tests of problem decoding and validation (fsw_scheduler.model)."""

from __future__ import annotations

import copy

import pytest

from fsw_scheduler.errors import InputError
from fsw_scheduler.model.problem import decode_problem

from ..factories import ONE_OF_EACH, make_doc, make_task, problem_from


def _doc(tasks: list[dict], **over: object) -> dict:
    doc = make_doc(tasks, resources=ONE_OF_EACH, precedences=[])
    doc.update(over)
    return doc


def _issues(doc: dict) -> list[tuple[str, str]]:
    with pytest.raises(InputError) as info:
        problem_from(doc)
    return [(i.path, i.reason) for i in info.value.issues]


def test_table1_decodes(table1_doc: dict) -> None:
    """Tests that the paper's Table 1 file decodes with its nine tasks."""
    problem = problem_from(table1_doc)
    assert problem.num_tasks == 9
    assert problem.feasible_interval_applies_to == "start"
    assert problem.start_bounds(problem.task("BatteryCharge")) == (0, 15)


def test_window_readings() -> None:
    """Tests that the task reading keeps the whole task inside [a, b]."""
    whole = problem_from(_doc([make_task(feasible_interval=[2, 6])]))
    assert whole.start_bounds(whole.tasks[0]) == (2, 4)
    start = problem_from(
        _doc(
            [make_task(feasible_interval=[2, 6])],
            feasible_interval_applies_to="start",
        )
    )
    assert start.start_bounds(start.tasks[0]) == (2, 6)


@pytest.mark.parametrize(
    ("tasks", "over", "path", "words"),
    [
        ([make_task(), make_task()], {}, "tasks[1].id", "duplicate"),
        ([make_task(uses={"laser": 1})], {}, "tasks[0].uses.laser", "unknown"),
        ([make_task(uses={"cam": 2})], {}, "tasks[0].uses.cam", "must be 1"),
        ([make_task(uses={"power": -1})], {}, "tasks[0].uses.power", ">= 0"),
        ([make_task(length=0)], {}, "tasks[0].length", "outside [1,"),
        ([make_task(length=11)], {}, "tasks[0].length", "exceeds the horizon"),
        ([make_task(delay_cost=0)], {}, "tasks[0].delay_cost", "1..5"),
        ([make_task(schedule_cost=6)], {}, "tasks[0].schedule_cost", "0..5"),
        (
            [make_task(feasible_interval=[3, 4])],
            {},
            "tasks[0].feasible_interval",
            "cannot hold",
        ),
        (
            [make_task(feasible_interval=[5, 3])],
            {},
            "tasks[0].feasible_interval",
            "after end",
        ),
        (
            [make_task(feasible_interval=[20, 30])],
            {},
            "tasks[0].feasible_interval",
            "no start time",
        ),
        ([make_task()], {"horizon": 0}, "horizon", "1..100000, got 0"),
        (
            [make_task()],
            {"precedences": [{"before": "a", "after": "zz", "kind": "lax"}]},
            "precedences[0].after",
            "unknown task",
        ),
        (
            [make_task()],
            {"precedences": [{"before": "a", "after": "a", "kind": "lax"}]},
            "precedences[0].after",
            "itself",
        ),
        (
            [make_task()],
            {"resources": {"consumable": {"battery": -1}}},
            "resources.consumable.battery",
            ">= 0",
        ),
        (
            [make_task()],
            {"resources": {"binary": ["x"], "multiple": {"x": 1}}},
            "resources.multiple.x",
            "already declared",
        ),
        ([], {}, "tasks", "at least one"),
    ],
)
def test_validation_rules(
    tasks: list[dict], over: dict, path: str, words: str
) -> None:
    """Tests that each validation rule names the field path and reason."""
    issues = _issues(_doc(copy.deepcopy(tasks), **over))
    assert any(p == path and words in r for p, r in issues), issues


def test_tight_cycle_that_holds_is_accepted() -> None:
    """Tests that a tight cycle whose offsets sum to zero is accepted."""
    doc = _doc(
        [make_task(id="a"), make_task(id="b")],
        precedences=[
            {"before": "a", "after": "b", "kind": "tight", "offset": -2},
            {"before": "b", "after": "a", "kind": "tight", "offset": -2},
        ],
    )
    assert problem_from(doc).num_tasks == 2


@pytest.mark.parametrize(
    ("text", "path"),
    [
        (b'{"horizon": "ten", "tasks": []}', "horizon"),
        (b'{"tasks": []}', "horizon"),
        (
            b'{"horizon": 5, "tasks": [{"id": "a", "length": 1}]}',
            "tasks[0].delay_cost",
        ),
        (
            b'{"horizon": 5, "tasks": [{"id": "a", "length": 1, '
            b'"delay_cost": 1, "schedule_cost": 1, "preemption": "maybe"}]}',
            "tasks[0].preemption",
        ),
        (b"{not json", ""),
    ],
)
def test_type_errors_name_the_field(text: bytes, path: str) -> None:
    """Tests that wrong types and missing fields name their path."""
    with pytest.raises(InputError) as info:
        decode_problem(text)
    assert info.value.issues[0].path == path
    assert info.value.issues[0].reason


@pytest.mark.parametrize(
    ("start", "horizon"), [(0, 40), (5, 12), (15, 3), (25, 100), (0, 2)]
)
def test_external_charge_is_the_sum_of_the_positive_rates(
    start: int, horizon: int
) -> None:
    """Tests that the external charge read from the steps is the sum of
    the positive rates of every unit, from before the first step to past
    the last one."""
    doc = make_doc([make_task("a", uses={"battery": 1})])
    doc["start"] = start
    doc["horizon"] = horizon
    doc["resources"] = {
        "consumable": {
            "battery": {
                "initial": 5,
                "external": [[3, 1.5], [10, -2], [14, 0.25], [30, 0]],
            }
        }
    }
    resources = problem_from(doc).resources
    units = resources.external_profile("battery", start, horizon)
    assert resources.external_charge("battery", start, horizon) == (
        pytest.approx(sum(max(0.0, rate) for rate in units))
    )
