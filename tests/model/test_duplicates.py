"""Tests of duplicate keys: every strict decoder refuses a key written
twice, naming its path and both places, at little cost."""

from __future__ import annotations

import json
import time
from typing import TYPE_CHECKING

import msgspec
import pytest

from fsw_scheduler.errors import ConfigError, InputError
from fsw_scheduler.model.change import decode_change
from fsw_scheduler.model.codec import read_strict
from fsw_scheduler.model.duplicates import (
    count_kept_keys,
    count_text_keys,
    duplicate_issues,
)
from fsw_scheduler.model.goal import decode_goal
from fsw_scheduler.model.problem import Problem, decode_problem
from fsw_scheduler.runtime.config import load_config
from fsw_scheduler.wire import messages

from ..factories import make_doc, make_task

if TYPE_CHECKING:
    from collections.abc import Callable

TASK = '"id": "a", "delay_cost": 1, "schedule_cost": 1'


def _issues(decode: Callable[[str], object], text: str) -> dict[str, str]:
    with pytest.raises(InputError) as info:
        decode(text)
    return {issue.path: issue.reason for issue in info.value.issues}


def test_a_length_written_twice_is_refused_with_both_places() -> None:
    """Tests the issue's case: ``"length": 3, "length": 30`` is not
    planned as 30 units but refused, with line and column of each."""
    text = (
        '{"horizon": 50, "tasks": [{' + TASK + ',\n "length": 3, '
        '"length": 30}]}'
    )
    found = _issues(decode_problem, text)
    assert list(found) == ["tasks[0].length"]
    reason = found["tasks[0].length"]
    assert "written 2 times" in reason
    assert "line 2, column 2" in reason
    assert "line 2, column 15" in reason


def test_a_goal_with_two_ids_and_two_lengths_names_both() -> None:
    """Tests a goal with two ``goal_id`` and two ``length``: both keys are
    named, in document order, with the shape mistakes of the same pass."""
    text = (
        '{"goal_id": "g1", "goal_id": "g2", "tasks": [{' + TASK + ", "
        '"length": 3, "length": 30, "preemption": "never"}]}'
    )
    found = _issues(decode_goal, text)
    assert list(found) == [
        "goal_id",
        "tasks[0].length",
        "tasks[0].preemption",
    ]


@pytest.mark.parametrize(
    ("kind", "text", "path"),
    [
        ("clock", '{"now": 3, "now": 30}', "now"),
        (
            "resource_level",
            '{"resource": "battery", "level": 1, "level": 9, "at": 1}',
            "level",
        ),
        (
            "activity_report",
            '{"task": "A", "state": "running", "state": "failed", "at": 1}',
            "state",
        ),
        (
            "goal",
            '{"goal_id": "g", "tasks": [{' + TASK + ', "length": 1, '
            '"uses": {"power": 1, "power": 9}}]}',
            "tasks[0].uses.power",
        ),
    ],
)
def test_every_bus_input_refuses_a_key_written_twice(
    kind: str, text: str, path: str
) -> None:
    """Tests the bus decoders (clock, level, report, goal): the node's
    decoder names the repeated key."""
    with pytest.raises(InputError) as info:
        messages.decode_input(kind, text.encode())
    assert [issue.path for issue in info.value.issues] == [path]


def test_a_change_document_refuses_a_key_written_twice() -> None:
    """Tests the change format (reports and removals from a file)."""
    text = '{"event": "activity_failed", "task": "a", "at": 1, "at": 2}'
    assert list(_issues(decode_change, text)) == ["at"]


def test_a_settings_file_refuses_a_key_written_twice(tmp_path) -> None:
    """Tests that the TOML settings refuse ``heartbeat`` twice (TOML itself
    forbids it; the message names the key)."""
    path = tmp_path / "node.toml"
    path.write_text("heartbeat = 5\nheartbeat = 10\n")
    with pytest.raises(ConfigError, match="heartbeat"):
        load_config(path)


def test_keys_equal_after_unescaping_are_the_same_key() -> None:
    """Tests that ``"a"`` and ``"\\u0061"`` count as one key written twice
    (the parser keeps one of them)."""
    text = '{"horizon": 5, "tasks": [], "horizon": 6}'
    assert list(_issues(decode_problem, text)) == ["horizon"]
    escaped = '{"horizon": 5, "tasks": [], "\\u0068orizon": 6}'
    assert list(_issues(decode_problem, escaped)) == ["horizon"]


def test_no_duplicate_is_seen_where_there_is_none() -> None:
    """Tests no false alarm: the same key in sibling objects, quotes and
    colons inside strings, keys that are JSON text themselves."""
    doc = {
        "a": {"x": 1, "y": '":" \\" x": 1'},
        "b": [{"x": 1}, {"x": 2}, {'"x": 1, "x"': {"x": [1, {}]}}],
        "c": '{"k": 1, "k": 2}',
    }
    for indent in (None, 2):
        text = json.dumps(doc, indent=indent)
        raw = msgspec.json.decode(text)
        assert count_text_keys(text.encode()) == count_kept_keys(raw) == 9
        assert duplicate_issues(text, raw) == []


def test_a_repeated_key_deep_in_arrays_is_placed() -> None:
    """Tests the slow path's paths: indexes of arrays, nested objects,
    a key that is not an id."""
    text = '{"a": [1, [2, {"b": {"c d": 1, "c d": 2}}]]}'
    issues = duplicate_issues(text, msgspec.json.decode(text))
    assert [issue.path for issue in issues] == ["a[1][1].b['c d']"]


def test_the_check_costs_little_beside_strict_decoding() -> None:
    """Tests the cost on a 1000-task problem with no duplicate: the
    check takes under a fifth of the strict decoder's time (it counts
    keys in one regular-expression pass and one walk)."""
    tasks = [
        make_task(
            f"t{i}",
            uses={"power": 2, "battery": 1},
            feasible_interval=[0, 400],
        )
        for i in range(1000)
    ]
    doc = make_doc(
        tasks,
        horizon=500,
        resources={"multiple": {"power": 10}, "consumable": {"battery": 99}},
    )
    text = json.dumps(doc, indent=1).encode()
    raw = msgspec.json.decode(text)

    def best(run: Callable[[], object], repeat: int = 5) -> float:
        times = []
        for _ in range(repeat):
            start = time.perf_counter()
            run()
            times.append(time.perf_counter() - start)
        return min(times)

    check = best(lambda: duplicate_issues(text, raw))
    strict = best(lambda: read_strict(text, Problem, "problem"))
    assert check < 0.2 * strict, (check, strict)
