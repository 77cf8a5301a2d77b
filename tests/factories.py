"""Shared test factories: paths, problem and task dicts, the command line.

Every test that builds a task, a problem document, a command line or
loads one of ``tools/`` takes it from here, so a change in the formats
is made once. Fixtures (the paper's scenarios) are in ``conftest.py``.
"""

from __future__ import annotations

import importlib
import importlib.machinery
import importlib.util
import json
import shutil
import socket
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import pytest

from fsw_scheduler.model.problem import Problem, decode_problem

if TYPE_CHECKING:
    from types import ModuleType

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "fsw_scheduler" / "data"
TOOLS = ROOT / "tools"
TABLE1 = str(DATA / "paper_table1.json")
TABLE2 = str(DATA / "paper_table2_goal.json")

#: ``python -m fsw_scheduler.cli``: the command line in a fresh interpreter.
CLI = (sys.executable, "-m", "fsw_scheduler.cli")

#: The optimal Table 1 plan (task, start, end): delay cost 359.
TABLE1_PLAN = (
    ("SetHFOption", 0, 1),
    ("SetPositionX", 0, 1),
    ("DownlinkSat2Sat", 1, 6),
    ("SetPositionK", 6, 7),
    ("BatteryCharge", 7, 17),
    ("SetPositionZ", 17, 18),
    ("AcquisitionHF", 18, 38),
    ("SetPositionY", 38, 39),
    ("DownlinkSat2Ground", 39, 49),
)

#: One resource of each kind: a camera, 10 units of power, 5 of battery.
ONE_OF_EACH = {
    "binary": ["cam"],
    "multiple": {"power": 10},
    "consumable": {"battery": 5},
}


def make_task(name: str = "a", length: int = 2, **over: Any) -> dict:
    """A task dict: ``length`` units, delay and schedule costs 1.

    Parameters
    ----------
    name
        The task id (``id=`` in ``over`` wins, for tests about ids).
    length
        Its length in time units.
    **over
        Any other task field, or one to replace.
    """
    task: dict[str, Any] = {
        "id": name,
        "length": length,
        "delay_cost": 1,
        "schedule_cost": 1,
    }
    task.update(over)
    return task


def crowded_camera(count: int) -> dict:
    """A problem dict: one camera over 10 units, ``long`` (worth 5) and
    ``count`` more tasks (worth 1, ids ``t00``... as wide as ``count``
    needs), each 10 units long: only one task fits in all."""
    width = len(str(count - 1))
    tasks = [make_task("long", 10, schedule_cost=5, uses={"camera": 1})]
    tasks += [
        make_task(f"t{k:0{width}d}", 10, schedule_cost=1, uses={"camera": 1})
        for k in range(count)
    ]
    return {"horizon": 10, "resources": {"binary": ["camera"]}, "tasks": tasks}


def make_doc(
    tasks: list[dict],
    horizon: int = 10,
    resources: dict | None = None,
    **over: Any,
) -> dict:
    """A problem dict of ``tasks`` (no resources unless given)."""
    doc: dict[str, Any] = {"horizon": horizon, "tasks": tasks}
    if resources is not None:
        doc["resources"] = resources
    doc.update(over)
    return doc


def problem_from(doc: dict) -> Problem:
    """Decode a problem from a Python dict (validating it)."""
    return decode_problem(json.dumps(doc))


def free_port() -> int:
    """A loopback TCP port free now (another process may take it before
    it is bound: callers whose node then fails to start retry)."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def cli_command(*args: str) -> list[str]:
    """The installed ``fsw-scheduler`` script with ``args``, or ``CLI``."""
    script = Path(sys.executable).with_name("fsw-scheduler")
    head = [str(script)] if script.exists() else list(CLI)
    return [*head, *args]


def ping_goal(goal_id: str, task: str = "Ping", **extra: object) -> dict:
    """A goal of one short, cheap task that fits at once."""
    return {
        "goal_id": goal_id,
        "tasks": [
            {
                "id": task,
                "length": 1,
                "delay_cost": 5,
                "schedule_cost": 3,
                "uses": {"power": 5},
            }
        ],
        **extra,
    }


def tool(name: str) -> str:
    """The path of a console tool of this environment, or skip."""
    found = shutil.which(name, path=str(Path(sys.executable).parent))
    if found is None:
        pytest.skip(f"{name} is not installed (pip install -e '.[test]')")
    return found


def bench_lib(name: str) -> ModuleType:
    """``tools/bench_lib/<name>``, imported (the benchmark's library)."""
    if str(TOOLS) not in sys.path:
        sys.path.insert(0, str(TOOLS))
    return importlib.import_module(f"bench_lib.{name}")


def large_suite_problem(seed: int, name: str) -> Problem:
    """The problem ``name`` of the benchmark's large suite of ``seed``
    (``tools/bench_lib/generator.py``), e.g. ``b60-h1440``."""
    suite = bench_lib("generator").large_suite(seed)
    return next(p for p in suite if p.name == name).problem()


def tool_script(name: str, module: str | None = None) -> ModuleType:
    """The script ``tools/<name>`` loaded as the module ``module``."""
    if str(TOOLS) not in sys.path:
        sys.path.insert(0, str(TOOLS))
    return importlib.import_module("soak_lib").load_script(name, module)


class InvalidInput(NamedTuple):
    """A bus input that must be refused, and where.

    Attributes
    ----------
    name
        What is wrong, in words (the test's id).
    kind
        ``goal``, ``clock``, ``activity_report`` or ``resource_level``.
    text
        The payload, as sent (a key written twice cannot be a dict).
    path
        The field path every refusal must name.
    schema
        Whether JSON Schema can say it: a key written twice is gone from
        the parsed document, an unknown resource depends on the node.
    """

    name: str
    kind: str
    text: str
    path: str
    schema: bool = True


def _goal_text(**task: Any) -> str:
    doc = {
        "goal_id": "g-bad",
        "tasks": [make_task("T", **{"length": 1, **task})],
    }
    return json.dumps(doc)


#: Every invalid bus input of the suite, against the paper's Table 1
#: (power, battery): refused by ``send`` (exit 2, naming ``path``), by the
#: node on the bus (its rejection names ``path``) and, where it can say
#: it, by the shipped JSON Schema.
INVALID_INPUTS = [
    InvalidInput("clock before 0", "clock", '{"now": -1}', "now"),
    InvalidInput(
        "clock past the limit", "clock", '{"now": 4611686018427387904}', "now"
    ),
    InvalidInput("clock as a string", "clock", '{"now": "5"}', "now"),
    InvalidInput("clock misspelt", "clock", '{"nwo": 5}', "nwo"),
    InvalidInput(
        "clock twice", "clock", '{"now": 3, "now": 30}', "now", False
    ),
    InvalidInput(
        "report of a key-unsafe task",
        "activity_report",
        '{"task": "a/b", "state": "running", "at": 1}',
        "task",
    ),
    InvalidInput(
        "report state misspelt",
        "activity_report",
        '{"task": "A", "state": "done", "at": 1}',
        "state",
    ),
    InvalidInput(
        "report before 0",
        "activity_report",
        '{"task": "A", "state": "running", "at": -1}',
        "at",
    ),
    InvalidInput(
        "report of a negative term",
        "activity_report",
        '{"task": "A", "state": "running", "at": 1, "term": -2}',
        "term",
    ),
    InvalidInput(
        "report state twice",
        "activity_report",
        '{"task": "A", "state": "running", "state": "failed", "at": 1}',
        "state",
        False,
    ),
    InvalidInput(
        "level of a key-unsafe resource",
        "resource_level",
        '{"resource": "b*", "level": 1.0, "at": 1}',
        "resource",
    ),
    InvalidInput(
        "level as a word",
        "resource_level",
        '{"resource": "battery", "level": "full", "at": 1}',
        "level",
    ),
    InvalidInput(
        "level before 0",
        "resource_level",
        '{"resource": "battery", "level": 1.0, "at": -3}',
        "at",
    ),
    InvalidInput(
        "negative level",
        "resource_level",
        '{"resource": "battery", "level": -3, "at": 1}',
        "level",
    ),
    InvalidInput(
        "level twice",
        "resource_level",
        '{"resource": "battery", "level": 1, "level": 9, "at": 1}',
        "level",
        False,
    ),
    InvalidInput(
        "goal without a task",
        "goal",
        '{"goal_id": "g-bad", "tasks": []}',
        "tasks",
    ),
    InvalidInput(
        "window before 0",
        "goal",
        _goal_text(feasible_interval=[-5, 50]),
        "tasks[0].feasible_interval[0]",
    ),
    InvalidInput(
        "fractional length", "goal", _goal_text(length=1.5), "tasks[0].length"
    ),
    InvalidInput(
        "misspelt task field",
        "goal",
        _goal_text(feasable_interval=[1, 9]),
        "tasks[0].feasable_interval",
    ),
    InvalidInput(
        "key-unsafe task id", "goal", _goal_text(id="T/1"), "tasks[0].id"
    ),
    InvalidInput(
        "schedule cost 6",
        "goal",
        _goal_text(schedule_cost=6),
        "tasks[0].schedule_cost",
    ),
    InvalidInput(
        "length twice",
        "goal",
        '{"goal_id": "g-bad", "tasks": [{"id": "T", "delay_cost": 1, '
        '"schedule_cost": 1, "length": 3, "length": 30}]}',
        "tasks[0].length",
        False,
    ),
    InvalidInput(
        "unknown resource",
        "goal",
        _goal_text(uses={"laser": 1}),
        "tasks[0].uses.laser",
        False,
    ),
]
