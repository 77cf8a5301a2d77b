"""Robustness of the scheduler node on a real Zenoh bus (issue 12).

Each test drives the real node on loopback peers (scouting off,
ephemeral ports) with the real CBC, and waits on received samples,
liveliness or query answers, never on fixed sleeps.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

from fsw_scheduler.bus import topics as keys
from fsw_scheduler.model import MAX_ID_LENGTH

if TYPE_CHECKING:
    from collections.abc import Iterator

    from fsw_scheduler.testing import SchedulerHarness

pytest_plugins = ["fsw_scheduler.testing"]

DATA = Path(__file__).resolve().parents[1] / "fsw_scheduler" / "data"


def goal_of(goal_id: str, *tasks: dict, **extra: object) -> dict:
    """A goal document with ``tasks``."""
    return {"goal_id": goal_id, "tasks": list(tasks), **extra}


def task(task_id: str, **extra: object) -> dict:
    """A short, cheap task that fits at once."""
    return {
        "id": task_id,
        "length": 1,
        "delay_cost": 5,
        "schedule_cost": 3,
        "uses": {"power": 5},
        **extra,
    }


@pytest.fixture
def started(
    scheduler_harness: SchedulerHarness,
) -> Iterator[SchedulerHarness]:
    """A harness whose node has adopted its initial plan at t=0."""
    scheduler_harness.tick(0)
    scheduler_harness.wait_plan(lambda p: p.plan_id == 1)
    yield scheduler_harness


def rejection(h: SchedulerHarness, goal: object, goal_id: str | None):
    """Publish ``goal`` and return the goal_rejected status naming it."""
    seen = len(h.statuses)
    h.publish_goal(goal)
    return h.wait_status(
        lambda s: s.event == "goal_rejected" and s.goal_id == goal_id,
        since=seen,
    )


# -- finding 2: key-safe ids -------------------------------------------------

UNSAFE_IDS = ["a/b", "x*", "$*", "q?", "h#", "a//b", "**", "@x", "", "é"]


def test_unsafe_task_ids_are_rejected_on_the_bus(
    started: SchedulerHarness,
) -> None:
    """Tests that key-unsafe or too long ids are rejected with path+reason."""
    h = started
    for n, bad in enumerate([*UNSAFE_IDS, "L" * 65_536]):
        status = rejection(h, goal_of(f"g{n}", task(bad)), f"g{n}")
        assert [e.path for e in status.errors] == ["tasks[0].id"], bad
        reason = status.errors[0].reason
        assert "task id" in reason
        assert len(reason) < 200  # a huge id is not echoed back
    # A bad goal id, a bad resource name and a bad obsoletes entry.
    status = rejection(h, goal_of("a/b", task("Fine")), "a/b")
    assert [e.path for e in status.errors] == ["goal_id"]
    long_id = "g" * (MAX_ID_LENGTH + 1)
    status = rejection(h, goal_of(long_id, task("Fine")), long_id)
    assert "at most 64" in status.errors[0].reason
    status = rejection(
        h, goal_of("res", task("Fine", uses={"po*wer": 1})), "res"
    )
    assert [e.path for e in status.errors] == ["tasks[0].uses['po*wer']"]
    status = rejection(
        h, goal_of("obs", task("Fine", obsoletes=["a/b"])), "obs"
    )
    assert [e.path for e in status.errors] == ["tasks[0].obsoletes[0]"]
    # Nothing was dispatched on a key built from a bad id, and the node
    # still serves.
    assert all(
        key.count("/") == 4 and "*" not in key
        for key, _ in h.samples
        if "/dispatch/" in key
    )
    status = h.tick(1)
    assert status.plan_id == 1
    assert status.counters.goals_rejected == len(UNSAFE_IDS) + 5


def test_unsafe_ids_are_rejected_by_solve_and_replan(
    tmp_path: Path, table1_doc: dict
) -> None:
    """Tests that solve and replan reject unsafe ids with path and reason."""
    doc = json.loads(json.dumps(table1_doc))
    doc["tasks"][0]["id"] = "Set/HF"
    doc["resources"]["binary"][0] = "cam*"
    problem = tmp_path / "p.json"
    problem.write_text(json.dumps(doc))
    done = subprocess.run(
        [sys.executable, "-m", "fsw_scheduler.cli", "solve", str(problem)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2
    assert "tasks[0].id: task id 'Set/HF' has characters" in done.stderr
    assert "resources.binary[0]: resource name 'cam*'" in done.stderr
    plan = tmp_path / "plan.json"
    solved = subprocess.run(
        [
            sys.executable,
            "-m",
            "fsw_scheduler.cli",
            "solve",
            str(DATA / "paper_table1.json"),
            "--out",
            str(plan),
        ],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert solved.returncode == 0, solved.stderr
    goal = tmp_path / "goal.json"
    goal.write_text(json.dumps(goal_of("g", task("**"))))
    replan = subprocess.run(
        [
            sys.executable,
            "-m",
            "fsw_scheduler.cli",
            "replan",
            str(DATA / "paper_table1.json"),
            str(plan),
            str(goal),
            "--now",
            "1",
        ],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert replan.returncode == 2
    assert "tasks[0].id: task id '**'" in replan.stderr


# -- finding 9: hostile structure --------------------------------------------


def test_deep_nesting_and_dict_paths_on_the_bus(
    started: SchedulerHarness,
) -> None:
    """Tests that a deeply nested goal is rejected by name, paths name keys."""
    h = started
    deep = (
        b'{"goal_id": "deep", "pad": '
        + b"[" * 100_000
        + b"]" * 100_000
        + b', "tasks": []}'
    )
    status = rejection(h, deep, "deep")
    assert "nested too deeply" in status.errors[0].reason
    deep_first = b'{"tasks": ' + b"[" * 100_000 + b"]" * 100_000
    deep_first += b', "goal_id": "deep2"}'
    status = rejection(h, deep_first, "deep2")
    assert status.errors
    status = rejection(
        h, goal_of("typed", task("T", uses={"power": "lots"})), "typed"
    )
    assert [e.path for e in status.errors] == ["tasks[0].uses.power"]
    assert "float" in status.errors[0].reason
    assert h.tick(1).plan_id == 1


def test_spacecraft_id_is_checked() -> None:
    """Tests that `run --spacecraft` refuses a key-unsafe id."""
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "fsw_scheduler.cli",
            "run",
            "--problem",
            str(DATA / "paper_table1.json"),
            "--spacecraft",
            "sat/*",
        ],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2
    assert "spacecraft id 'sat/*'" in done.stderr
    assert keys.DEFAULT_SPACECRAFT == "sat1"
