"""Tests of the library entry points (fsw_scheduler.api, package top)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypedDict

import pytest

import fsw_scheduler as fs
from fsw_scheduler.model.problem import decode_problem

if TYPE_CHECKING:
    from fsw_scheduler.api import ProblemLike
    from fsw_scheduler.model.plan import Plan
    from fsw_scheduler.model.stability import Mode

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
    problems: dict[str, ProblemLike] = {
        "typed": decode_problem(text),
        "dict": TINY,
        "text": text,
        "bytes": text.encode(),
        "path": tmp_path / "p.json",
    }
    plan = fs.solve(problems[form])
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


class StabilitySettings(TypedDict, total=False):
    """The stability keywords of ``fs.replan`` and of ``EngineConfig``."""

    commit_window: int
    stability: Mode
    move_cost: int


def _paper_at_15() -> tuple[str, Plan, Path]:
    """Table 1, its plan and the Table 2 goal, for a replan at t=15."""
    problem = (DATA / "paper_table1.json").read_text()
    return problem, fs.solve(problem), (DATA / "paper_table2_goal.json")


@pytest.mark.parametrize(
    "settings",
    [
        {"stability": "lexicographic"},
        {"stability": "moves", "move_cost": 1000},
        {"commit_window": 30},
    ],
)
def test_replan_takes_the_stability_settings(
    settings: StabilitySettings,
) -> None:
    """Tests that the Table 2 replan at t=15, which moves SetPositionY and
    DownlinkSat2Ground 5 units earlier by default, moves nothing planned
    under lexicographic stability, under a high move cost or inside a
    30-unit commit window, and that each setting shows in the plan (its
    objective's moves) or the diff."""
    problem, plan, goal = _paper_at_15()
    _, free, free_diff = fs.replan(problem, plan, goal.read_bytes(), 15)
    assert {m.task for m in free_diff.moved} == {
        "SetPositionY",
        "DownlinkSat2Ground",
    }
    assert all("costs less" in m.why for m in free_diff.moved)
    _, kept, diff = fs.replan(problem, plan, goal.read_bytes(), 15, **settings)
    assert not diff.moved
    starts = kept.starts()
    assert (starts["SetPositionY"], starts["DownlinkSat2Ground"]) == (38, 39)
    assert kept.objective is not None and free.objective is not None
    assert kept.objective.delay_cost > free.objective.delay_cost
    if "stability" in settings:
        assert kept.objective.moves == 0


def test_replan_stability_matches_the_node() -> None:
    """Tests that an offline replan with lexicographic stability and a
    commit window gives the plan the node gives the same goal at the same
    time with the same settings (the engine, driven by the clock)."""
    from fsw_scheduler.engine.config import EngineConfig

    from .engine.driver import Driver, paper_goal

    settings: StabilitySettings = {
        "commit_window": 5,
        "stability": "lexicographic",
    }
    driver = Driver(config=EngineConfig(**settings))
    for now in range(16):
        driver.tick(now)
    driver.goal(paper_goal(), 15)
    problem, plan, goal = _paper_at_15()
    _, offline, _ = fs.replan(problem, plan, goal.read_bytes(), 15, **settings)
    assert offline.activities == driver.plan.activities
    assert offline.objective == driver.plan.objective


#: A mandatory goal task that needs the position at 37, which the planned
#: AcquisitionHF and SetPositionY hold in the replan at t=15.
SLEW_GOAL: dict[str, Any] = {
    "goal_id": "slew",
    "tasks": [
        {
            "id": "Slew",
            "length": 2,
            "delay_cost": 1,
            "schedule_cost": 0,
            "feasible_interval": [37, 37],
            "uses": {"position": 1},
        }
    ],
}


def test_replan_pins_that_leave_no_plan_degrade() -> None:
    """Tests that a commit window whose pins leave no plan (a mandatory
    goal task needs the position at 37, which the planned AcquisitionHF
    and SetPositionY hold) is released: the plan is degraded and its why
    names each broken pin, as the node's degraded path does; without the
    window the same goal just fits."""
    problem, plan, _ = _paper_at_15()
    goal = SLEW_GOAL
    _, free, _ = fs.replan(problem, plan, goal, 15)
    assert free.status.value == "optimal"
    _, pinned, diff = fs.replan(problem, plan, goal, 15, commit_window=30)
    assert pinned.status.value == "degraded"
    broken = {
        b.task: b.detail for b in pinned.why if b.cause == "commit_window"
    }
    assert broken
    assert all("commit window [15, 45)" in d for d in broken.values())
    assert pinned.starts()["Slew"] == 37
    moved = {m.task for m in diff.moved}
    assert set(broken) <= moved | set(pinned.unscheduled)


def test_a_degraded_replan_solves_again_in_what_is_left_of_its_limit() -> None:
    """Tests that the degraded path of an offline replan (the pins left no
    plan, so the problem is solved again without them) gets what is left
    of the limit, not the whole limit again: the limit bounds the whole
    answer, as the node's response deadline does. The solves are the real
    ones, recorded on their way."""
    from fsw_scheduler.api import ReplanSettings, replan_typed
    from fsw_scheduler.model.change import decode_change
    from fsw_scheduler.solving.solve import solve

    text, plan, _ = _paper_at_15()
    goal = decode_change(json.dumps(SLEW_GOAL))
    limits: list[float | None] = []

    def recorded(*args: Any, **kwargs: Any) -> Plan:
        limits.append(kwargs["time_limit"])
        return solve(*args, **kwargs)

    _, pinned, _ = replan_typed(
        decode_problem(text),
        plan,
        goal,
        15,
        time_limit=5.0,
        solve_fn=recorded,
        settings=ReplanSettings(commit_window=30),
    )
    assert pinned.status.value == "degraded"
    first, second = limits
    assert first == 5.0
    assert second is not None and second < 5.0


@pytest.mark.parametrize(
    ("settings", "field"),
    [
        ({"commit_window": -1}, "commit_window"),
        ({"stability": "strict"}, "stability"),
        ({"move_cost": 0}, "move_cost"),
        ({"move_cost": 1001}, "move_cost"),
    ],
)
def test_replan_settings_out_of_range_are_named(
    settings: dict[str, Any], field: str
) -> None:
    """Tests that a stability setting out of its range raises InputError
    naming it, before anything is solved."""
    # Any, not StabilitySettings: "strict" is outside Mode on purpose.
    problem, plan, goal = _paper_at_15()
    with pytest.raises(fs.InputError) as caught:
        fs.replan(problem, plan, goal.read_bytes(), 15, **settings)
    assert caught.value.issues[0].path == field
