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
from typing import TYPE_CHECKING, Any

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


def tool_script(name: str, module: str | None = None) -> ModuleType:
    """The script ``tools/<name>`` loaded as the module ``module``."""
    if str(TOOLS) not in sys.path:
        sys.path.insert(0, str(TOOLS))
    return importlib.import_module("soak_lib").load_script(name, module)
