"""Tests of the library entry points (fsw_scheduler.api, package top)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import fsw_scheduler as fs
from fsw_scheduler.model.problem import decode_problem

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "fsw_scheduler" / "data"
TINY = {
    "horizon": 6,
    "resources": {"binary": ["camera"]},
    "tasks": [
        {
            "id": "a",
            "length": 2,
            "delay_cost": 1,
            "schedule_cost": 1,
            "uses": {"camera": 1},
        },
        {
            "id": "b",
            "length": 3,
            "delay_cost": 2,
            "schedule_cost": 1,
            "uses": {"camera": 1},
        },
    ],
}


@pytest.mark.parametrize(
    "form", ["typed", "dict", "text", "bytes", "path"], ids=str
)
def test_solve_accepts_every_form(form: str, tmp_path: Path) -> None:
    """Tests that solve takes a Problem, a dict, JSON text, bytes, a file."""
    text = json.dumps(TINY)
    (tmp_path / "p.json").write_text(text)
    problem = {
        "typed": decode_problem(text),
        "dict": TINY,
        "text": text,
        "bytes": text.encode(),
        "path": tmp_path / "p.json",
    }[form]
    plan = fs.solve(problem)
    assert plan.status is fs.SolveStatus.OPTIMAL
    assert plan.starts() == {"b": 0, "a": 3}


def test_plan_to_dict_and_json_round_trip() -> None:
    """Tests that to_dict/to_json give the plan format back, decodable."""
    plan = fs.solve(TINY)
    data = plan.to_dict()
    assert data["status"] == "optimal"
    assert data["activities"][0] == {"task": "b", "start": 0, "end": 3}
    assert json.loads(plan.to_json()) == data
    assert json.loads(plan.to_json(indent=2)) == data
    assert "\n" in plan.to_json(indent=2)
    assert fs.as_plan(plan.to_json()) == plan
    assert fs.as_plan(data) == plan


def test_check_plan_accepts_dicts_and_reports_violations() -> None:
    """Tests that check_plan takes dicts and names a broken rule."""
    plan = fs.solve(TINY).to_dict()
    assert fs.check_plan(TINY, plan).ok
    plan["activities"][1]["start"] = 1
    plan["activities"][1]["end"] = 3
    report = fs.check_plan(json.dumps(TINY), plan)
    assert not report.ok
    assert "binary" in report.rules


def test_replan_accepts_files_as_text() -> None:
    """Tests that replan takes the paper's files as JSON text."""
    problem = (DATA / "paper_table1.json").read_text()
    plan = fs.solve(problem)
    goal = (DATA / "paper_table2_goal.json").read_bytes()
    new_problem, new_plan, diff = fs.replan(problem, plan.to_dict(), goal, 15)
    assert new_problem.start == 15
    assert new_plan.status.has_plan
    assert fs.check_plan(new_problem, new_plan).ok
    assert {r.task for r in diff.removed} >= {"AcquisitionHF"}


def test_replan_accepts_an_event_dict() -> None:
    """Tests that an event given as a dict is told apart from a goal."""
    plan = fs.solve(TINY)
    event = {"event": "activity_failed", "task": "b", "at": 1}
    new_problem, new_plan, _ = fs.replan(TINY, plan, event, 1)
    assert new_problem.start == 1
    assert new_plan.activity("b") is not None


def test_bad_inputs_name_the_field() -> None:
    """Tests that a wrong dict raises InputError with the field path."""
    bad = json.loads(json.dumps(TINY))
    bad["tasks"][1]["uses"] = {"laser": 1}
    with pytest.raises(fs.InputError) as caught:
        fs.solve(bad)
    assert "tasks[1].uses.laser" in str(caught.value)
    with pytest.raises(fs.InputError, match="expected a problem"):
        fs.solve(42)  # type: ignore[arg-type]
    with pytest.raises(fs.InputError):
        fs.solve("{not json")
    with pytest.raises(fs.InputError, match="cannot read"):
        fs.solve(Path("/nonexistent/problem.json"))
    typed = decode_problem(json.dumps(TINY)).replace(horizon=0)
    with pytest.raises(fs.InputError, match="horizon"):
        fs.solve(typed)


def test_package_top_exports_the_entry_points() -> None:
    """Tests that check_plan, replan and decoders are at the package top."""
    import importlib

    importlib.import_module("fsw_scheduler.solving.solve")  # must not rebind
    assert callable(fs.solve) and callable(fs.check_plan)
    # The checker module stays importable by its name.
    from fsw_scheduler.analysis import check

    assert check.check_plan is not fs.check_plan
    assert fs.check_plan.__module__ == "fsw_scheduler.api"
    for name in ("replan", "decode_goal", "decode_change", "Goal"):
        assert name in dir(fs)
